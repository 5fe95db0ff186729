// Known-answer tests of the alignment and the metrics on synthetic trajectories.
#include "eval/metrics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "eval/align.hpp"
#include "tests/test_support.hpp"

namespace ovo::eval {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

Mat3 yaw(double rad) { return Eigen::AngleAxisd(rad, Vec3::UnitZ()).toRotationMatrix(); }

SE3 pose(const Mat3& R, const Vec3& p) {
  SE3 T = SE3::Identity();
  T.linear() = R;
  T.translation() = p;
  return T;
}

// A planar loop-ish path: 1 m steps, slowly turning left, 10 Hz.
Trajectory wigglyPath(std::size_t n) {
  Trajectory t;
  Vec3 p = Vec3::Zero();
  double heading = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    t.push_back({static_cast<Timestamp>(i) * 100'000'000, pose(yaw(heading), p)});
    heading += 0.02 + 0.01 * std::sin(0.1 * static_cast<double>(i));
    p += Vec3(std::cos(heading), std::sin(heading), 0.05 * std::sin(0.3 * static_cast<double>(i)));
  }
  return t;
}

TEST(Stats, MatchNumpyDefinitions) {
  const auto s = computeStats({4.0, 1.0, 3.0, 2.0});
  ASSERT_TRUE(s);
  EXPECT_DOUBLE_EQ(s->rmse, std::sqrt(7.5));
  EXPECT_DOUBLE_EQ(s->mean, 2.5);
  EXPECT_DOUBLE_EQ(s->median, 2.5);
  EXPECT_DOUBLE_EQ(s->std, std::sqrt(1.25));  // population std, as np.std
  EXPECT_DOUBLE_EQ(s->min, 1.0);
  EXPECT_DOUBLE_EQ(s->max, 4.0);
  EXPECT_DOUBLE_EQ(s->sse, 30.0);
  EXPECT_DOUBLE_EQ(computeStats({3.0, 1.0, 2.0})->median, 2.0);
  EXPECT_FALSE(computeStats({}));
}

TEST(Umeyama, RecoversAKnownSimilarity) {
  std::mt19937 rng(7);
  std::normal_distribution<double> g(0.0, 3.0);
  std::vector<Vec3> from, to;
  const Mat3 R = (Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized())).toRotationMatrix();
  const Vec3 t(4, -2, 1);
  const double s = 2.5;
  for (int i = 0; i < 50; ++i) {
    from.push_back(ovo::test::draw3(g, rng));
    to.push_back(s * R * from.back() + t);
  }
  const auto sim3 = umeyama(from, to, true);
  ASSERT_TRUE(sim3);
  EXPECT_NEAR((sim3->R - R).norm(), 0.0, 1e-12);
  EXPECT_NEAR((sim3->t - t).norm(), 0.0, 1e-12);
  EXPECT_NEAR(sim3->scale, s, 1e-12);
  const auto se3 = umeyama(from, to, false);
  ASSERT_TRUE(se3);
  EXPECT_DOUBLE_EQ(se3->scale, 1.0);
  EXPECT_NEAR((se3->R - R).norm(), 0.0, 1e-12);  // rotation is independent of the scale
}

TEST(Umeyama, ReflectionGuardKeepsAProperRotation) {
  // `to` is a mirror image of `from`: the best orthogonal map is a reflection, Umeyama's S
  // turns it into the best rotation (det +1).
  std::vector<Vec3> from = {{1, 0, 0}, {0, 2, 0}, {0, 0, 3}, {1, 1, 1}, {-2, 1, 0.5}};
  std::vector<Vec3> to;
  for (const auto& p : from) to.emplace_back(-p.x(), p.y(), p.z());
  const auto S = umeyama(from, to, false);
  ASSERT_TRUE(S);
  EXPECT_NEAR(S->R.determinant(), 1.0, 1e-12);
  EXPECT_NEAR((S->R.transpose() * S->R - Mat3::Identity()).norm(), 0.0, 1e-12);
}

TEST(Umeyama, RejectsDegenerateInput) {
  EXPECT_FALSE(umeyama({{0, 0, 0}, {1, 0, 0}}, {{0, 0, 0}, {1, 0, 0}}, false));  // < 3 points
  EXPECT_FALSE(umeyama({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}}, {{0, 0, 0}, {0, 1, 0}, {0, 2, 0}},
                       false));  // collinear: rotation about the line is free
  EXPECT_FALSE(umeyama({{1, 1, 1}, {1, 1, 1}, {1, 1, 1}}, {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, true));
  EXPECT_FALSE(umeyama({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 0, 0}, {1, 0, 0}}, false));
}

