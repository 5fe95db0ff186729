// Known-answer tests of two-view midpoint triangulation (frontend/triangulation.hpp).
#include "frontend/triangulation.hpp"

#include <gtest/gtest.h>

#include "common/so3.hpp"

namespace ovo::frontend {
namespace {

TEST(Triangulation, RecoversPointsAllAroundTheCameraWithPositiveDepths) {
  const Mat3 R = so3::exp(Vec3(0.05, -0.2, 0.1));
  const Vec3 t(0.3, 0.1, -0.4);
  // In front, beside (z = 0) and behind (z < 0) the previous camera.
  for (const Vec3& p_P : {Vec3(1, 2, 8), Vec3(-3, 0.5, 0.0), Vec3(2, -1, -5), Vec3(0.2, 0.1, -9)}) {
    const Vec3 p_C = R * p_P + t;
    const auto tp = triangulateMidpoint(R, t, p_P.normalized(), p_C.normalized());
    ASSERT_TRUE(tp.has_value());
    EXPECT_LT((tp->p_prev - p_P).norm(), 1e-9);
    EXPECT_NEAR(tp->depth_prev, p_P.norm(), 1e-9);
    EXPECT_NEAR(tp->depth_cur, p_C.norm(), 1e-9);
  }
}

TEST(Triangulation, ReportsNegativeDepthForAPointBehindBothRays) {
  const Mat3 R = Mat3::Identity();
  const Vec3 t(1.0, 0.0, 0.0);
  const Vec3 p_P(0.5, 0.0, 4.0);
  const Vec3 p_C = R * p_P + t;
  // Rays pointing away from the point: it lies at depth -|p| on both.
  const auto tp = triangulateMidpoint(R, t, -p_P.normalized(), -p_C.normalized());
  ASSERT_TRUE(tp.has_value());
  EXPECT_LT(tp->depth_prev, 0.0);
  EXPECT_LT(tp->depth_cur, 0.0);
  EXPECT_NEAR(tp->depth_prev, -p_P.norm(), 1e-9);
}

TEST(Triangulation, ParallelRaysHaveNoDepth) {
  const Vec3 b(0.0, 0.6, 0.8);
  EXPECT_FALSE(triangulateMidpoint(Mat3::Identity(), Vec3(1, 0, 0), b, b).has_value());
  EXPECT_FALSE(triangulateMidpoint(Mat3::Identity(), Vec3(1, 0, 0), b, Vec3::Zero()).has_value());
}

}  // namespace
}  // namespace ovo::frontend
