// Non-maximum suppression and feature extraction on images with planted blobs.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "frontend/features.hpp"

namespace ovo::frontend {
namespace {

struct Planted {
  int u, v;
  double amplitude;
};

cv::Mat plantBlobs(const std::vector<Planted>& blobs, int width, int height) {
  cv::Mat img(height, width, CV_32F, cv::Scalar(100));
  for (const auto& b : blobs) {
    for (int v = std::max(0, b.v - 6); v <= std::min(height - 1, b.v + 6); ++v) {
      for (int u = std::max(0, b.u - 6); u <= std::min(width - 1, b.u + 6); ++u) {
        const double r2 = (u - b.u) * (u - b.u) + (v - b.v) * (v - b.v);
        img.at<float>(v, u) += static_cast<float>(b.amplitude * std::exp(-r2 / (2 * 1.2 * 1.2)));
      }
    }
  }
  cv::Mat out;
  img.convertTo(out, CV_8U);
  return out;
}

TEST(Detection, FindsPlantedBrightAndDarkBlobsInTheirClass) {
  const std::vector<Planted> bright = {{40, 50, 90}, {121, 93, 90}, {170, 30, 90}};
  const std::vector<Planted> dark = {{80, 120, -90}, {30, 130, -90}};
  std::vector<Planted> all = bright;
  all.insert(all.end(), dark.begin(), dark.end());
  const cv::Mat img = plantBlobs(all, 200, 160);
  FeatureFrame frame;
  extractFeatures(img, DetectorOptions{}, cv::Mat(), &frame);

  // Each planted blob is a feature of its class at its centre, stronger than any other feature of
  // that class (the opposite-sign ring around a blob of the other polarity gives weaker ones).
  for (const auto& [planted, cls] :
       {std::pair{bright, FeatureClass::kBlobMax}, std::pair{dark, FeatureClass::kBlobMin}}) {
    int weakest_planted = 1 << 20, strongest_other = 0;
    int found = 0;
    for (const auto& f : frame.features) {
      if (f.cls != cls) continue;
      bool at_planted = false;
      for (const auto& p : planted) at_planted |= (f.u == p.u && f.v == p.v);
      if (at_planted) {
        ++found;
        weakest_planted = std::min(weakest_planted, std::abs(int(f.value)));
      } else {
        strongest_other = std::max(strongest_other, std::abs(int(f.value)));
      }
    }
    EXPECT_EQ(found, static_cast<int>(planted.size())) << "class " << int(cls);
    EXPECT_GT(weakest_planted, 2 * strongest_other) << "class " << int(cls);
  }
}

TEST(Detection, BlobPeakRefinementFindsSubPixelCentre) {
  // A Gaussian blob centred at (60.3, 40.0) on a flat background.
  cv::Mat img(100, 120, CV_32F, cv::Scalar(80));
  for (int v = 30; v <= 50; ++v)
    for (int u = 50; u <= 72; ++u) {
      const double r2 = (u - 60.3) * (u - 60.3) + (v - 40.0) * (v - 40.0);
      img.at<float>(v, u) += static_cast<float>(120 * std::exp(-r2 / (2 * 1.5 * 1.5)));
    }
  cv::Mat img8;
  img.convertTo(img8, CV_8U);
  FeatureFrame frame;
  extractFeatures(img8, DetectorOptions{}, cv::Mat(), &frame);
  int found = 0;
  for (int i = 0; i < frame.size(); ++i) {
    if (frame.features[i].cls != FeatureClass::kBlobMax) continue;
    const Vec2 px = frame.pixel(i, true);
    EXPECT_NEAR(px.x(), 60.3, 0.15);
    EXPECT_NEAR(px.y(), 40.0, 0.1);
    ++found;
  }
  EXPECT_EQ(found, 1);
}

TEST(Detection, ThresholdAndMarginAreRespected) {
  const cv::Mat img = plantBlobs({{40, 50, 3}, {5, 5, 90}, {100, 80, 90}}, 160, 120);
  FeatureFrame frame;
  DetectorOptions options;
  extractFeatures(img, options, cv::Mat(), &frame);
  for (const auto& f : frame.features) {
    EXPECT_GE(std::abs(f.value), options.nms_tau);
    EXPECT_GE(f.u, options.margin_px);
    EXPECT_GE(f.v, options.margin_px);
    EXPECT_LT(f.u, 160 - options.margin_px);
    EXPECT_LT(f.v, 120 - options.margin_px);
    EXPECT_FALSE(std::abs(f.u - 40) <= 2 && std::abs(f.v - 50) <= 2) << "weak blob detected";
  }
}

TEST(Detection, FeaturesAreGroupedByClassAndBin) {
  cv::Mat img(240, 320, CV_8UC1);
  cv::RNG rng(3);
  rng.fill(img, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(img, img, cv::Size(), 1.5);
  FeatureFrame frame;
  extractFeatures(img, DetectorOptions{}, cv::Mat(), &frame);
  ASSERT_GT(frame.size(), 100);
  for (int cls = 0; cls < kNumFeatureClasses; ++cls) {
    for (int row = 0; row < frame.bins_v; ++row) {
      const auto [b, e] = frame.binRange(cls, row, 0, frame.bins_u - 1);
      for (int i = b; i < e; ++i) {
        EXPECT_EQ(static_cast<int>(frame.features[i].cls), cls);
        EXPECT_EQ(frame.features[i].v / frame.bin_size, row);
      }
    }
  }
  EXPECT_EQ(frame.bin_begin.back(), frame.size());
}

TEST(Detection, MaskRemovesFeaturesOutsideIt) {
  cv::Mat img(240, 320, CV_8UC1);
  cv::RNG rng(4);
  rng.fill(img, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(img, img, cv::Size(), 1.5);
  cv::Mat mask(240, 320, CV_8UC1, cv::Scalar(0));
  cv::circle(mask, cv::Point(160, 120), 80, cv::Scalar(255), cv::FILLED);
  FeatureFrame frame;
  extractFeatures(img, DetectorOptions{}, mask, &frame);
  ASSERT_GT(frame.size(), 50);
  for (int i = 0; i < frame.size(); ++i) {
    EXPECT_LE((frame.pixel(i) - Vec2(160, 120)).norm(), 80.5);
  }
}

// The filtered NMS must keep exactly the pixels the definition names, with the raster tie rule.
TEST(Detection, NonMaximumSuppressionMatchesTheBruteForceDefinitionWithTies) {
  cv::Mat img(120, 160, CV_8UC1);
  cv::RNG rng(11);
  rng.fill(img, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(img, img, cv::Size(), 1.2);
  img = img / 16 * 16;  // coarse grey levels: many equal responses
  FilterImages f;
  computeFilters(img, &f);
  for (const auto& [n, n_sparse] : {std::pair{3, 6}, std::pair{5, 10}, std::pair{2, 9}}) {
    const int tau = 20, margin = 8;
    std::vector<kernels::RawFeature> got;
    kernels::nonMaximumSuppression(f.blob.data(), f.corner.data(), f.width, f.height, n, n_sparse,
                                   tau, margin, &got);
    std::vector<kernels::RawFeature> want;
    for (int v = margin; v < f.height - margin; ++v) {
      for (int u = margin; u < f.width - margin; ++u) {
        for (int cls = 0; cls < 4; ++cls) {
          const std::int16_t* r = cls < 2 ? f.blob.data() : f.corner.data();
          const bool is_max = (cls & 1) != 0;
          const int value = r[v * f.width + u];
          if (is_max ? value < tau : value > -tau) continue;
          if (!kernels::isExtremum(r, f.width, f.height, u, v, n, is_max)) continue;
          const bool sparse = kernels::isExtremum(r, f.width, f.height, u, v, n_sparse, is_max);
          want.push_back({static_cast<std::int16_t>(u), static_cast<std::int16_t>(v),
                          static_cast<std::int16_t>(value), static_cast<std::uint8_t>(cls),
                          static_cast<std::uint8_t>(sparse)});
        }
      }
    }
    ASSERT_GT(want.size(), 50u);
    ASSERT_EQ(got.size(), want.size()) << "n " << n;
    for (std::size_t k = 0; k < want.size(); ++k) {
      EXPECT_EQ(got[k].u, want[k].u);
      EXPECT_EQ(got[k].v, want[k].v);
      EXPECT_EQ(got[k].cls, want[k].cls);
      EXPECT_EQ(got[k].sparse, want[k].sparse)
          << "n " << n << " at " << got[k].u << ", " << got[k].v;
    }
  }
}

}  // namespace
}  // namespace ovo::frontend
