// Lucas-Kanade step refinement of a track (frontend/track_refine): known sub-pixel shifts of a
// smooth synthetic texture, a brightness offset, and the cases it must refuse.
#include "frontend/track_refine.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <opencv2/core.hpp>

namespace ovo::frontend {
namespace {

constexpr int kW = 96, kH = 80;

// Grey image of f(u, v) at the integer pixels, rounded to 8 bits.
cv::Mat render(const std::function<double(double, double)>& f) {
  cv::Mat img(kH, kW, CV_8UC1);
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW; ++u)
      img.at<std::uint8_t>(v, u) = cv::saturate_cast<std::uint8_t>(std::lround(f(u, v)));
  return img;
}

// Band-limited texture: sinusoids of wavelengths 7-19 px in four directions.
double texture(double x, double y) {
  return 128.0 + 30.0 * std::sin(0.9 * x + 0.3 * y + 0.4) + 25.0 * std::sin(-0.35 * x + 0.8 * y) +
         20.0 * std::sin(0.5 * x - 0.55 * y + 1.3) + 15.0 * std::sin(0.33 * x + 0.41 * y + 2.0);
}

TEST(TrackRefine, RecoversASubPixelShiftFromAnOffStart) {
  const Vec2 shift(0.37, -0.62);
  const cv::Mat prev = render(texture);
  const cv::Mat cur =
      render([&](double u, double v) { return texture(u - shift.x(), v - shift.y()); });
  const TrackStepRefiner refiner;
  for (const Vec2& x_prev : {Vec2(40.0, 30.0), Vec2(52.3, 41.7), Vec2(30.5, 50.25)}) {
    const Vec2 truth = x_prev + shift;
    // The descriptor match lands within half a pixel or so.
    const auto x = refiner.refine(prev, x_prev, cur, truth + Vec2(0.4, 0.3));
    ASSERT_TRUE(x.has_value());
    // Bilinear sampling of 8-bit wavelengths down to 7 px is good to ~0.04 px (measured).
    EXPECT_NEAR(x->x(), truth.x(), 0.05);
    EXPECT_NEAR(x->y(), truth.y(), 0.05);
  }
}

TEST(TrackRefine, IgnoresABrightnessOffset) {
  const Vec2 shift(-0.8, 0.15);
  const cv::Mat prev = render(texture);
  const cv::Mat cur =
      render([&](double u, double v) { return 20.0 + texture(u - shift.x(), v - shift.y()); });
  const Vec2 x_prev(45.2, 38.9), truth = x_prev + shift;
  const auto x = TrackStepRefiner().refine(prev, x_prev, cur, x_prev);
  ASSERT_TRUE(x.has_value());
  EXPECT_NEAR((*x - truth).norm(), 0.0, 0.06);
}

TEST(TrackRefine, GivesTheSameStepNextToTheRightEdge) {
  // Away from the right edge the patch rows are sampled whole, past the patch (zero weight); next
  // to it only the patch's own columns are read. Same images, cut just right of the patch.
  const Vec2 shift(0.45, 0.2);
  const cv::Mat prev = render(texture);
  const cv::Mat cur =
      render([&](double u, double v) { return texture(u - shift.x(), v - shift.y()); });
  const TrackStepRefiner refiner;
  const Vec2 x_prev(60.3, 40.6);
  const auto inside = refiner.refine(prev, x_prev, cur, x_prev + Vec2(0.1, 0.1));
  const cv::Range cols(0, 67);  // the 11x11 template of x_prev reaches column 66
  const auto at_edge =
      refiner.refine(prev.colRange(cols), x_prev, cur.colRange(cols), x_prev + Vec2(0.1, 0.1));
  ASSERT_TRUE(inside.has_value());
  ASSERT_TRUE(at_edge.has_value());
  EXPECT_NEAR((*inside - x_prev - shift).norm(), 0.0, 0.05);
  EXPECT_EQ(inside->x(), at_edge->x());
  EXPECT_EQ(inside->y(), at_edge->y());
  // One column less and the template leaves the image.
  EXPECT_FALSE(refiner.refine(prev.colRange(0, 66), x_prev, cur.colRange(0, 66), x_prev));
}

TEST(TrackRefine, RefusesFlatPatchesEdgesBordersAndFarMoves) {
  const TrackStepRefiner refiner;
  const cv::Mat flat(kH, kW, CV_8UC1, cv::Scalar(90));
  EXPECT_FALSE(refiner.refine(flat, Vec2(40, 40), flat, Vec2(40, 40)));
  // A straight edge fixes only the step across it (aperture problem).
  const auto edge = [](double u, double) { return 128.0 + 60.0 * std::tanh((u - 40.0) / 2.0); };
  const cv::Mat e = render(edge);
  EXPECT_FALSE(refiner.refine(e, Vec2(40.2, 40), e, Vec2(40.2, 40.5)));
  // The patch must lie inside both images.
  const cv::Mat t = render(texture);
  EXPECT_FALSE(refiner.refine(t, Vec2(2.0, 40.0), t, Vec2(2.0, 40.0)));
  EXPECT_FALSE(refiner.refine(t, Vec2(40.0, 40.0), t, Vec2(kW - 2.5, 40.0)));
  // A true step of 2.5 px from the start is beyond max_shift_px (1 px): refused, not followed.
  const cv::Mat moved = render([](double u, double v) { return texture(u - 2.5, v); });
  EXPECT_FALSE(refiner.refine(t, Vec2(40.0, 40.0), moved, Vec2(40.0, 40.0)));
  // ... and found with a wider bound.
  TrackRefineOptions wide;
  wide.max_shift_px = 4.0;
  const auto x = TrackStepRefiner(wide).refine(t, Vec2(40.0, 40.0), moved, Vec2(41.5, 40.0));
  ASSERT_TRUE(x.has_value());
  EXPECT_NEAR(x->x(), 42.5, 0.05);
}

}  // namespace
}  // namespace ovo::frontend
