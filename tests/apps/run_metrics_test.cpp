// metrics.json keys of `ovo run` computed from trajectories with known errors.
#include "apps/run_metrics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

namespace ovo::app {
namespace {

constexpr double kDeg = M_PI / 180.0;

// A straight drive along x at `step_m` per frame, 20 Hz.
Trajectory straightDrive(int frames, double step_m) {
  Trajectory t;
  for (int i = 0; i < frames; ++i) {
    SE3 T = SE3::Identity();
    T.translation() = Vec3(step_m * i, 0.0, 0.0);
    t.push_back({static_cast<Timestamp>(i) * 50'000'000, T});
  }
  return t;
}

// The same drive, but each frame's translation turned by `yaw_rad` in the body frame (a
// translation-direction error of exactly that angle, no rotation error).
Trajectory skewedDrive(int frames, double step_m, double yaw_rad) {
  Trajectory t;
  for (int i = 0; i < frames; ++i) {
    SE3 T = SE3::Identity();
    T.translation() = step_m * i * Vec3(std::cos(yaw_rad), std::sin(yaw_rad), 0.0);
    t.push_back({static_cast<Timestamp>(i) * 50'000'000, T});
  }
  return t;
}

TEST(RunMetrics, TranslationDirectionSpansFramesShorterThanTheMinimumMove) {
  // 4 cm per frame (0.8 m/s at 20 Hz): no single frame moves 5 cm, pairs of frames do.
  const Trajectory gt = straightDrive(40, 0.04);
  const Trajectory est = skewedDrive(40, 0.04, 2.0 * kDeg);
  const nlohmann::json m = computeRunMetrics(est, gt, {}, {}, 0.05);
  ASSERT_TRUE(m.contains("rpe_trans_dir_deg_median"));
  EXPECT_NEAR(m["rpe_trans_dir_deg_median"].get<double>(), 2.0, 1e-6);
  EXPECT_NEAR(m["rpe_rot_deg_per_frame_median"].get<double>(), 0.0, 1e-9);
}

TEST(RunMetrics, AteIsSplitAlongTrackLateralAndVertical) {
  // An L: 40 frames along x, a left turn in place, 40 frames along y. The estimate bows 1 cm to
  // the side of the drive (two periods a leg) and is right along it and in height: the error is
  // in the body's y on both legs, though it is world y on the first and world x on the second.
  Trajectory gt;
  for (int i = 0; i < 80; ++i) {
    SE3 T = SE3::Identity();
    if (i < 40) {
      T.translation() = Vec3(0.04 * i, 0.0, 0.0);
    } else {
      T.linear() = Eigen::AngleAxisd(M_PI / 2, Vec3::UnitZ()).toRotationMatrix();
      T.translation() = Vec3(0.04 * 39, 0.04 * (i - 39), 0.0);
    }
    gt.push_back({static_cast<Timestamp>(i) * 50'000'000, T});
  }
  Trajectory est = gt;
  for (std::size_t i = 0; i < est.size(); ++i)
    est[i].T_W_B.translation() +=
        gt[i].T_W_B.linear() * Vec3(0.0, 0.01 * std::sin(M_PI * static_cast<double>(i) / 10), 0.0);
  const nlohmann::json m = computeRunMetrics(est, gt, {}, {}, 0.05);
  ASSERT_TRUE(m.contains("ate_body_rmse_m"));
  const nlohmann::json& axes = m["ate_body_rmse_m"];
  const double ate = m["ate_rmse_m"].get<double>();
  EXPECT_GT(ate, 0.005);
  EXPECT_GT(axes["y"].get<double>(), 0.95 * ate);
  EXPECT_LT(axes["x"].get<double>(), 0.2 * ate);
  EXPECT_LT(axes["z"].get<double>(), 0.2 * ate);
}

TEST(RunMetrics, AnEstimateThatStandsStillGetsTheWorstDirectionError) {
  const Trajectory gt = straightDrive(20, 0.04);
  Trajectory est = gt;
  for (auto& p : est) p.T_W_B = SE3::Identity();
  const nlohmann::json m = computeRunMetrics(est, gt, {}, {}, 0.05);
  EXPECT_NEAR(m["rpe_trans_dir_deg_median"].get<double>(), 180.0, 1e-9);
}

TEST(RunMetrics, SegmentErrorsAtTheLengthsThePathReaches) {
  // 60 m at 5 cm a frame, 1 % too long: 10, 25 and 50 m segments, each about 1 % off.
  const Trajectory gt = straightDrive(1201, 0.05);
  const Trajectory est = straightDrive(1201, 0.0505);
  const nlohmann::json m = computeRunMetrics(est, gt, {}, {}, 0.05);
  ASSERT_TRUE(m.contains("segments"));
  const auto& seg = m["segments"];
  ASSERT_EQ(seg.size(), 3u);
  EXPECT_EQ(seg[0]["length_m"].get<double>(), 10.0);
  EXPECT_EQ(seg[2]["length_m"].get<double>(), 50.0);
  for (const auto& s : seg) {
    EXPECT_NEAR(s["trans_pct"].get<double>(), 1.0, 0.01);
    EXPECT_NEAR(s["rot_deg_per_100m"].get<double>(), 0.0, 1e-9);
    EXPECT_GT(s["count"].get<int>(), 0);
  }
}

TEST(RunMetrics, CostTrendComparesTheFirstAndTheLastTenth) {
  // 1000 frames: a frame costs 20 ms, a keyframe (every 5th) 60 ms at the start and 66 at the
  // end; 25 ms of CPU a frame; memory 100 MiB, 150 in the last tenth (a leak would look so).
  RunTiming t;
  for (std::size_t i = 0; i < 1000; ++i) {
    const bool late = i >= 900;
    const bool keyframe = i % 5 == 0;
    if (keyframe) {
      t.keyframe_ms.push_back(late ? 66.0 : 60.0);
      t.keyframe_frame.push_back(i);
    }
    t.total_ms.push_back(keyframe ? (late ? 66.0 : 60.0) : 20.0);
  }
  for (int k = 0; k <= 100; ++k)
    t.resources.push_back({0.5 * k, 10 * k, 0.025 * 10 * k, k * 10 >= 900 ? 150.0 : 100.0});
  const nlohmann::json trend = costTrend(t);
  ASSERT_FALSE(trend.is_null());
  EXPECT_EQ(trend["first"]["frames"][0].get<int>(), 50);  // after a 5 % warm-up
  EXPECT_EQ(trend["first"]["frames"][1].get<int>(), 150);
  EXPECT_EQ(trend["last"]["frames"][0].get<int>(), 900);
  EXPECT_NEAR(trend["first"]["frame_ms_median"].get<double>(), 20.0, 1e-9);
  EXPECT_NEAR(trend["first"]["keyframe_ms_median"].get<double>(), 60.0, 1e-9);
  EXPECT_NEAR(trend["last"]["keyframe_ms_median"].get<double>(), 66.0, 1e-9);
  EXPECT_NEAR(trend["first"]["cpu_ms_per_frame"].get<double>(), 25.0, 1e-9);
  EXPECT_NEAR(trend["ratio"]["frame_ms"].get<double>(), 1.0, 1e-9);
  EXPECT_NEAR(trend["ratio"]["keyframe_ms"].get<double>(), 1.1, 1e-9);
  EXPECT_NEAR(trend["ratio"]["cpu_per_frame"].get<double>(), 1.0, 1e-9);
  EXPECT_NEAR(trend["ratio"]["rss"].get<double>(), 1.5, 1e-9);
  // Too short a run for a trend, and metrics.json has none then.
  RunTiming short_run;
  short_run.total_ms.assign(100, 20.0);
  EXPECT_TRUE(costTrend(short_run).is_null());
  EXPECT_FALSE(computeRunMetrics({}, {}, {}, short_run)["timing"].contains("trend"));
  EXPECT_TRUE(computeRunMetrics({}, {}, {}, t)["timing"].contains("trend"));
}

TEST(RunMetrics, AStandstillGivesNoDirectionPairs) {
  const Trajectory gt = straightDrive(30, 0.0);
  const nlohmann::json m = computeRunMetrics(gt, gt, {}, {}, 0.05);
  EXPECT_FALSE(m.contains("rpe_trans_dir_deg_median"));
  EXPECT_TRUE(m.contains("rpe_rot_deg_per_frame_median"));
}

TEST(RunMetrics, TheEstimatorsCountersAreWrittenAsTheyAre) {
  const Trajectory gt = straightDrive(10, 0.04);
  estimator::EstimatorStats stats;
  stats.frames = 10;
  stats.keyframes = 4;
  stats.lidar_scale_frames = 7;
  stats.ground_scale_frames = 2;
  stats.lidar_keyframes = 3;
  stats.lidar_ranges = 41;
  const nlohmann::json m = computeRunMetrics(gt, gt, stats, {}, 0.05);
  EXPECT_EQ(m["frames"].get<int>(), 10);
  EXPECT_EQ(m["keyframes"].get<int>(), 4);
  EXPECT_EQ(m["lidar_scale_frames"].get<int>(), 7);
  EXPECT_EQ(m["ground_scale_frames"].get<int>(), 2);
  EXPECT_EQ(m["lidar_keyframes"].get<int>(), 3);
  EXPECT_EQ(m["lidar_ranges"].get<int>(), 41);
  EXPECT_FALSE(m.contains("refine"));  // no full refinement ran
}

// Issue 42: the LiDAR range factors' fit, in metres and in the range noise, over all keyframes and
// over the turning ones (residuals 3 and 4 cm over 2 ranges, 5 cm over 1 turning range).
TEST(RunMetrics, LidarResidualsAreWrittenAsRmsInMetresAndInTheRangeNoise) {
  const Trajectory gt = straightDrive(10, 0.04);
  estimator::EstimatorStats stats;
  estimator::LidarResidualStats r;
  r.range_sigma_m = 0.02;
  r.count = 2;
  r.sum_sq_m2 = 0.03 * 0.03 + 0.04 * 0.04;
  r.rejected = 3;
  r.turning_count = 1;
  r.turning_sum_sq_m2 = 0.05 * 0.05;
  r.turning_rejected = 1;
  stats.lidar_residuals = r;
  const nlohmann::json j = computeRunMetrics(gt, gt, stats, {}, 0.05)["lidar_residuals"];
  EXPECT_EQ(j["count"].get<int>(), 2);
  EXPECT_NEAR(j["rms_m"].get<double>(), std::sqrt(0.00125), 1e-12);
  EXPECT_NEAR(j["rms_sigmas"].get<double>(), std::sqrt(0.00125) / 0.02, 1e-9);
  EXPECT_DOUBLE_EQ(j["range_sigma_m"].get<double>(), 0.02);
  EXPECT_EQ(j["rejected"].get<int>(), 3);
  EXPECT_EQ(j["turning_count"].get<int>(), 1);
  EXPECT_NEAR(j["turning_rms_m"].get<double>(), 0.05, 1e-12);
  EXPECT_NEAR(j["turning_rms_sigmas"].get<double>(), 2.5, 1e-9);
  EXPECT_EQ(j["turning_rejected"].get<int>(), 1);
  EXPECT_GT(j["turning_deg_s"].get<double>(), 0.0);
  // Without LiDAR ranges (vo, kf, no scans) the key is left out.
  EXPECT_FALSE(computeRunMetrics(gt, gt, {}, {}, 0.05).contains("lidar_residuals"));
}

// Issue 43: the keyframes' cost where it is paid, the run's CPU and its peak memory.
TEST(RunMetrics, KeyframeCostCpuAndMemoryAreReported) {
  const Trajectory gt = straightDrive(10, 0.04);
  RunTiming timing;
  timing.estimator_ms = {1, 2, 40, 1, 2, 80, 1, 3, 60, 1};
  timing.keyframe_ms = {40, 80, 60, 120};  // percentiles interpolate linearly
  timing.cpu_s = 12.5;
  timing.peak_rss_mb = 250.0;
  timing.wall_s = 10.0;
  timing.sequence_s = 20.0;
  const nlohmann::json t = computeRunMetrics(gt, gt, {}, timing, 0.05)["timing"];
  EXPECT_DOUBLE_EQ(t["keyframe_ms_median"].get<double>(), 70.0);
  EXPECT_DOUBLE_EQ(t["keyframe_ms_p90"].get<double>(), 108.0);
  EXPECT_DOUBLE_EQ(t["keyframe_ms_max"].get<double>(), 120.0);
  EXPECT_DOUBLE_EQ(t["cpu_s"].get<double>(), 12.5);
  EXPECT_DOUBLE_EQ(t["peak_rss_mb"].get<double>(), 250.0);
  EXPECT_DOUBLE_EQ(t["realtime_factor"].get<double>(), 2.0);
  // An estimator without keyframes (vo, kf) and a timing not measured: the keys are left out.
  const nlohmann::json none = computeRunMetrics(gt, gt, {}, RunTiming{}, 0.05)["timing"];
  EXPECT_FALSE(none.contains("keyframe_ms_p90"));
  EXPECT_FALSE(none.contains("cpu_s"));
  EXPECT_FALSE(none.contains("peak_rss_mb"));
}

TEST(RunMetrics, AFullRefinementIsReportedWithItsSizeAndCosts) {
  const Trajectory gt = straightDrive(10, 0.04);
  estimator::EstimatorStats stats;
  estimator::RefineInfo r;
  r.usable = true;
  r.keyframes = 81;
  r.landmarks = 5258;
  r.bearing_factors = 17197;
  r.ground_factors = 286;
  r.removed_outliers = 13;
  r.passes = 2;
  r.iterations = 19;
  r.initial_cost = 112861.2;
  r.final_cost = 9966.5;
  r.message = "Function tolerance reached.";
  stats.refine = r;
  const nlohmann::json m = computeRunMetrics(gt, gt, stats, {}, 0.05);
  ASSERT_TRUE(m.contains("refine"));
  const nlohmann::json& j = m["refine"];
  EXPECT_TRUE(j["usable"].get<bool>());
  EXPECT_EQ(j["keyframes"].get<int>(), 81);
  EXPECT_EQ(j["landmarks"].get<int>(), 5258);
  EXPECT_EQ(j["bearing_factors"].get<int>(), 17197);
  EXPECT_EQ(j["lidar_factors"].get<int>(), 0);
  EXPECT_EQ(j["ground_factors"].get<int>(), 286);
  EXPECT_EQ(j["removed_outliers"].get<int>(), 13);
  EXPECT_EQ(j["passes"].get<int>(), 2);
  EXPECT_EQ(j["iterations"].get<int>(), 19);
  EXPECT_DOUBLE_EQ(j["initial_cost"].get<double>(), 112861.2);
  EXPECT_DOUBLE_EQ(j["final_cost"].get<double>(), 9966.5);
  EXPECT_EQ(j["message"].get<std::string>(), "Function tolerance reached.");

  // A failed batch has no finite costs to report: it says so instead of writing null.
  r.usable = false;
  r.final_cost = std::numeric_limits<double>::quiet_NaN();
  stats.refine = r;
  const nlohmann::json f = computeRunMetrics(gt, gt, stats, {}, 0.05)["refine"];
  EXPECT_FALSE(f["usable"].get<bool>());
  EXPECT_FALSE(f.contains("final_cost"));
}

}  // namespace
}  // namespace ovo::app
