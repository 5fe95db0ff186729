#include "frontend/track_refine.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace ovo::frontend {

namespace {

constexpr int kMaxHalf = 7;
constexpr int kMaxSide = 2 * kMaxHalf + 3;  // the template keeps a one-pixel ring for gradients

// Bilinear samples of img on the (2h+1)^2 grid centred at (x, y); false if any leaves the image.
bool samplePatch(const cv::Mat& img, double x, double y, int h, float* out) {
  const double x0 = x - h, y0 = y - h;
  const int side = 2 * h + 1;
  if (!(x0 >= 0.0) || !(y0 >= 0.0) || !(x0 + side < img.cols) || !(y0 + side < img.rows))
    return false;
  const int ix = static_cast<int>(std::floor(x0)), iy = static_cast<int>(std::floor(y0));
  const float ax = static_cast<float>(x0 - ix), ay = static_cast<float>(y0 - iy);
  const float w00 = (1.f - ax) * (1.f - ay), w01 = ax * (1.f - ay), w10 = (1.f - ax) * ay,
              w11 = ax * ay;
  for (int r = 0; r < side; ++r) {
    const std::uint8_t* a = img.ptr<std::uint8_t>(iy + r) + ix;
    const std::uint8_t* b = img.ptr<std::uint8_t>(iy + r + 1) + ix;
    for (int c = 0; c < side; ++c)
      out[r * side + c] = w00 * a[c] + w01 * a[c + 1] + w10 * b[c] + w11 * b[c + 1];
  }
  return true;
}

}  // namespace

TrackStepRefiner::TrackStepRefiner(const TrackRefineOptions& options)
    : options_(options), half_(std::clamp(options.half_window_px, 1, kMaxHalf)) {
  const int side = 2 * half_ + 1;
  const double inv2s2 = 0.5 / (options_.sigma_px * options_.sigma_px);
  weight_.resize(static_cast<std::size_t>(side * side));
  double sum = 0.0;
  for (int r = 0; r < side; ++r) {
    for (int c = 0; c < side; ++c) {
      const double dx = c - half_, dy = r - half_;
      const double w = std::exp(-(dx * dx + dy * dy) * inv2s2);
      weight_[static_cast<std::size_t>(r * side + c)] = static_cast<float>(w);
      sum += static_cast<float>(w);
    }
  }
  weight_sum_ = static_cast<float>(sum);
}

std::optional<Vec2> TrackStepRefiner::refine(const cv::Mat& prev, const Vec2& x_prev,
                                             const cv::Mat& cur, const Vec2& x_cur) const {
  const TrackRefineOptions& o = options_;
  const int h = half_, side = 2 * h + 1, tside = side + 2, n = side * side;
  const float* w = weight_.data();
  const double sw = weight_sum_;
  std::array<float, kMaxSide * kMaxSide> tpl;
  std::array<float, (2 * kMaxHalf + 1) * (2 * kMaxHalf + 1)> gx, gy, t0, patch;
  if (!samplePatch(prev, x_prev.x(), x_prev.y(), h + 1, tpl.data())) return std::nullopt;

  // Template, its central-difference gradients on the inner grid, and their weighted means.
  double t_mean = 0.0, mgx = 0.0, mgy = 0.0;
  for (int r = 0; r < side; ++r) {
    for (int c = 0; c < side; ++c) {
      const int k = r * side + c, t = (r + 1) * tside + (c + 1);
      gx[k] = 0.5f * (tpl[t + 1] - tpl[t - 1]);
      gy[k] = 0.5f * (tpl[t + tside] - tpl[t - tside]);
      t0[k] = tpl[t];
      t_mean += w[k] * tpl[t];
      mgx += w[k] * gx[k];
      mgy += w[k] * gy[k];
    }
  }
  t_mean /= sw;
  mgx /= sw;
  mgy /= sw;
  // Brightness offset compensation: the gradients enter with their mean removed.
  double hxx = 0.0, hxy = 0.0, hyy = 0.0;
  for (int k = 0; k < n; ++k) {
    gx[k] -= static_cast<float>(mgx);
    gy[k] -= static_cast<float>(mgy);
    t0[k] -= static_cast<float>(t_mean);
    hxx += w[k] * gx[k] * gx[k];
    hxy += w[k] * gx[k] * gy[k];
    hyy += w[k] * gy[k] * gy[k];
  }
  const double tr = hxx + hyy, det = hxx * hyy - hxy * hxy;
  const double lambda_min = 0.5 * (tr - std::sqrt(std::max(0.0, tr * tr - 4.0 * det)));
  if (!(lambda_min >= o.min_gradient * o.min_gradient * sw)) return std::nullopt;

  Vec2 x = x_cur;
  for (int it = 0; it < o.max_iterations; ++it) {
    if (!samplePatch(cur, x.x(), x.y(), h, patch.data())) return std::nullopt;
    float p_mean = 0.f;
    for (int k = 0; k < n; ++k) p_mean += w[k] * patch[k];
    p_mean /= static_cast<float>(sw);
    float bx = 0.f, by = 0.f;
    for (int k = 0; k < n; ++k) {
      const float e = w[k] * ((patch[k] - p_mean) - t0[k]);
      bx += gx[k] * e;
      by += gy[k] * e;
    }
    // Inverse compositional step: the template moved by d matches, so the point moves by -d.
    const Vec2 d((hyy * bx - hxy * by) / det, (hxx * by - hxy * bx) / det);
    x -= d;
    if (!x.allFinite() || (x - x_cur).norm() > o.max_shift_px) return std::nullopt;
    if (d.squaredNorm() < 9e-4) return x;  // 0.03 px: bilinear sampling is good to ~0.04 px
  }
  return std::nullopt;
}

}  // namespace ovo::frontend