TEST(Ate, IsZeroForARigidlyMovedCopyAndNotWithoutAlignment) {
  const Trajectory ref = wigglyPath(200);
  const Similarity moved{yaw(0.5), Vec3(10, -3, 2), 1.0};
  const Trajectory est = transformed(ref, moved);
  const Associated pairs{ref, est};
  const auto se3 = computeAte(pairs, AlignMode::kSE3);
  ASSERT_TRUE(se3);
  EXPECT_LT(se3->trans_m.max, 1e-9);
  const auto none = computeAte(pairs, AlignMode::kNone);
  ASSERT_TRUE(none);
  EXPECT_GT(none->trans_m.rmse, 1.0);
}

TEST(Ate, Sim3RemovesAScaleErrorThatSe3Cannot) {
  const Trajectory ref = wigglyPath(200);
  const Trajectory est = transformed(ref, Similarity{yaw(-1.0), Vec3(1, 2, 3), 0.5});
  const Associated pairs{ref, est};
  const auto sim3 = computeAte(pairs, AlignMode::kSim3);
  const auto se3 = computeAte(pairs, AlignMode::kSE3);
  ASSERT_TRUE(sim3 && se3);
  EXPECT_LT(sim3->trans_m.max, 1e-9);
  EXPECT_NEAR(sim3->alignment.scale, 2.0, 1e-12);
  EXPECT_GT(se3->trans_m.rmse, 1.0);
  EXPECT_NEAR(*scaleErrorPct(pairs), -50.0, 1e-9);  // the estimate is half size
}

TEST(Ate, KnownOffsetGivesItsLength) {
  // Translation-only offset of half the points: no alignment, errors 0 and 2 m.
  Trajectory ref = wigglyPath(10);
  Trajectory est = ref;
  for (std::size_t i = 0; i < est.size(); i += 2) est[i].T_W_B.translation() += Vec3(0, 2, 0);
  const auto ate = computeAte(Associated{ref, est}, AlignMode::kNone);
  ASSERT_TRUE(ate);
  EXPECT_DOUBLE_EQ(ate->trans_m.max, 2.0);
  EXPECT_DOUBLE_EQ(ate->trans_m.min, 0.0);
  EXPECT_DOUBLE_EQ(ate->trans_m.rmse, std::sqrt(2.0));
}

TEST(Ate, ErrorsResolvedInTheReferenceBodyAxes) {
  // Each estimate pose 3 cm ahead, 2 cm to the right and 1 cm above the reference in the
  // reference's own body axes, on a turning path (the offset turns with the heading): no
  // alignment, the per-axis RMSEs are those offsets whatever the heading.
  const Trajectory ref = wigglyPath(50);
  Trajectory est = ref;
  const Vec3 offset_B(0.03, -0.02, 0.01);
  for (std::size_t i = 0; i < est.size(); ++i)
    est[i].T_W_B.translation() += ref[i].T_W_B.linear() * offset_B;
  const auto ate = computeAte(Associated{ref, est}, AlignMode::kNone);
  ASSERT_TRUE(ate);
  EXPECT_NEAR(ate->body_rmse_m.x(), 0.03, 1e-12);
  EXPECT_NEAR(ate->body_rmse_m.y(), 0.02, 1e-12);
  EXPECT_NEAR(ate->body_rmse_m.z(), 0.01, 1e-12);

  // With alignment and errors of every direction, the axes still split the ATE exactly.
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.05);
  for (auto& p : est) p.T_W_B.translation() += ovo::test::draw3(noise, rng);
  const auto se3 = computeAte(Associated{ref, est}, AlignMode::kSE3);
  ASSERT_TRUE(se3);
  EXPECT_NEAR(se3->body_rmse_m.squaredNorm(), se3->trans_m.rmse * se3->trans_m.rmse, 1e-12);
  EXPECT_GT(se3->body_rmse_m.minCoeff(), 0.03);  // the noise reaches every axis
}

Trajectory stamped(std::initializer_list<double> seconds) {
  Trajectory t;
  double x = 0.0;
  for (double s : seconds) t.push_back({fromSeconds(s), pose(Mat3::Identity(), Vec3(x++, 0, 0))});
  return t;
}

