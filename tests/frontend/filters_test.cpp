// Known-answer tests of the 5x5 filters and the descriptor.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "frontend/features.hpp"
#include "frontend/kernels.hpp"

namespace ovo::frontend {
namespace {

int at(const std::vector<std::uint8_t>& img, int w, int u, int v) { return img[v * w + u]; }
int at(const std::vector<std::int16_t>& img, int w, int u, int v) { return img[v * w + u]; }

TEST(Filters, RampGivesSlopePlus128InSobel) {
  // I = 5 u + 3 v: the separable Sobel sums to 128 per unit slope, so du = 133 and dv = 131.
  cv::Mat img(20, 24, CV_8UC1);
  for (int v = 0; v < img.rows; ++v)
    for (int u = 0; u < img.cols; ++u) img.at<std::uint8_t>(v, u) = 5 * u + 3 * v;
  FilterImages f;
  computeFilters(img, &f);
  EXPECT_EQ(at(f.du, f.width, 10, 10), 128 + 5);
  EXPECT_EQ(at(f.dv, f.width, 10, 10), 128 + 3);
  EXPECT_EQ(at(f.blob, f.width, 10, 10), 0);    // a plane has no blob...
  EXPECT_EQ(at(f.corner, f.width, 10, 10), 0);  // ...and no corner response
  // Border pixels are neutral.
  EXPECT_EQ(at(f.du, f.width, 1, 10), 128);
  EXPECT_EQ(at(f.blob, f.width, 10, 0), 0);
}

TEST(Filters, BlobKernelSumsToZeroOnConstantImage) {
  cv::Mat img(16, 16, CV_8UC1, cv::Scalar(200));
  FilterImages f;
  computeFilters(img, &f);
  for (int v = 2; v < 14; ++v) {
    for (int u = 2; u < 14; ++u) {
      ASSERT_EQ(at(f.blob, f.width, u, v), 0);
      ASSERT_EQ(at(f.corner, f.width, u, v), 0);
      ASSERT_EQ(at(f.du, f.width, u, v), 128);
      ASSERT_EQ(at(f.dv, f.width, u, v), 128);
    }
  }
}

TEST(Filters, ImpulseResponsesMatchHandComputedKernels) {
  cv::Mat img(21, 21, CV_8UC1, cv::Scalar(0));
  img.at<std::uint8_t>(10, 10) = 100;
  FilterImages f;
  computeFilters(img, &f);
  const int w = f.width;
  // Blob: centre +8, inner ring +1, outer ring -1.
  EXPECT_EQ(at(f.blob, w, 10, 10), 800);
  EXPECT_EQ(at(f.blob, w, 11, 9), 100);
  EXPECT_EQ(at(f.blob, w, 12, 10), -100);
  EXPECT_EQ(at(f.blob, w, 8, 12), -100);
  EXPECT_EQ(at(f.blob, w, 13, 10), 0);
  // Checkerboard: the response at (u, v) is K(10 - v, 10 - u) * 100.
  EXPECT_EQ(at(f.corner, w, 10, 10), 0);
  EXPECT_EQ(at(f.corner, w, 8, 8), -100);    // K(+2, +2) = -1
  EXPECT_EQ(at(f.corner, w, 12, 8), 100);    // K(+2, -2) = +1
  EXPECT_EQ(at(f.corner, w, 8, 12), 100);    // K(-2, +2) = +1
  EXPECT_EQ(at(f.corner, w, 11, 11), -100);  // K(-1, -1) = -1
  EXPECT_EQ(at(f.corner, w, 10, 8), 0);      // middle column
  // Sobel du at (9, 10): weight 6 * 2 = 12 -> 1200 >> 7 = 9; at (11, 10): -1200 >> 7 = -10.
  EXPECT_EQ(at(f.du, w, 9, 10), 137);
  EXPECT_EQ(at(f.du, w, 11, 10), 118);
  EXPECT_EQ(at(f.dv, w, 10, 9), 137);
  EXPECT_EQ(at(f.dv, w, 10, 11), 118);
  // du at (8, 9): column weight 4 (row offset +1), row weight 1 (column offset +2) -> 400 >> 7 = 3.
  EXPECT_EQ(at(f.du, w, 8, 9), 131);
}

TEST(Filters, AgreeWithOpenCvCorrelationOnRandomImage) {
  cv::Mat img(37, 53, CV_8UC1);
  cv::RNG rng(7);
  rng.fill(img, cv::RNG::UNIFORM, 0, 256);
  FilterImages f;
  computeFilters(img, &f);
  const float s[5] = {1, 4, 6, 4, 1}, g[5] = {-1, -2, 0, 2, 1};
  cv::Mat k_du(5, 5, CV_32F), k_dv(5, 5, CV_32F), k_blob(5, 5, CV_32F), k_corner(5, 5, CV_32F);
  const float a[5] = {-1, -1, 0, 1, 1}, b[5] = {1, 1, 0, -1, -1};
  for (int r = 0; r < 5; ++r) {
    for (int c = 0; c < 5; ++c) {
      k_du.at<float>(r, c) = s[r] * g[c];
      k_dv.at<float>(r, c) = g[r] * s[c];
      const bool outer = r == 0 || r == 4 || c == 0 || c == 4;
      k_blob.at<float>(r, c) = (r == 2 && c == 2) ? 8.f : (outer ? -1.f : 1.f);
      k_corner.at<float>(r, c) = b[r] * a[c];
    }
  }
  EXPECT_EQ(cv::sum(k_blob)[0], 0.0);
  cv::Mat img_f, du, dv, blob, corner;
  img.convertTo(img_f, CV_32F);
  cv::filter2D(img_f, du, CV_32F, k_du);
  cv::filter2D(img_f, dv, CV_32F, k_dv);
  cv::filter2D(img_f, blob, CV_32F, k_blob);
  cv::filter2D(img_f, corner, CV_32F, k_corner);
  const auto sobelByte = [](float x) {
    return std::clamp((static_cast<int>(x) >> 7) + 128, 0, 255);
  };
  for (int v = 2; v < img.rows - 2; ++v) {
    for (int u = 2; u < img.cols - 2; ++u) {
      ASSERT_EQ(at(f.du, f.width, u, v), sobelByte(du.at<float>(v, u))) << u << "," << v;
      ASSERT_EQ(at(f.dv, f.width, u, v), sobelByte(dv.at<float>(v, u))) << u << "," << v;
      ASSERT_EQ(at(f.blob, f.width, u, v), static_cast<int>(blob.at<float>(v, u)));
      ASSERT_EQ(at(f.corner, f.width, u, v), static_cast<int>(corner.at<float>(v, u)));
    }
  }
}

TEST(Filters, HalfResolutionAveragesTwoByTwo) {
  cv::Mat img = (cv::Mat_<std::uint8_t>(2, 4) << 0, 4, 10, 10, 8, 4, 10, 11);
  std::uint8_t out[2];
  kernels::halfResolution(img.data, 4, 2, static_cast<int>(img.step[0]), out);
  EXPECT_EQ(out[0], 4);   // (0 + 4 + 8 + 4) / 4
  EXPECT_EQ(out[1], 10);  // (10 + 10 + 10 + 11 + 2) >> 2
}

TEST(Descriptor, SamplesDuAndDvAtThePattern) {
  cv::Mat img(30, 30, CV_8UC1);
  for (int v = 0; v < 30; ++v)
    for (int u = 0; u < 30; ++u) img.at<std::uint8_t>(v, u) = 2 * u + v;
  FilterImages f;
  computeFilters(img, &f);
  std::uint8_t d[32];
  computeDescriptor(f, 15, 15, d);
  for (int k = 0; k < 16; ++k) {
    EXPECT_EQ(d[2 * k], 130);
    EXPECT_EQ(d[2 * k + 1], 129);
  }
  for (const auto& o : kDescriptorPattern) {
    EXPECT_LE(std::max(std::abs(o.du), std::abs(o.dv)), kernels::kDescriptorRadius);
  }
}

TEST(Descriptor, SadAndSsdCountEveryByte) {
  std::uint8_t a[32], b[32];
  for (int k = 0; k < 32; ++k) {
    a[k] = static_cast<std::uint8_t>(10 + k * 7);
    b[k] = static_cast<std::uint8_t>(10 + k * 7 + (k % 2 ? 3 : -2));
  }
  EXPECT_EQ(kernels::sad32(a, b), 16u * 3 + 16u * 2);
  EXPECT_EQ(kernels::ssd32(a, b), 16u * 9 + 16u * 4);
  EXPECT_EQ(kernels::sad32(a, a), 0u);
  b[0] = 250;
  EXPECT_GE(kernels::sad32(a, b), 240u);
}

}  // namespace
}  // namespace ovo::frontend
