// Known-answer tests of the essential-matrix geometry on the sphere (frontend/essential.hpp).
#include "frontend/essential.hpp"

#include <gtest/gtest.h>

#include <Eigen/SVD>

#include "common/so3.hpp"
#include "gpu/thread_pool.hpp"
#include "tests/gpu/two_view_scene.hpp"

namespace ovo::frontend {
namespace {

double rotationErrorRad(const Mat3& A, const Mat3& B) { return so3::angle(A.transpose() * B); }

test::TwoViewScene noiseFreeScene(int n, double max_off_axis_deg, std::uint64_t seed = 3) {
  test::TwoViewSceneOptions o;
  o.num_matches = n;
  o.outlier_ratio = 0.0;
  o.noise_px = 0.0;
  o.max_off_axis_deg = max_off_axis_deg;
  o.seed = seed;
  return test::makeTwoViewScene(o);
}

TEST(Essential, EightPointRecoversMotionFromNoiseFreeBearingsBeyond90Degrees) {
  const auto s = noiseFreeScene(60, 115.0);
  int backward = 0;
  for (const auto& b : s.b_prev) backward += b.z() < 0 ? 1 : 0;
  ASSERT_GT(backward, 5) << "the scene must contain rays beyond 90 degrees";

  const auto E = eightPoint(s.b_prev, s.b_cur);
  ASSERT_TRUE(E.has_value());
  int positive = 0;
  const auto m = selectByCheirality(*E, s.b_prev, s.b_cur, {}, &positive);
  ASSERT_TRUE(m.has_value());
  EXPECT_EQ(positive, 60);
  EXPECT_LT(rotationErrorRad(m->R_cur_prev, s.R_cur_prev), 1e-9);
  EXPECT_LT((m->t_cur_prev - s.t_cur_prev.normalized()).norm(), 1e-9);
}

TEST(Essential, MinimalEightPointIsExactOnNoiseFreeSample) {
  const auto s = noiseFreeScene(8, 110.0, 11);
  std::array<Vec3, 8> bp, bc;
  for (int i = 0; i < 8; ++i) {
    bp[i] = s.b_prev[i];
    bc[i] = s.b_cur[i];
  }
  const auto E = eightPointMinimal(bp, bc);
  ASSERT_TRUE(E.has_value());
  Mat3 E_true = essentialFromMotion(s.R_cur_prev, s.t_cur_prev.normalized());
  // Same matrix up to sign (both have singular values (1, 1, 0)).
  const double d = std::min((*E - E_true).norm(), (*E + E_true).norm());
  EXPECT_LT(d, 1e-9);
}

TEST(Essential, MinimalEightPointGivesAnEssentialMatrixForPureRotation) {
  test::TwoViewSceneOptions o;
  o.num_matches = 8;
  o.outlier_ratio = 0.0;
  o.noise_px = 0.0;
  o.t_cur_prev = Vec3::Zero();
  const auto s = test::makeTwoViewScene(o);
  std::array<Vec3, 8> bp, bc;
  for (int i = 0; i < 8; ++i) {
    bp[i] = s.b_prev[i];
    bc[i] = s.b_cur[i];
  }
  const auto E = eightPointMinimal(bp, bc);
  ASSERT_TRUE(E.has_value());  // rank-6 system: any [t]x R fits, one is returned
  for (int i = 0; i < 8; ++i) EXPECT_LT(sphereError(*E, bp[i], bc[i]), 1e-20);
}

TEST(Essential, ProjectionHasSingularValuesOneOneZero) {
  Mat3 M;
  M << 0.3, -1.2, 0.5, 0.9, 0.1, -0.4, 0.2, 0.7, 1.1;
  const auto E = projectToEssential(M);
  ASSERT_TRUE(E.has_value());
  const Vec3 s = Eigen::JacobiSVD<Mat3>(*E).singularValues();
  EXPECT_NEAR(s(0), 1.0, 1e-12);
  EXPECT_NEAR(s(1), 1.0, 1e-12);
  EXPECT_NEAR(s(2), 0.0, 1e-12);
  EXPECT_FALSE(projectToEssential(Mat3::Zero()).has_value());
}

// For each of the four decompositions of one E, a scene whose true motion is that candidate:
// points all around the camera (in front, behind, beside), so every sign case is exercised.
TEST(Essential, CheiralityPicksEachOfTheFourCandidates) {
  const Mat3 R0 = so3::exp(Vec3(0.1, 0.3, -0.2));
  const Vec3 t0 = Vec3(0.4, -0.3, 0.8).normalized();
  const Mat3 E = essentialFromMotion(R0, t0);
  const auto candidates = decomposeEssential(E);
  for (int k = 0; k < 4; ++k) {
    for (int j = 0; j < k; ++j)
      EXPECT_GT((candidates[k].R_cur_prev - candidates[j].R_cur_prev).norm() +
                    (candidates[k].t_cur_prev - candidates[j].t_cur_prev).norm(),
                0.1);
    test::TwoViewSceneOptions o;
    o.num_matches = 40;
    o.outlier_ratio = 0.0;
    o.noise_px = 0.0;
    o.max_off_axis_deg = 180.0;
    o.min_depth_m = 1.0;
    o.max_depth_m = 10.0;
    o.R_cur_prev = candidates[k].R_cur_prev;
    o.t_cur_prev = candidates[k].t_cur_prev;
    o.seed = 100 + k;
    const auto s = test::makeTwoViewScene(o);
    int behind = 0;
    for (const auto& b : s.b_cur) behind += b.z() < 0 ? 1 : 0;
    EXPECT_GT(behind, 5);
    // On one thread, and with the four candidates spread over the pool.
    auto pool_for = [](int n, const std::function<void(int, int)>& fn) {
      gpu::ThreadPool::shared().run(n, [&](int t) { fn(t, t + 1); });
    };
    for (const Mat3& E_signed : {E, Mat3(-E)})
      for (const ParallelFor& parallel_for : {ParallelFor{}, ParallelFor{pool_for}}) {
        int positive = -1;
        const auto m = selectByCheirality(E_signed, s.b_prev, s.b_cur, {}, &positive, parallel_for);
        ASSERT_TRUE(m.has_value());
        EXPECT_LT(rotationErrorRad(m->R_cur_prev, candidates[k].R_cur_prev), 1e-9) << "case " << k;
        EXPECT_LT((m->t_cur_prev - candidates[k].t_cur_prev).norm(), 1e-9) << "case " << k;
        EXPECT_GT(positive, 30) << "case " << k;
      }
  }
}

TEST(Essential, SphereErrorIsZeroOnTrueMatchesAndGrowsWithTheSquaredOffset) {
  const auto s = noiseFreeScene(20, 100.0, 5);
  const Mat3 E = essentialFromMotion(s.R_cur_prev, s.t_cur_prev.normalized());
  for (int i = 0; i < 20; ++i) {
    EXPECT_LT(sphereError(E, s.b_prev[i], s.b_cur[i]), 1e-24);
    // E b_prev is the normal of the epipolar plane in the current frame. Moving b_cur out of the
    // plane by delta costs, to first order, delta^2 |a|^2 / (|a|^2 + |c|^2) with a = E b_prev,
    // c = E^T b_cur: the optimal split of the correction over both bearings (delta^2 / 2 when
    // both bearings are equally far from their epipoles).
    const Vec3 a = E * s.b_prev[i], c = E.transpose() * s.b_cur[i];
    const Vec3 normal = a.normalized();
    const double share = a.squaredNorm() / (a.squaredNorm() + c.squaredNorm());
    double last = 0.0;
    for (double delta : {1e-4, 1e-3, 1e-2}) {
      const Vec3 b = std::cos(delta) * s.b_cur[i] + std::sin(delta) * normal;
      const double err = sphereError(E, s.b_prev[i], b);
      EXPECT_GT(err, last);
      last = err;
      EXPECT_NEAR(err / (delta * delta * share), 1.0, delta < 5e-3 ? 1e-3 : 3e-2)
          << "match " << i << " delta " << delta;
    }
    // Moving along the epipolar great circle keeps the error zero.
    const Vec3 along = s.b_cur[i].cross(normal).normalized();
    const Vec3 b_along = (std::cos(0.01) * s.b_cur[i] + std::sin(0.01) * along).normalized();
    EXPECT_LT(sphereError(E, s.b_prev[i], b_along), 1e-20);
  }
}

TEST(Essential, RotationOnlyRecoversPureRotation) {
  test::TwoViewSceneOptions o;
  o.num_matches = 30;
  o.outlier_ratio = 0.0;
  o.noise_px = 0.0;
  o.t_cur_prev = Vec3::Zero();
  const auto s = test::makeTwoViewScene(o);
  const auto R = rotationOnly(s.b_prev, s.b_cur, {});
  ASSERT_TRUE(R.has_value());
  EXPECT_LT(rotationErrorRad(*R, s.R_cur_prev), 1e-12);
}

TEST(Essential, RefinementLowersTheSphereCostOnNoisyMatches) {
  test::TwoViewSceneOptions o;
  o.num_matches = 300;
  o.outlier_ratio = 0.0;
  o.noise_px = 1.0;
  const auto s = test::makeTwoViewScene(o);
  const auto E = eightPoint(s.b_prev, s.b_cur);
  ASSERT_TRUE(E.has_value());
  const auto m0 = selectByCheirality(*E, s.b_prev, s.b_cur, {});
  ASSERT_TRUE(m0.has_value());
  const auto m1 = refineOnSphere(*m0, s.b_prev, s.b_cur, {}, 50);
  auto cost = [&](const RelativeMotion& m) {
    double c = 0;
    const Mat3 Em = essentialFromMotion(m.R_cur_prev, m.t_cur_prev);
    for (std::size_t i = 0; i < s.b_prev.size(); ++i) c += sphereError(Em, s.b_prev[i], s.b_cur[i]);
    return c;
  };
  const RelativeMotion truth{s.R_cur_prev, s.t_cur_prev.normalized()};
  EXPECT_LT(cost(m1), cost(*m0));
  EXPECT_LE(cost(m1), cost(truth));  // the minimum is at least as good as the truth
  // The same minimum when started from the truth.
  const auto m2 = refineOnSphere(truth, s.b_prev, s.b_cur, {}, 50);
  EXPECT_LT(rotationErrorRad(m1.R_cur_prev, m2.R_cur_prev), 1e-6);
  EXPECT_NEAR((m1.t_cur_prev).norm(), 1.0, 1e-12);
  // 300 matches at 1 px: statistical error well below these bounds.
  EXPECT_LT(rotationErrorRad(m1.R_cur_prev, s.R_cur_prev), 0.15 * M_PI / 180.0);
  EXPECT_LT(std::acos(std::min(1.0, m1.t_cur_prev.dot(s.t_cur_prev.normalized()))),
            2.0 * M_PI / 180.0);
}

TEST(Essential, RefinementOnThreadsGivesTheSameBitsAsOnOneThread) {
  test::TwoViewSceneOptions o;
  o.num_matches = 700;  // several reduction chunks, the last one partial
  o.outlier_ratio = 0.0;
  o.noise_px = 1.0;
  o.seed = 17;
  const auto s = test::makeTwoViewScene(o);
  RelativeMotion init{so3::exp(Vec3(0.003, -0.002, 0.001)) * s.R_cur_prev,
                      (s.t_cur_prev.normalized() + Vec3(0.02, -0.01, 0.0)).normalized()};
  std::vector<std::uint8_t> flags(s.b_prev.size(), 1);
  flags[5] = flags[300] = 0;
  const auto one = refineOnSphere(init, s.b_prev, s.b_cur, flags, 6, 1e-3);
  auto pool_for = [](int n, const std::function<void(int, int)>& fn) {
    gpu::ThreadPool::shared().run(n, [&](int t) { fn(t, t + 1); });
  };
  const auto many = refineOnSphere(init, s.b_prev, s.b_cur, flags, 6, 1e-3, pool_for);
  EXPECT_TRUE((one.R_cur_prev.array() == many.R_cur_prev.array()).all());
  EXPECT_TRUE((one.t_cur_prev.array() == many.t_cur_prev.array()).all());
  EXPECT_LT(rotationErrorRad(one.R_cur_prev, s.R_cur_prev),
            rotationErrorRad(init.R_cur_prev, s.R_cur_prev));
}

}  // namespace
}  // namespace ovo::frontend