TEST(Association, NearestStampWithinMaxDiffFromTheShorterTrajectory) {
  const Trajectory ref = stamped({0.00, 0.10, 0.20, 0.30, 0.40, 0.50});
  const Trajectory est = stamped({0.011, 0.19, 0.35, 0.52});  // 0.35: 0.05 away, dropped
  const Associated pairs = associateByTime(ref, est, fromSeconds(0.02));
  ASSERT_EQ(pairs.size(), 3u);
  EXPECT_EQ(pairs.ref[0].t_ns, fromSeconds(0.0));
  EXPECT_EQ(pairs.est[0].t_ns, fromSeconds(0.011));
  EXPECT_EQ(pairs.ref[1].t_ns, fromSeconds(0.2));
  EXPECT_EQ(pairs.ref[2].t_ns, fromSeconds(0.5));
  EXPECT_EQ(pairs.est[2].t_ns, fromSeconds(0.52));
  // The result does not depend on which file is called the reference.
  const Associated swapped = associateByTime(est, ref, fromSeconds(0.02));
  ASSERT_EQ(swapped.size(), 3u);
  EXPECT_EQ(swapped.est[1].t_ns, fromSeconds(0.2));
}

TEST(Association, TieGoesToTheEarlierStamp) {
  const Trajectory ref = stamped({0.0, 0.1, 0.2, 0.3});
  const Trajectory est = stamped({0.15});
  const Associated pairs = associateByTime(ref, est, fromSeconds(0.05));
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(pairs.ref[0].t_ns, fromSeconds(0.1));
}

TEST(Association, ByIndexUsesTheCommonLength) {
  const Associated pairs = associateByIndex(wigglyPath(5), wigglyPath(7));
  EXPECT_EQ(pairs.size(), 5u);
}

TEST(RpePairs, FramesMetresAndSeconds) {
  // Straight line with 1 m steps at 10 Hz.
  Trajectory line;
  for (int i = 0; i < 11; ++i)
    line.push_back({i * 100'000'000LL, pose(Mat3::Identity(), Vec3(i, 0, 0))});
  using P = std::vector<std::pair<std::size_t, std::size_t>>;
  EXPECT_EQ(rpePairs(line, 4, DeltaUnit::kFrames), (P{{0, 4}, {4, 8}}));
  // Path: ids where the length since the previous id reaches 2.5 m: 3, 6, 9 (not 0, as evo).
  EXPECT_EQ(rpePairs(line, 2.5, DeltaUnit::kMeters), (P{{3, 6}, {6, 9}}));
  EXPECT_EQ(rpePairs(line, 3.0, DeltaUnit::kMeters), (P{{3, 6}, {6, 9}}));
  EXPECT_EQ(rpePairs(line, 0.25, DeltaUnit::kSeconds), (P{{3, 6}, {6, 9}}));
  EXPECT_TRUE(rpePairs(line, 20.0, DeltaUnit::kMeters).empty());
  EXPECT_TRUE(rpePairs(line, 0.0, DeltaUnit::kFrames).empty());
}

TEST(Rpe, ZeroForARigidlyMovedCopy) {
  const Trajectory ref = wigglyPath(100);
  const Trajectory est = transformed(ref, Similarity{yaw(2.0), Vec3(5, 5, 5), 1.0});
  const auto rpe = computeRpe(Associated{ref, est}, RpeOptions{5.0, DeltaUnit::kFrames, false});
  ASSERT_TRUE(rpe);
  EXPECT_EQ(rpe->id_pairs.size(), 19u);
  EXPECT_LT(rpe->trans.max, 1e-9);
  EXPECT_LT(rpe->rot.max, 1e-6);
}

