// Synthetic images for the frontend tests: a smooth random texture and exact sub-pixel shifts.
#pragma once

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace ovo::frontend::synth {

/// Smooth random texture (uniform noise blurred with a Gaussian of sigma_px), stretched to 0..255.
inline cv::Mat texture(int width, int height, int seed, double sigma_px = 2.0) {
  cv::Mat noise(height, width, CV_32F);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::Mat blurred, out;
  cv::GaussianBlur(noise, blurred, cv::Size(), sigma_px);
  cv::normalize(blurred, blurred, 0.0, 255.0, cv::NORM_MINMAX);
  blurred.convertTo(out, CV_8U);
  return out;
}

/// The image content moved by (du, dv) pixels: out(u + du, v + dv) = in(u, v).
inline cv::Mat shifted(const cv::Mat& in, double du, double dv) {
  const cv::Mat M = (cv::Mat_<double>(2, 3) << 1, 0, du, 0, 1, dv);
  cv::Mat out;
  cv::warpAffine(in, out, M, in.size(), cv::INTER_CUBIC, cv::BORDER_REFLECT);
  return out;
}

}  // namespace ovo::frontend::synth