TEST(Rpe, KnownScaleAndHeadingErrors) {
  // Straight line along x with 1 m steps; the estimate moves 1.5 m a step and turns 2 deg a
  // step more than the truth. Over 1 frame: translation error 0.5 m, rotation error 2 deg.
  Trajectory ref, est;
  for (int i = 0; i < 20; ++i) {
    ref.push_back({i * 100'000'000LL, pose(Mat3::Identity(), Vec3(i, 0, 0))});
    est.push_back({i * 100'000'000LL, pose(yaw(2.0 * kDeg * i), Vec3(1.5 * i, 0, 0))});
  }
  // In the estimate's frame i the step is R_i^T (1.5, 0, 0): rotate the positions so that
  // each step is along the estimate's own heading.
  Vec3 p = Vec3::Zero();
  for (int i = 0; i < 20; ++i) {
    est[i].T_W_B.translation() = p;
    p += est[i].T_W_B.linear() * Vec3(1.5, 0, 0);
  }
  const auto rpe = computeRpe(Associated{ref, est}, RpeOptions{1.0, DeltaUnit::kFrames, true});
  ASSERT_TRUE(rpe);
  EXPECT_EQ(rpe->id_pairs.size(), 19u);
  EXPECT_NEAR(rpe->trans.max, 0.5, 1e-12);
  EXPECT_NEAR(rpe->trans.min, 0.5, 1e-12);
  EXPECT_NEAR(rpe->rot.mean, 2.0, 1e-9);
}

TEST(Drift, OnePercentScaleOnALongStraightRun) {
  Trajectory ref, est;
  for (int i = 0; i <= 1000; ++i) {
    ref.push_back({i * 100'000'000LL, pose(Mat3::Identity(), Vec3(i, 0, 0))});
    est.push_back({i * 100'000'000LL, pose(Mat3::Identity(), Vec3(1.01 * i, 0, 0))});
  }
  const auto drift = kittiDrift(Associated{ref, est});
  ASSERT_TRUE(drift);
  EXPECT_TRUE(drift->full_lengths);
  // Segment L ends at the first frame beyond L: ref L+1 m, error 0.01 (L+1) m -> 1.01 (L+1)/L %.
  EXPECT_NEAR(drift->trans_pct, 1.0, 0.01);
  EXPECT_GT(drift->trans_pct, 1.0);
  EXPECT_NEAR(drift->rot_deg_per_m, 0.0, 1e-9);
}

TEST(Drift, ShortRunUsesFractionsOfItsLength) {
  Trajectory ref, est;
  for (int i = 0; i <= 100; ++i) {
    ref.push_back({i * 100'000'000LL, pose(Mat3::Identity(), Vec3(i, 0, 0))});
    est.push_back({i * 100'000'000LL, pose(Mat3::Identity(), Vec3(0.98 * i, 0, 0))});
  }
  const auto drift = kittiDrift(Associated{ref, est});
  ASSERT_TRUE(drift);
  EXPECT_FALSE(drift->full_lengths);
  EXPECT_GT(drift->segments, 8u);
  EXPECT_NEAR(drift->trans_pct, 2.0, 0.2);
}

// A straight drive along x at 5 cm a pose (20 Hz at 1 m/s), `n` poses.
Trajectory straightAlongX(int n, double scale = 1.0) {
  Trajectory t;
  for (int i = 0; i < n; ++i)
    t.push_back({i * 50'000'000LL, pose(Mat3::Identity(), Vec3(scale * 0.05 * i, 0, 0))});
  return t;
}

TEST(Segments, AScaleErrorIsTheTranslationErrorAtEveryLength) {
  // 2 % too long: a segment of reference length d (the first pose beyond L, so L < d <= L +
  // 5 cm) is 0.02 d too long, 2 d / L % of L; no rotation error.
  const Trajectory ref = straightAlongX(2000), est = straightAlongX(2000, 1.02);
  const auto seg = segmentErrors(Associated{ref, est});
  ASSERT_EQ(seg.size(), 3u);  // 99.95 m of path: no segment beyond 100 m
  const double lengths[] = {10.0, 25.0, 50.0};
  for (std::size_t k = 0; k < seg.size(); ++k) {
    const double L = lengths[k];
    EXPECT_EQ(seg[k].length_m, L);
    EXPECT_GE(seg[k].trans_pct, 2.0 - 1e-9) << L;
    EXPECT_LE(seg[k].trans_pct, 2.0 * (L + 0.05 + 1e-9) / L) << L;
    EXPECT_NEAR(seg[k].rot_deg_per_100m, 0.0, 1e-9) << L;
    // One segment from every 10th pose whose L of path is still ahead.
    EXPECT_EQ(seg[k].count, static_cast<std::size_t>((1999 - std::floor(L / 0.05)) / 10) + 1)
        << L;
  }
}

TEST(Segments, AHeadingThatCreepsIsTheRotationErrorPerHundredMetres) {
  // The estimate's heading turns 0.3 deg per metre driven more than the truth's: a segment of
  // length d has 0.3 d deg of rotation error, 30 d / L deg per 100 m.
  const Trajectory ref = straightAlongX(4200);
  Trajectory est = ref;
  for (std::size_t i = 0; i < est.size(); ++i)
    est[i].T_W_B.linear() = yaw(0.3 * kDeg * 0.05 * static_cast<double>(i));
  const auto seg = segmentErrors(Associated{ref, est}, {10.0, 100.0, 200.0, 300.0});
  ASSERT_EQ(seg.size(), 3u);
  for (const auto& s : seg) {
    EXPECT_GE(s.rot_deg_per_100m, 30.0 - 1e-9) << s.length_m;
    EXPECT_LE(s.rot_deg_per_100m, 30.0 * (s.length_m + 0.05 + 1e-9) / s.length_m) << s.length_m;
  }
  EXPECT_TRUE(segmentErrors(Associated{ref, est}, {}).empty());
  EXPECT_TRUE(segmentErrors(Associated{}, kSegmentLengthsM).empty());
}

TEST(DriftAlongPath, ZeroForAPerfectEstimateAndTheKnownErrorsOtherwise) {
  const Trajectory ref = straightAlongX(1200);  // 60 m
  const auto exact = driftAlongPath(Associated{ref, ref});
  ASSERT_TRUE(exact);
  ASSERT_EQ(exact->distance_m.size(), ref.size());
  EXPECT_NEAR(exact->distance_m.back(), 59.95, 1e-9);
  for (std::size_t i = 0; i < ref.size(); ++i) {
    EXPECT_NEAR(exact->pos_err_m[i], 0.0, 1e-12);
    EXPECT_NEAR(exact->yaw_err_deg[i], 0.0, 1e-12);
    if (exact->distance_m[i] < 25.0) {
      EXPECT_TRUE(std::isnan(exact->scale_err_pct[i]));
    }
  }
  EXPECT_NEAR(exact->scale_err_pct.back(), 0.0, 1e-9);

  // 3 % too long, and an estimate that starts elsewhere, turned by 40 deg: the first-pose
  // alignment takes that out; what is left is 0.03 d of position error and +3 % of scale.
  Trajectory est = straightAlongX(1200, 1.03);
  SE3 offset = pose(yaw(40.0 * kDeg), Vec3(5.0, -2.0, 1.0));
  for (auto& p : est) p.T_W_B = offset * p.T_W_B;
  // From 40 m on, the heading creeps by 0.5 deg per metre (positions kept).
  for (std::size_t i = 800; i < est.size(); ++i)
    est[i].T_W_B.linear() =
        yaw(40.0 * kDeg) * yaw(0.5 * kDeg * 0.05 * static_cast<double>(i - 800));
  const auto drift = driftAlongPath(Associated{ref, est});
  ASSERT_TRUE(drift);
  for (std::size_t i = 0; i < ref.size(); i += 100) {
    const double d = drift->distance_m[i];
    EXPECT_NEAR(drift->pos_err_m[i], 0.03 * d, 1e-9) << d;
    EXPECT_NEAR(drift->yaw_err_deg[i], i < 800 ? 0.0 : 0.5 * (d - 40.0), 1e-6) << d;
    if (d >= 26.0) {
      EXPECT_NEAR(drift->scale_err_pct[i], 3.0, 1e-6) << d;
    }
  }
}

TEST(FinalYaw, SignedHeadingErrorAboutUp) {
  Trajectory ref = wigglyPath(30);
  Trajectory est = ref;
  est.back().T_W_B.linear() = yaw(10.0 * kDeg) * est.back().T_W_B.linear();
  const Associated pairs{ref, est};
  const auto first = alignFirstPose(ref, est);
  ASSERT_TRUE(first);
  EXPECT_NEAR(*finalYawErrorDeg(pairs, *first), 10.0, 1e-9);
  // Seen with y up (e.g. a camera frame world), a yaw about z is no heading error.
  EXPECT_NEAR(*finalYawErrorDeg(pairs, *first, Vec3::UnitY()), 0.0, 1e-9);
  Associated flipped{ref, ref};
  flipped.est.back().T_W_B.linear() = yaw(-170.0 * kDeg) * ref.back().T_W_B.linear();
  EXPECT_NEAR(*finalYawErrorDeg(flipped, *first), -170.0, 1e-9);
}

}  // namespace
}  // namespace ovo::eval
