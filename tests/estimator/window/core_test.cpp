// The window core on synthetic tracked bearings, gyro and LiDAR (no images): known trajectories
// with known scale, standstill, gyro gaps, dropped frames, tracking loss and marginalisation.
#include "estimator/window/core.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <optional>
#include <random>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "common/so3.hpp"
#include "tests/estimator/window/synthetic.hpp"
#include "tests/test_support.hpp"

namespace ovo::estimator {
namespace {

using test::SyntheticOptions;

/// Seen by the simulator's camera (the RoMoVi fisheye's calib_results.txt, kept in the
/// repository).
test::SyntheticSequence makeSyntheticSequence(const SyntheticOptions& o) {
  return test::makeSyntheticSequence(o, test::sourcePath("configs/cameras/romovi_ocam.txt"));
}
using test::SyntheticSequence;

struct RunResult {
  Trajectory trajectory;
  std::vector<FrameEstimate> estimates;
  EstimatorStats stats;
};

RunResult run(const SyntheticSequence& seq, WindowOptions options = {}) {
  WindowCore core(seq.setup, options);
  RunResult r;
  const bool debug = std::getenv("OVO_WINDOW_DEBUG") != nullptr;
  test::feedSequence(seq, core, [&](std::size_t i, const FrameEstimate& e) {
    r.estimates.push_back(e);
    if (debug) {
      const SE3 T_true = seq.frames.front().T_W_B.inverse() * seq.frames[i].T_W_B;
      std::printf(
          "%3zu %-18s kf=%d lm=%zu nkf=%zu p=(%.3f %.3f %.3f) true=(%.3f %.3f %.3f) it=%d lid=%d\n",
          i, e.status.c_str(), e.is_keyframe, core.map().landmarks.size(),
          core.map().keyframes.size(), e.T_W_B.translation().x(), e.T_W_B.translation().y(),
          e.T_W_B.translation().z(), T_true.translation().x(), T_true.translation().y(),
          T_true.translation().z(), core.lastSolve().iterations, core.lastSolve().lidar_factors);
    }
  });
  r.trajectory = core.trajectory();
  r.stats = core.stats();
  return r;
}

/// Ground truth of frame i relative to the first frame (the estimator's W = B at frame 0).
SE3 truthRel(const SyntheticSequence& seq, std::size_t i) {
  return seq.frames.front().T_W_B.inverse() * seq.frames[i].T_W_B;
}

double pathLength(const SyntheticSequence& seq) {
  double len = 0.0;
  for (std::size_t i = 1; i < seq.frames.size(); ++i)
    len += (seq.frames[i].T_W_B.translation() - seq.frames[i - 1].T_W_B.translation()).norm();
  return len;
}

void expectAllFinite(const RunResult& r) {
  for (const auto& e : r.estimates) ASSERT_TRUE(allFinite(e.T_W_B)) << "t " << e.t_ns;
  for (const auto& p : r.trajectory) ASSERT_TRUE(allFinite(p.T_W_B)) << "t " << p.t_ns;
}

/// The drive of `o` with frames 60..71 (0.6 s) that the frontend could not track.
SyntheticSequence sequenceWithBlindStretch(const SyntheticOptions& o) {
  auto seq = makeSyntheticSequence(o);
  for (std::size_t i = 60; i < 72; ++i) seq.frames[i].visual.frontend_ok = false;
  return seq;
}

/// True when one of the run's notes contains `text`.
bool noted(const RunResult& r, std::string_view text) {
  return std::any_of(r.stats.notes.begin(), r.stats.notes.end(),
                     [&](const std::string& n) { return n.find(text) != std::string::npos; });
}

double maxStep(const Trajectory& traj) {
  double m = 0.0;
  for (std::size_t i = 1; i < traj.size(); ++i)
    m = std::max(m, (traj[i].T_W_B.translation() - traj[i - 1].T_W_B.translation()).norm());
  return m;
}

TEST(WindowCore, TracksADriveWithMetricScaleFromTheLidar) {
  SyntheticOptions o;
  const auto seq = makeSyntheticSequence(o);
  const auto r = run(seq);
  expectAllFinite(r);
  ASSERT_EQ(r.trajectory.size(), seq.frames.size());
  const double length = pathLength(seq);
  ASSERT_GT(length, 3.0);
  const SE3 T_true = truthRel(seq, seq.frames.size() - 1);
  const SE3 T_est = r.trajectory.back().T_W_B;
  const double scale = T_est.translation().norm() / T_true.translation().norm();
  EXPECT_NEAR(scale, 1.0, 0.03) << "final distance from the start, estimated / true";
  EXPECT_LT((T_est.translation() - T_true.translation()).norm(), 0.02 * length);
  EXPECT_LT(so3::angle(T_est.linear().transpose() * T_true.linear()) * 180.0 / M_PI, 0.5);
  EXPECT_GT(r.stats.keyframes, 5);
  EXPECT_GT(r.stats.lidar_scale_frames, 0);
  // Measured: all 14 keyframes with LiDAR ranges, 208 in all.
  EXPECT_GT(r.stats.lidar_keyframes, r.stats.keyframes * 8 / 10);
  EXPECT_GT(r.stats.lidar_ranges, 10 * r.stats.lidar_keyframes);
  EXPECT_GT(r.stats.frames_tracked, static_cast<int>(0.6 * seq.frames.size()));  // init: ~1.5 s
  // The range factors fit to the range noise: their residuals against the final landmarks are
  // of the order of the LiDAR's noise (a wrong pose, extrinsic or beam time gives decimetres).
  ASSERT_TRUE(r.stats.lidar_residuals.has_value());
  const auto& res = *r.stats.lidar_residuals;
  EXPECT_DOUBLE_EQ(res.range_sigma_m, seq.setup.lidar_range_sigma_m);
  // Measured: 84 range associations of 352 (the rest are ground-beam planes, not ranges).
  EXPECT_GT(res.count, 40);
  EXPECT_LE(res.count, r.stats.lidar_ranges);
  RecordProperty("lidar_rms_mm", std::to_string(1e3 * res.rmsM()));
  EXPECT_GT(res.rmsM(), 0.0);
  EXPECT_LT(res.rmsM(), 2.5 * res.range_sigma_m);
}

// The rig's camera height 3 cm short (0.97 m for the true 1.0 m; on rough ground the ground the
// camera sees sits off the height the rig gives): with estimate_camera_height the window
// estimates the correction from the LiDAR, and its final distance comes out nearer the truth than
// with the rig's height held. Measured: correction +2.86 cm, distance error 0.07 % against 0.68 %
// held.
TEST(WindowCore, EstimatesACorrectionOfTheRigsCameraHeight) {
  SyntheticOptions o;
  o.duration_s = 10.0;
  auto seq = makeSyntheticSequence(o);
  const double true_height = seq.setup.camera_height_m.value();
  seq.setup.camera_height_m = true_height - 0.03;
  const SE3 T_true = truthRel(seq, seq.frames.size() - 1);
  const auto distanceErr = [&](const RunResult& r) {
    return std::abs(r.trajectory.back().T_W_B.translation().norm() / T_true.translation().norm() -
                    1.0);
  };
  WindowOptions options;
  options.estimate_camera_height = true;
  const RunResult corrected = run(seq, options);
  const RunResult held = run(seq);  // the default: the rig's height
  expectAllFinite(corrected);
  ASSERT_TRUE(corrected.stats.camera_height_offset_m.has_value());
  EXPECT_FALSE(held.stats.camera_height_offset_m.has_value());
  RecordProperty("correction_cm", std::to_string(100.0 * *corrected.stats.camera_height_offset_m));
  RecordProperty("distance_err_pct", std::to_string(100.0 * distanceErr(corrected)));
  RecordProperty("distance_err_pct_held", std::to_string(100.0 * distanceErr(held)));
  EXPECT_GT(*corrected.stats.camera_height_offset_m, 0.015);
  EXPECT_LT(*corrected.stats.camera_height_offset_m, 0.045);
  EXPECT_LT(distanceErr(corrected), distanceErr(held));
}

// The camera height along the path with a rig whose height is 3 cm short (as above) and the
// sigma of a rough ground given (3 cm): the keyframes' corrections find the +3 cm that the ground
// shows, and the final distance comes out nearer the truth than with the rig's height held.
// Measured: the corrections' median +2.7 cm (the last keyframes, whose ground landmarks are not
// made yet, fall back towards 0 along the path), the distance error 0.16 % against 0.93 % held.
TEST(WindowCore, TheCameraHeightAlongThePathFindsARigHeightThatIsOff) {
  SyntheticOptions o;
  o.duration_s = 14.0;
  auto seq = makeSyntheticSequence(o);
  seq.setup.camera_height_m = seq.setup.camera_height_m.value() - 0.03;
  WindowOptions options;
  options.camera_height_path = true;
  options.camera_height_path_sigma_m = 0.03;
  WindowCore core(seq.setup, options);
  test::feedSequence(seq, core, [](std::size_t, const FrameEstimate&) {});
  const EstimatorStats stats = core.stats();
  ASSERT_EQ(stats.camera_height_path_m.size(), core.keyframes().size());
  ASSERT_GT(stats.camera_height_path_m.size(), 20u);
  // The keyframes after the start (3 keyframes) and before the end (5).
  std::vector<double> middle(stats.camera_height_path_m.begin() + 3,
                             stats.camera_height_path_m.end() - 5);
  std::nth_element(middle.begin(), middle.begin() + middle.size() / 2, middle.end());
  const double median = middle[middle.size() / 2];
  const SE3 T_true = truthRel(seq, seq.frames.size() - 1);
  const auto distanceErr = [&](const Trajectory& traj) {
    return std::abs(traj.back().T_W_B.translation().norm() / T_true.translation().norm() - 1.0);
  };
  const RunResult held = run(seq);
  RecordProperty("correction_median_cm", std::to_string(100.0 * median));
  RecordProperty("distance_err_pct", std::to_string(100.0 * distanceErr(core.trajectory())));
  RecordProperty("distance_err_pct_held", std::to_string(100.0 * distanceErr(held.trajectory)));
  EXPECT_NEAR(median, 0.03, 0.01);
  EXPECT_LT(distanceErr(core.trajectory()), 0.5 * distanceErr(held.trajectory));
}

// Its sigma estimated (the default): the synthetic ground is flat, its LiDAR's ground beams spread
// by their range noise alone, so the sigma stays at its floor (0.1 mm) and the corrections hold
// the rig's height; the trajectory is the held one's to a millimetre. Told that its LiDAR has no
// range noise (window.lidar_range_sigma_m 0.1 mm), the window reads the beams' 2.6 mm of spread as
// terrain: the sigma is what the scans say.
TEST(WindowCore, OnFlatGroundTheCameraHeightAlongThePathHoldsTheRigsHeight) {
  SyntheticOptions o;
  o.duration_s = 10.0;
  const auto seq = makeSyntheticSequence(o);
  WindowOptions options;
  options.camera_height_path = true;
  WindowCore core(seq.setup, options);
  test::feedSequence(seq, core, [](std::size_t, const FrameEstimate&) {});
  const EstimatorStats stats = core.stats();
  ASSERT_TRUE(stats.camera_height_path_sigma_m.has_value());
  EXPECT_LE(*stats.camera_height_path_sigma_m, 1e-3);
  ASSERT_GT(stats.camera_height_path_m.size(), 10u);
  for (const double c : stats.camera_height_path_m) EXPECT_LT(std::abs(c), 1e-3);
  const RunResult held = run(seq);
  const Trajectory& path = core.trajectory();
  ASSERT_EQ(path.size(), held.trajectory.size());
  const double apart =
      (path.back().T_W_B.translation() - held.trajectory.back().T_W_B.translation()).norm();
  RecordProperty("sigma_mm", std::to_string(1000.0 * *stats.camera_height_path_sigma_m));
  RecordProperty("end_apart_mm", std::to_string(1000.0 * apart));
  EXPECT_LT(apart, 1e-3);

  options.lidar_range_sigma_m = 1e-4;
  WindowCore noiseless(seq.setup, options);
  test::feedSequence(seq, noiseless, [](std::size_t, const FrameEstimate&) {});
  const auto sigma = noiseless.stats().camera_height_path_sigma_m;
  ASSERT_TRUE(sigma.has_value());
  RecordProperty("sigma_noiseless_mm", std::to_string(1000.0 * *sigma));
  EXPECT_GT(*sigma, 1.5e-3);
  EXPECT_LT(*sigma, 4e-3);
}

TEST(WindowCore, HoldsThePoseDuringAStandstill) {
  SyntheticOptions o;
  o.duration_s = 6.0;
  o.stop_from_s = 3.0;
  o.stop_to_s = 4.5;
  const auto seq = makeSyntheticSequence(o);
  const auto r = run(seq);
  expectAllFinite(r);
  std::vector<Vec3> held;
  for (std::size_t i = 0; i < seq.frames.size(); ++i) {
    const double t = toSeconds(seq.frames[i].t_ns);
    if (t > 3.1 && t < 4.4) held.push_back(r.estimates[i].T_W_B.translation());
  }
  ASSERT_GT(held.size(), 10u);
  for (const Vec3& p : held) EXPECT_LT((p - held.front()).norm(), 1e-3);
  int standstill = 0;
  for (const auto& e : r.estimates) standstill += e.status == "standstill";
  EXPECT_GT(standstill, 10);
}

TEST(WindowCore, TracksThatCreptDuringAStandstillRestartFromTheStillPose) {
  // While the robot stands, each frame's sub-pixel error adds up along the tracks: here every
  // track walks 0.1 px per still frame in its own direction (4 px over the stop; slow enough that
  // the standstill is still seen) and keeps that offset afterwards, so the window's landmarks no
  // longer fit when the robot drives on.
  SyntheticOptions o;
  o.duration_s = 8.0;
  o.stop_from_s = 3.0;
  o.stop_to_s = 5.0;
  auto seq = makeSyntheticSequence(o);
  std::map<TrackId, Vec2> offset;
  for (auto& f : seq.frames) {
    const double t = toSeconds(f.t_ns);
    for (auto& obs : f.visual.observations) {
      Vec2& d = offset.try_emplace(obs.track_id, Vec2::Zero()).first->second;
      if (t > 3.05 && t < 5.0) {
        const double a = 2.399963 * static_cast<double>(obs.track_id);  // golden-angle directions
        d += 0.1 * Vec2(std::cos(a), std::sin(a));
      }
      if (auto b = camera::unproject(seq.setup.camera, obs.px + d)) {
        obs.px += d;
        obs.bearing_C = *b;
      }
    }
  }
  const auto r = run(seq);
  expectAllFinite(r);
  EXPECT_TRUE(noted(r, "restarted from the last still frame"));
  EXPECT_LT(maxStep(r.trajectory), 0.1);
  // The new segment starts at the still pose, so the drive away from the stop is not lost.
  double worst_m = 0.0, worst_start_m = 0.0;
  for (std::size_t i = 0; i < seq.frames.size(); ++i) {
    const double t = toSeconds(seq.frames[i].t_ns);
    const double e = (r.trajectory[i].T_W_B.translation() - truthRel(seq, i).translation()).norm();
    if (t > 5.0 && t < 7.0) worst_m = std::max(worst_m, e);
    if (t > 5.0 && t < 6.0) worst_start_m = std::max(worst_start_m, e);
  }
  std::printf("largest position error in the 1 s / 2 s after the stop: %.3f / %.3f m\n",
              worst_start_m, worst_m);
  // 0.002 m over the first second; re-initialising 5 lost frames later from a guessed pose
  // instead gave 0.018 m.
  EXPECT_LT(worst_start_m, 0.006);
  // Over 2 s the new segment's scale adds to it: 0.015 m. The tracks keep their 4 px offsets,
  // which turn the rays to the far ground landmarks by ~0.75 deg; the LiDAR's ground planes
  // (window.lidar_ground_beams=plane, mm) hold those landmarks' depth against them (0.008 m with
  // the beams' raw ranges, window.lidar_ground_beams=raw).
  EXPECT_LT(worst_m, 0.02);
}

TEST(WindowCore, StandstillBeforeInitialisationMeasuresTheGyroBias) {
  SyntheticOptions o;
  o.duration_s = 2.5;
  o.start_hold_s = 1.0;
  const auto seq = makeSyntheticSequence(o);
  const auto r = run(seq);
  expectAllFinite(r);
  // The last held frame: ~0.95 s of still gyro, sigma = 1.7e-4 / sqrt(0.95 s) ~ 1.8e-4 rad/s.
  std::optional<Vec3> bias_still;
  for (std::size_t i = 0; i < seq.frames.size(); ++i)
    if (toSeconds(seq.frames[i].t_ns - seq.frames.front().t_ns) < 0.95 &&
        r.estimates[i].status == "standstill")
      bias_still = r.estimates[i].gyro_bias;
  ASSERT_TRUE(bias_still.has_value());
  EXPECT_LT((*bias_still - o.gyro_bias).norm(), 1e-3) << bias_still->transpose();
  EXPECT_TRUE(noted(r, "zero-rate"));
}

TEST(WindowCore, AGyroWithALargeBiasStillSeesTheStandstillAtTheStart) {
  // EuRoC's gyro reads 0.08 rad/s at rest. Before the bias is known the mean rate is the bias, so
  // a still robot counts as still by the samples' scatter alone (the mean rate test alone never
  // saw the stop, and the bias went unmeasured).
  SyntheticOptions o;
  o.duration_s = 2.5;
  o.start_hold_s = 1.0;
  o.gyro_bias = Vec3(0.01, -0.02, 0.08);
  const auto seq = makeSyntheticSequence(o);
  const auto r = run(seq);
  expectAllFinite(r);
  int still = 0;
  std::optional<Vec3> bias_still;
  for (std::size_t i = 0; i < seq.frames.size(); ++i)
    if (toSeconds(seq.frames[i].t_ns - seq.frames.front().t_ns) < 0.95 &&
        r.estimates[i].status == "standstill") {
      ++still;
      bias_still = r.estimates[i].gyro_bias;
    }
  EXPECT_GE(still, 15) << "of the 19 frames in the first 0.95 s";
  ASSERT_TRUE(bias_still.has_value());
  EXPECT_LT((*bias_still - o.gyro_bias).norm(), 1e-3) << bias_still->transpose();
}

TEST(WindowCore, GyroGapAndDroppedFramesKeepTheTrajectoryContinuous) {
  SyntheticOptions o;
  o.gyro_gap_from_s = 2.5;
  o.gyro_gap_to_s = 2.8;
  auto seq = makeSyntheticSequence(o);
  // Drop 6 camera frames (0.3 s) after the gap.
  seq.frames.erase(seq.frames.begin() + 70, seq.frames.begin() + 76);
  const auto r = run(seq);
  expectAllFinite(r);
  EXPECT_GE(r.stats.gyro_gaps, 1);
  EXPECT_LT(maxStep(r.trajectory), 0.8 * 0.35 + 0.05);  // at most the 0.35 s hole at 0.8 m/s
  const SE3 T_true = truthRel(seq, seq.frames.size() - 1);
  EXPECT_LT((r.trajectory.back().T_W_B.translation() - T_true.translation()).norm(),
            0.05 * pathLength(seq));
}

TEST(WindowCore, ALongCameraAndGyroGapDoesNotCoastOnTheLastVelocity) {
  // Every sensor stops for an hour (a camera unplugged, a stamp jump) while the robot is driving.
  // Nothing measures the motion over the gap: the prediction must not carry the last velocity
  // across it (0.8 m/s for an hour is 2.9 km; a stamp jump of centuries went to 1e10 m).
  SyntheticOptions o;
  auto seq = makeSyntheticSequence(o);
  const Timestamp gap_at = seq.frames[70].t_ns - 1;
  const Timestamp hour = 3600LL * 1000000000LL;
  for (auto& f : seq.frames)
    if (f.t_ns > gap_at) f.t_ns = f.visual.t_ns = f.t_ns + hour;
  for (auto& g : seq.imu)
    if (g.t_ns > gap_at) g.t_ns += hour;
  for (auto& l : seq.scans)
    if (l.t_ns > gap_at) l.t_ns += hour;
  const auto r = run(seq);
  expectAllFinite(r);
  EXPECT_GE(r.stats.gyro_gaps, 1);
  // At most 1 s at the last speed and the decay's 1 / ln 2 s after it (velocity_decay_per_s 0.5):
  // 2.44 s of driving, not an hour's.
  EXPECT_LT(maxStep(r.trajectory), (1.0 + 1.0 / std::log(2.0)) * o.speed_mps + 0.1);
}

TEST(WindowCore, BeamsUnderTheCanopyDoNotOutvoteTheGroundPlane) {
  // Seen by a pinhole camera (an ideal 640x480 one, narrower than the fisheye), few beams that
  // reach the ground land next to a track. At the initialisation of seeds 2 and 13, the beams that
  // pass under the canopy slab's lower edge land next to its features and outvote them with a
  // range ratio 2.3 times too large; only the ground plane and a beam or two disagree. When the
  // ground plane needed a group of min_associations / 2 on its side, both drives ended 2.2-2.3
  // times too far (5 m off after 4 m). 30 seeds now end within 2.1 % of the distance.
  for (const std::uint32_t seed : {2u, 13u}) {
    SCOPED_TRACE(seed);
    SyntheticOptions o;
    o.seed = seed;
    const auto seq = test::makeSyntheticSequence(o, {});  // no calibration file: the pinhole
    const auto r = run(seq);
    expectAllFinite(r);
    EXPECT_TRUE(noted(r, "put off"));
    const SE3 T_true = truthRel(seq, seq.frames.size() - 1);
    const SE3 T_est = r.trajectory.back().T_W_B;
    EXPECT_NEAR(T_est.translation().norm() / T_true.translation().norm(), 1.0, 0.03);
    EXPECT_LT((T_est.translation() - T_true.translation()).norm(), 0.03 * pathLength(seq));
    EXPECT_GT(r.stats.lidar_keyframes, 0);
  }
}

TEST(WindowCore, RecoversFromTrackingLossWithoutJumpingToTheOrigin) {
  SyntheticOptions o;
  o.duration_s = 7.0;
  const auto seq = sequenceWithBlindStretch(o);
  const auto r = run(seq);
  expectAllFinite(r);
  EXPECT_GE(r.stats.tracking_losses, 1);
  EXPECT_LT(maxStep(r.trajectory), 0.15);
  // Tracking comes back and the last poses are tracked again.
  EXPECT_TRUE(r.estimates.back().tracked);
  const SE3 T_true = truthRel(seq, seq.frames.size() - 1);
  EXPECT_LT((r.trajectory.back().T_W_B.translation() - T_true.translation()).norm(),
            0.1 * pathLength(seq));
}

TEST(WindowCore, ASegmentAfterALossStartsFromTheCarriedGyroBias) {
  SyntheticOptions o;
  o.duration_s = 7.0;
  const auto seq = sequenceWithBlindStretch(o);
  const auto r = run(seq);
  expectAllFinite(r);
  EXPECT_TRUE(noted(r, "carried over"));
  // The bias stays near the truth through the loss and the new segment's first solves.
  double worst = 0.0;
  for (std::size_t i = 50; i < r.estimates.size(); ++i)
    if (r.estimates[i].tracked)
      worst = std::max(worst, (r.estimates[i].gyro_bias - o.gyro_bias).norm());
  EXPECT_LT(worst, 1.5e-3) << "rad/s";
}

TEST(WindowCore, AStandstillAfterInitialisationMeasuresTheGyroBias) {
  // No hold at the start (the first keyframe's bias prior is the loose 0.02 rad/s), tracks that
  // creep 0.2 px per moving frame, a 2.5 s stop mid-way: its mean gyro rate becomes a zero-rate
  // factor on the keyframe before it.
  SyntheticOptions o;
  o.duration_s = 7.0;
  o.start_hold_s = 0.05;
  o.stop_from_s = 2.5;
  o.stop_to_s = 5.0;
  auto seq = makeSyntheticSequence(o);
  std::mt19937 rng(5);
  std::normal_distribution<double> step(0.0, 0.2);
  std::map<TrackId, Vec2> walk;
  for (auto& f : seq.frames) {
    const double t = toSeconds(f.t_ns - seq.frames.front().t_ns);
    const bool moving = t < o.stop_from_s || t > o.stop_to_s;
    for (auto& obs : f.visual.observations) {
      Vec2& d = walk.try_emplace(obs.track_id, Vec2::Zero()).first->second;
      if (moving) d += ovo::test::draw2(step, rng);
      if (auto b = camera::unproject(seq.setup.camera, obs.px + d)) {
        obs.px += d;
        obs.bearing_C = *b;
      }
    }
  }
  auto biasErrorAfterTheStop = [&](const WindowOptions& options) {
    const auto r = run(seq, options);
    expectAllFinite(r);
    double worst = 0.0;
    for (std::size_t i = 0; i < seq.frames.size(); ++i)
      if (toSeconds(seq.frames[i].t_ns - seq.frames.front().t_ns) > 5.5 && r.estimates[i].tracked)
        worst = std::max(worst, (r.estimates[i].gyro_bias - o.gyro_bias).norm());
    return std::make_pair(worst, noted(r, "zero-rate factor"));
  };
  const auto [with_zero_rate, noted_factor] = biasErrorAfterTheStop({});
  WindowOptions no_zero_rate;
  no_zero_rate.standstill_min_bias_s = 100.0;
  const auto [without, noted_without] = biasErrorAfterTheStop(no_zero_rate);
  std::printf("bias error after the stop: %.2e rad/s (without the zero-rate factor %.2e)\n",
              with_zero_rate, without);
  EXPECT_TRUE(noted_factor);
  EXPECT_FALSE(noted_without);
  // 2.2 s of still gyro: sigma 1.7e-4 / sqrt(2.2) = 1.1e-4 rad/s per axis (measured: 3.4e-4
  // with the factor, 4.4e-4 without).
  EXPECT_LT(with_zero_rate, 4e-4);
  EXPECT_LT(with_zero_rate, 0.85 * without);
}

TEST(WindowCore, AStopKeepsTheLastMillimetresOfTheSlowDown) {
  // The robot drives straight, slows over 1 s and stands from 4 s to the end; its features are
  // as sharp as the rendered rows' (0.05 px). Its last frames before the stop move it less than
  // the standstill detector's flow threshold (0.3 px). Held from the first still frame, the pose
  // stays short of where the robot stands by those frames' motion (measured: 5.1 mm); placed
  // against the landmarks for the first standstill_settle_s, it reaches it (0.05 mm). On the
  // rendered rows the hold lost 2-4 mm at each stop.
  SyntheticOptions o;
  o.duration_s = 6.0;
  o.stop_from_s = 4.0;
  o.stop_to_s = 100.0;
  o.pixel_sigma = 0.05;
  o.yaw_amplitude_deg = 0.0;
  const auto seq = makeSyntheticSequence(o);
  // Along-track error of the held pose: the displacement from a frame in the slow-down (3.5 s,
  // 0.2 m before the stop) to the last frame, estimated against true.
  auto shortfall = [&](const WindowOptions& options) {
    const auto r = run(seq, options);
    expectAllFinite(r);
    std::size_t before = 0;
    while (toSeconds(seq.frames[before].t_ns - seq.frames.front().t_ns) < 3.5) ++before;
    const std::size_t last = seq.frames.size() - 1;
    EXPECT_EQ(r.estimates[last].status, "standstill");
    const Vec3 est =
        r.trajectory[last].T_W_B.translation() - r.trajectory[before].T_W_B.translation();
    const Vec3 truth = truthRel(seq, last).translation() - truthRel(seq, before).translation();
    return truth.norm() - est.dot(truth.normalized());
  };
  WindowOptions settle;
  const double settled = shortfall(settle);
  WindowOptions hold = settle;
  hold.standstill_settle_s = 0.0;
  const double held = shortfall(hold);
  std::printf("short of the stop by %.2f mm placed against the landmarks, %.2f mm held\n",
              1e3 * settled, 1e3 * held);
  EXPECT_GT(held, 3e-3);  // the creep below the threshold is lost
  EXPECT_LT(std::abs(settled), 1e-3);
}

TEST(WindowCore, MarginalizationDoesNotMoveTheWindow) {
  SyntheticOptions o;
  o.duration_s = 7.0;
  const auto seq = makeSyntheticSequence(o);
  WindowOptions options;
  options.window_size = 4;
  WindowCore core(seq.setup, options);
  int marginalizations = 0;
  double max_jump = 0.0;
  std::map<int, SE3> before;
  int front_id = -1;
  test::feedSequence(seq, core, [&](std::size_t, const FrameEstimate&) {
    const auto& kfs = core.map().keyframes;
    if (kfs.empty()) return;
    if (front_id >= 0 && kfs.front()->id != front_id) {
      ++marginalizations;
      const auto it = before.find(kfs.front()->id);
      if (it != before.end())
        max_jump = std::max(max_jump,
                            (kfs.front()->pose().translation() - it->second.translation()).norm());
    }
    front_id = kfs.front()->id;
    before.clear();
    for (const auto& kf : kfs) before[kf->id] = kf->pose();
  });
  EXPECT_GT(marginalizations, 3);
  EXPECT_LT(max_jump, 0.01) << "the new first keyframe moved after marginalising the old one";
}

TEST(WindowCore, WithoutLidarFallsBackToTheGroundPlaneAndSaysSo) {
  SyntheticOptions o;
  const auto seq = makeSyntheticSequence(o);
  WindowOptions options;
  options.use_lidar = false;
  const auto r = run(seq, options);
  expectAllFinite(r);
  ASSERT_FALSE(r.stats.notes.empty());
  EXPECT_NE(r.stats.notes.front().find("ground-plane"), std::string::npos);
  EXPECT_EQ(r.stats.lidar_scale_frames, 0);
  EXPECT_EQ(r.stats.lidar_keyframes, 0);
  EXPECT_EQ(r.stats.lidar_ranges, 0);
  const SE3 T_true = truthRel(seq, seq.frames.size() - 1);
  const double scale = r.trajectory.back().T_W_B.translation().norm() / T_true.translation().norm();
  EXPECT_NEAR(scale, 1.0, 0.15);
}

// Keyframes by track loss alone: the parallax trigger off, a tenth of the tracks lost makes one;
// a frame between scans waits until fewer than `between_scans` live (0.9: no wait). Scans only at
// their own frame's time (no older scan moved to a keyframe between scans).
WindowOptions trackLossKeyframes(double between_scans) {
  WindowOptions o;
  o.lidar_scan_max_age_s = 0.0;
  o.kf_parallax_deg = 90.0;
  o.kf_track_fraction = 0.9;
  o.kf_track_fraction_between_scans = between_scans;
  return o;
}

// The LiDAR scans every second frame. Keyframes that track loss triggers land on a frame with a
// scan: one between scans waits for the next frame, which brings one. Without that wait, half of
// them had no scan (and so no LiDAR range) on the simulated rows, where the canopy's tracks end
// fast.
TEST(WindowCore, KeyframesWaitForTheNextScanWhenTracksRunOut) {
  SyntheticOptions o;
  o.duration_s = 8.0;
  const auto seq = makeSyntheticSequence(o);
  std::set<Timestamp> scan_times;
  for (const LidarScan& s : seq.scans) scan_times.insert(s.t_ns);
  const auto fractionWithScan = [&](const RunResult& r) {
    int kfs = 0, with_scan = 0;
    for (const FrameEstimate& e : r.estimates) {
      if (!e.is_keyframe) continue;
      ++kfs;
      with_scan += scan_times.count(e.t_ns) > 0;
    }
    return kfs > 0 ? static_cast<double>(with_scan) / kfs : 0.0;
  };
  const RunResult waiting = run(seq, trackLossKeyframes(0.8)),
                  not_waiting = run(seq, trackLossKeyframes(0.9));
  expectAllFinite(waiting);
  std::printf("keyframes on a frame with a scan: %.2f waiting, %.2f not\n",
              fractionWithScan(waiting), fractionWithScan(not_waiting));
  EXPECT_GT(waiting.stats.keyframes, 10);
  EXPECT_GT(fractionWithScan(waiting), 0.9);
  EXPECT_LT(fractionWithScan(not_waiting), 0.8);
  // Keyframes without a scan have no LiDAR range.
  const auto withRanges = [](const RunResult& r) {
    return static_cast<double>(r.stats.lidar_keyframes) / r.stats.keyframes;
  };
  std::printf("keyframes with LiDAR ranges: %.2f waiting, %.2f not\n", withRanges(waiting),
              withRanges(not_waiting));
  EXPECT_GT(withRanges(waiting), withRanges(not_waiting) + 0.2);
}

// A LiDAR out of step with the camera (every scan half a frame after a frame): no frame has a
// scan or precedes one, so no frame waits and the keyframes are those without the wait.
TEST(WindowCore, NoKeyframeWaitsForALidarOutOfStepWithTheCamera) {
  SyntheticOptions o;
  o.duration_s = 8.0;
  o.lidar_delay_s = 0.025;
  const auto seq = makeSyntheticSequence(o);
  const RunResult waiting = run(seq, trackLossKeyframes(0.8)),
                  not_waiting = run(seq, trackLossKeyframes(0.9));
  const auto keyframeTimes = [](const RunResult& r) {
    std::vector<Timestamp> t;
    for (const FrameEstimate& e : r.estimates)
      if (e.is_keyframe) t.push_back(e.t_ns);
    return t;
  };
  EXPECT_GT(waiting.stats.keyframes, 10);
  EXPECT_EQ(keyframeTimes(waiting), keyframeTimes(not_waiting));
}

// A LiDAR out of step with the camera: each scan 30 ms after a frame, so none belongs to a frame,
// and the LiDAR is the only scale (no camera height). A keyframe takes the latest scan up to
// lidar_scan_max_age_s (50 ms) older: here 20 ms, for keyframes on odd frames. On this 4 m
// sequence the LiDAR's scale is good to about 1 %, in step or not, and which keyframes fall on odd
// frames depends on the noise; so the test runs eight seeds and bounds each and their median.
// Measured over 24 seeds: |scale - 1| median 0.66 %, at most 2.2 % (a LiDAR in step: 0.52 %,
// 2.1 %); the median of eight seeds 0.27-0.96 %; LiDAR on 30-46 % of the keyframes of eight seeds
// (9-70 % on one).
TEST(WindowCore, ALidarOutOfStepWithTheCameraStillGivesTheScale) {
  std::vector<double> scale_errors;
  int lidar_keyframes = 0, keyframes = 0;
  for (std::uint32_t seed = 1; seed <= 8; ++seed) {
    SyntheticOptions o;
    o.lidar_delay_s = 0.03;
    o.seed = seed;
    auto seq = makeSyntheticSequence(o);
    seq.setup.camera_height_m.reset();
    const auto r = run(seq);
    expectAllFinite(r);
    const SE3 T_true = truthRel(seq, seq.frames.size() - 1);
    const SE3 T_est = r.trajectory.back().T_W_B;
    const double scale = T_est.translation().norm() / T_true.translation().norm();
    EXPECT_NEAR(scale, 1.0, 0.03) << "seed " << seed << ": final distance, estimated / true";
    EXPECT_GE(r.stats.lidar_keyframes, 1) << "seed " << seed;
    scale_errors.push_back(std::abs(scale - 1.0));
    lidar_keyframes += r.stats.lidar_keyframes;
    keyframes += r.stats.keyframes;
    // Only scans at the frames' own times: the LiDAR goes unused and the scale is a guess.
    WindowOptions only_own_time;
    only_own_time.lidar_scan_max_age_s = 0.0;
    EXPECT_EQ(run(seq, only_own_time).stats.lidar_keyframes, 0) << "seed " << seed;
  }
  std::nth_element(scale_errors.begin(), scale_errors.begin() + 4, scale_errors.end());
  EXPECT_LT(scale_errors[4], 0.015) << "median |scale - 1| over the seeds";
  EXPECT_GE(lidar_keyframes, keyframes / 5) << lidar_keyframes << " of " << keyframes;
}

// Where a keyframe's older scan was taken: its LiDAR pose in the keyframe's body frame is the
// rig's T_B_L moved back by the motion over the 20 ms (1.6 cm at 0.8 m/s), within a few mm.
TEST(WindowCore, AnOlderScanIsPlacedWhereTheLidarWasWhenItTookIt) {
  SyntheticOptions o;
  o.lidar_delay_s = 0.03;
  const auto seq = makeSyntheticSequence(o);
  WindowCore core(seq.setup, WindowOptions{});
  std::map<Timestamp, SE3> truth;
  for (const auto& f : seq.frames) truth[f.t_ns] = f.T_W_B;
  test::feedSequence(seq, core, [](std::size_t, const FrameEstimate&) {});
  int checked = 0;
  for (const auto& kf : core.map().keyframes) {
    if (!kf->scan || kf->scan->t_ns == kf->t_ns) continue;
    // The true body pose at the scan, between the frames around it (translation linear, the
    // yaw weave's rotation by slerp).
    const auto after = truth.lower_bound(kf->scan->t_ns), before = std::prev(after);
    const double a = static_cast<double>(kf->scan->t_ns - before->first) /
                     static_cast<double>(after->first - before->first);
    SE3 T_W_Bs = SE3::Identity();
    T_W_Bs.translation() =
        (1.0 - a) * before->second.translation() + a * after->second.translation();
    T_W_Bs.linear() = Eigen::Quaterniond(before->second.linear())
                          .slerp(a, Eigen::Quaterniond(after->second.linear()))
                          .toRotationMatrix();
    const SE3 expected = truth.at(kf->t_ns).inverse() * T_W_Bs * seq.setup.T_B_L;
    const double moved = (seq.setup.T_B_L.translation() - expected.translation()).norm();
    EXPECT_LT((kf->T_B_L.translation() - expected.translation()).norm(), 0.004)
        << "moved " << moved << " m";
    EXPECT_LT(so3::angle(kf->T_B_L.linear().transpose() * expected.linear()), 1e-3);
    checked += moved > 0.01;  // while driving (not in the start's hold)
  }
  EXPECT_GT(checked, 2);
}

// A rig without a camera height whose LiDAR sees nothing before `seconds` into the sequence:
// no scale until then.
void seeNoScaleBefore(SyntheticSequence* seq, double seconds) {
  seq->setup.camera_height_m.reset();
  const Timestamp until = seq->frames.front().t_ns + static_cast<Timestamp>(seconds * 1e9);
  std::erase_if(seq->scans, [&](const LidarScan& s) { return s.t_ns < until; });
}

TEST(WindowCore, ALidarThatStartsSeeingLateStillGivesTheStartItsScale) {
  // No camera height, and no scan in the first 2 s (a LiDAR that sees nothing yet). Each
  // reference puts the start off for 20 frames; a unit baseline then would keep a wrong scale for
  // good (the LiDAR gate rejects every range that would correct it). The reference restarts
  // instead, for up to 2 s, and the first scans give the scale.
  SyntheticOptions o;
  auto seq = makeSyntheticSequence(o);
  seeNoScaleBefore(&seq, 2.0);
  const auto r = run(seq);
  expectAllFinite(r);
  EXPECT_TRUE(noted(r, "the two-view reference restarted"));
  EXPECT_FALSE(noted(r, "unit baseline"));
  EXPECT_GT(r.stats.lidar_scale_frames, 0);
  // The motion before the restart is lost (the poses stay at the start); the scale is that of
  // the motion from the initialisation on.
  std::size_t first = r.estimates.size();
  while (first > 0 && r.estimates[first - 1].status != "initializing") --first;
  ASSERT_LT(first + 20, seq.frames.size());
  const std::size_t last = seq.frames.size() - 1;
  const double moved =
      (r.trajectory[last].T_W_B.translation() - r.trajectory[first].T_W_B.translation()).norm();
  const double moved_true =
      (truthRel(seq, last).translation() - truthRel(seq, first).translation()).norm();
  EXPECT_NEAR(moved / moved_true, 1.0, 0.05);
}

TEST(WindowCore, AScaleOffByMoreThanTheLidarGatesComesBackWhenTheRangesAgree) {
  // No camera height, and for the first 2.5 s a LiDAR whose ranges read 1.5x too long: the window
  // starts at 1.5x the true scale. The true ranges after that are 33 % shorter than the landmarks,
  // beyond the depth gate (25 %) and the outlier test (5 %), so every one of them was rejected and
  // the wrong scale kept for good. They agree with each other on one ratio: the window is
  // rescaled to them.
  SyntheticOptions o;
  o.duration_s = 8.0;
  auto seq = makeSyntheticSequence(o);
  seq.setup.camera_height_m.reset();
  const Timestamp until = seq.frames.front().t_ns + static_cast<Timestamp>(2.5e9);
  for (LidarScan& scan : seq.scans)
    if (scan.t_ns < until)
      for (double& range : scan.ranges_m) range *= 1.5;
  const auto scaleOver = [&](const RunResult& r, std::size_t from, std::size_t to) {
    const double moved =
        (r.trajectory[to].T_W_B.translation() - r.trajectory[from].T_W_B.translation()).norm();
    return moved / (truthRel(seq, to).translation() - truthRel(seq, from).translation()).norm();
  };
  const std::size_t last = seq.frames.size() - 1, from = last - 40;  // the last 2 s

  WindowOptions off;
  off.lidar_rescale_ratio = 0.0;
  const auto kept = run(seq, off);
  expectAllFinite(kept);
  EXPECT_NEAR(scaleOver(kept, from, last), 1.5, 0.1)
      << "without the rescale the start's scale stays";

  const auto r = run(seq);
  expectAllFinite(r);
  EXPECT_TRUE(noted(r, "window rescaled"));
  EXPECT_NEAR(scaleOver(r, from, last), 1.0, 0.05);
  // The rescale moves the window about its oldest keyframe: the current pose steps by a fraction
  // of the window's length (0.09 m here), not back to the start. A frame's step at 1.5x is 0.06 m.
  for (std::size_t k = 1; k < r.trajectory.size(); ++k)
    EXPECT_LT(
        (r.trajectory[k].T_W_B.translation() - r.trajectory[k - 1].T_W_B.translation()).norm(),
        0.12)
        << "frame " << k;
}

TEST(WindowCore, WithNoScaleAtAllItStartsAtAUnitBaselineWithinAFewSeconds) {
  // A LiDAR that never sees anything and no camera height: after putting off and restarting
  // for 2 s the window starts at a unit baseline and says so, rather than never.
  SyntheticOptions o;
  auto seq = makeSyntheticSequence(o);
  seeNoScaleBefore(&seq, o.duration_s + 1.0);
  const auto r = run(seq);
  expectAllFinite(r);
  EXPECT_TRUE(noted(r, "unit baseline"));
  const auto last_waiting =
      std::find_if(r.estimates.rbegin(), r.estimates.rend(),
                   [](const FrameEstimate& e) { return e.status == "initializing"; });
  ASSERT_NE(last_waiting, r.estimates.rend());
  EXPECT_LT(toSeconds(last_waiting->t_ns - seq.frames.front().t_ns), 3.5);
}

// The largest rotation error (deg) of the run's trajectory against the truth (W = B at frame 0).
double worstRotationDeg(const SyntheticSequence& seq, const RunResult& r) {
  double worst_deg = 0.0;
  for (std::size_t i = 0; i < seq.frames.size(); ++i) {
    const Mat3 dR = truthRel(seq, i).linear().transpose() * r.trajectory[i].T_W_B.linear();
    worst_deg = std::max(worst_deg, so3::angle(dR) * 180.0 / M_PI);
  }
  return worst_deg;
}

// A rig without a LiDAR (no scans), like KITTI's.
void withoutLidar(SyntheticSequence* seq) {
  seq->setup.has_lidar = false;
  seq->scans.clear();
}

// A vision whose rotation jitters: every frame's tracks are seen as from a camera turned by a
// random rotation of 1 mrad per axis, all of them alike (the rendered rows' keyframes are 0.3-2
// mrad off from one to the next where the gyro is within 0.1). Tied to the gyro chain by
// vision_rotation_sigma_rad, each keyframe's orientation as the vision sees it may be off by
// about that much, and the body's orientation (the output) follows the gyro from keyframe to
// keyframe; with one orientation for both (0) the many tracks outweigh the gyro.
TEST(WindowCore, AVisionWhoseRotationJittersIsSmoothedByTheGyro) {
  SyntheticOptions o;
  o.duration_s = 10.0;
  o.vision_rotation_jitter_rad = 1e-3;
  const auto seq = makeSyntheticSequence(o);
  // RMS rotation error (rad) from keyframe to keyframe, and of every frame against the truth.
  const auto errors = [&](const RunResult& r) {
    double step2 = 0.0, abs2 = 0.0;
    int steps = 0;
    std::optional<std::size_t> prev;
    for (std::size_t i = 0; i < seq.frames.size(); ++i) {
      const Mat3& R_est = r.trajectory[i].T_W_B.linear();
      abs2 += std::pow(so3::angle(truthRel(seq, i).linear().transpose() * R_est), 2);
      if (!r.estimates[i].is_keyframe) continue;
      if (prev) {
        const Mat3 rel_true = truthRel(seq, *prev).linear().transpose() * truthRel(seq, i).linear();
        const Mat3 rel_est = r.trajectory[*prev].T_W_B.linear().transpose() * R_est;
        step2 += std::pow(so3::angle(rel_true.transpose() * rel_est), 2);
        ++steps;
      }
      prev = i;
    }
    return std::pair(std::sqrt(step2 / std::max(steps, 1)), std::sqrt(abs2 / seq.frames.size()));
  };
  // The tie alone: the accelerometer, a second hold on roll and pitch, would smooth both runs
  // (measured with it: 3.1 against 3.0 mrad in all, 0.27 against 1.13 keyframe to keyframe).
  WindowOptions tied_options;
  tied_options.accel_sigma_mps2 = 0.0;
  const auto tied = run(seq, tied_options);
  WindowOptions one_orientation = tied_options;
  one_orientation.vision_rotation_sigma_rad = 0.0;
  const auto untied = run(seq, one_orientation);
  expectAllFinite(tied);
  const auto [step_tied, abs_tied] = errors(tied);
  const auto [step_untied, abs_untied] = errors(untied);
  // Measured: 0.24 against 0.85 mrad from keyframe to keyframe, 3.5 against 4.2 mrad in all.
  std::printf(
      "rotation error keyframe to keyframe %.2f / %.2f mrad, in all %.2f / %.2f mrad "
      "(tied / one orientation)\n",
      1e3 * step_tied, 1e3 * step_untied, 1e3 * abs_tied, 1e3 * abs_untied);
  EXPECT_LT(step_tied, 0.5e-3);
  EXPECT_LT(step_tied, 0.5 * step_untied);
  EXPECT_LT(abs_tied, abs_untied);
}

TEST(WindowCore, TheAccelerometerHoldsTheTiltAVisionDriftWouldTake) {
  // The tracks creep as if the camera pitched at 0.2 deg/s (issue 60's drift, 4x): with the gyro
  // and no gravity reference the window's bias follows part of it and the body tilts; the
  // accelerometer's factors (the synthetic IMU's specific force of the true motion) hold the
  // tilt to gravity.
  SyntheticOptions o;
  o.duration_s = 12.0;
  o.vision_drift_radps = 0.2 * M_PI / 180.0;
  const auto seq = makeSyntheticSequence(o);
  // The angle between the true and the estimated gravity direction in the body (the tilt error),
  // at the end and the largest over the run, rad.
  const auto tilt = [&](const RunResult& r) {
    double last = 0.0, worst = 0.0;
    for (std::size_t i = 0; i < seq.frames.size(); ++i) {
      const Vec3 up_true = truthRel(seq, i).linear().transpose() * Vec3::UnitZ();
      const Vec3 up_est = r.trajectory[i].T_W_B.linear().transpose() * Vec3::UnitZ();
      last = std::acos(std::clamp(up_true.dot(up_est), -1.0, 1.0));
      worst = std::max(worst, last);
    }
    return std::pair(last, worst);
  };
  WindowOptions no_accel;
  no_accel.accel_sigma_mps2 = 0.0;
  const auto without = run(seq, no_accel);
  WindowOptions with_accel;
  with_accel.accel_sigma_mps2 = 0.01;
  with_accel.accel_position_sigma_m = 0.0005;
  const auto with = run(seq, with_accel);
  expectAllFinite(with);
  EXPECT_TRUE(noted(with, "gravity set from the accelerometer"));
  EXPECT_FALSE(noted(without, "gravity set from the accelerometer"));
  const auto [last_without, worst_without] = tilt(without);
  const auto [last_with, worst_with] = tilt(with);
  std::printf("tilt error at the end %.3f / %.3f deg, largest %.3f / %.3f deg (without / with)\n",
              last_without * 180.0 / M_PI, last_with * 180.0 / M_PI, worst_without * 180.0 / M_PI,
              worst_with * 180.0 / M_PI);
  // Measured over the synthetic seeds 3, 4, 5: 1.89-1.99 deg without, 0.96 with (0.49-0.51 of it):
  // the accelerometer halves the tilt; the vision, a thousand sightings a keyframe, still
  // outweighs it where all the canopy drifts alike.
  EXPECT_LT(worst_with, 0.6 * worst_without);
}

TEST(WindowCore, WithoutGyroTheTurnBeforeInitialisationIsKept) {
  // No gyro, no scale for the first 2 s (the reference restarts for want of one) and a weaving
  // drive of +-20 deg. The rotation since each old reference is measured on its tracks, so no turn
  // is lost before the start (a held pose there: the yaw off by the turn until the end).
  SyntheticOptions o;
  o.yaw_amplitude_deg = 20.0;
  auto seq = makeSyntheticSequence(o);
  seeNoScaleBefore(&seq, 2.0);
  WindowOptions options;
  options.use_gyro = false;
  const auto r = run(seq, options);
  expectAllFinite(r);
  EXPECT_TRUE(noted(r, "the two-view reference restarted"));
  const double worst_deg = worstRotationDeg(seq, r);
  EXPECT_LT(worst_deg, 1.0);
}

TEST(WindowCore, WithoutLidarTheDistanceBeforeTheStartFollowsTheGround) {
  // No LiDAR, only the camera height, and a start that never comes (too few tracks for it): as
  // on KITTI, where the reference's tracks run out before its ground plane scales it, each frame's
  // position is chained over short baselines by the ground plane. The position then follows the
  // drive (holding it, the old behaviour, leaves every frame at the start).
  SyntheticOptions o;
  auto seq = makeSyntheticSequence(o);
  withoutLidar(&seq);
  WindowOptions options;
  options.init_min_tracks = 1000000;
  const auto r = run(seq, options);
  expectAllFinite(r);
  ASSERT_EQ(r.estimates.back().status, "initializing");
  double worst = 0.0;
  for (double t_s : {2.0, 3.0, 4.0, 5.0, 5.9}) {
    const auto i = static_cast<std::size_t>(t_s * o.camera_rate_hz);
    ASSERT_LT(i, seq.frames.size());
    const Vec3 p_true = truthRel(seq, i).translation();
    const double error = (r.trajectory[i].T_W_B.translation() - p_true).norm();
    worst = std::max(worst, error / p_true.norm());
    std::printf("t %.1f s: %.3f m from the start (true %.3f), error %.3f m\n", t_s,
                r.trajectory[i].T_W_B.translation().norm(), p_true.norm(), error);
  }
  EXPECT_LT(worst, 0.05) << "largest position error over the distance from the start";
}

TEST(WindowCore, WithoutGyroTheRotationGoesOnWhenTheReferencesTracksRunOut) {
  // No gyro, no LiDAR, a start that never comes, a +-20 deg weave, and tracks that live 15
  // frames (KITTI's die fast): the two-view reference soon shares too few tracks for a rotation.
  // The ground chain's recent anchor still shares many and gives it (held instead, the weave's
  // turn since then is lost: 34 deg off).
  SyntheticOptions o;
  o.yaw_amplitude_deg = 20.0;
  auto seq = makeSyntheticSequence(o);
  seq.setup.has_gyro = false;
  withoutLidar(&seq);
  constexpr TrackId kLife = 15;
  for (std::size_t i = 0; i < seq.frames.size(); ++i)
    for (auto& ob : seq.frames[i].visual.observations)
      ob.track_id = ob.track_id * 1000 + (i + ob.track_id % kLife) / kLife;
  WindowOptions options;
  options.init_min_tracks = 1000000;
  const auto r = run(seq, options);
  expectAllFinite(r);
  ASSERT_EQ(r.estimates.back().status, "initializing");
  const double worst_deg = worstRotationDeg(seq, r);
  std::printf("largest rotation error: %.2f deg\n", worst_deg);
  EXPECT_LT(worst_deg, 1.0);
}

TEST(WindowCore, AStopWhileWaitingForAScaleRestartsTheWait) {
  // No camera height and no scan before 4 s. The robot creeps off without a scale, stands 1.5 s
  // and drives on: waiting while still loses nothing, so the 2 s of waiting start again when it
  // moves, and the first scans (1 s later) still give the start its scale. It takes both: the
  // wait restarted by the stop, and references restarted on frames with a scan (one view's
  // beams alone are too few here).
  SyntheticOptions o;
  o.duration_s = 8.0;
  o.stop_from_s = 1.5;
  o.stop_to_s = 3.0;
  auto seq = makeSyntheticSequence(o);
  seeNoScaleBefore(&seq, 4.0);
  const auto r = run(seq);
  expectAllFinite(r);
  EXPECT_FALSE(noted(r, "unit baseline"));
  EXPECT_GT(r.stats.lidar_scale_frames, 0);
}

TEST(WindowCore, AmbiguousLidarVoteAtInitialisationIsSettledByTheGroundPlane) {
  // In the synthetic row, beams next to tracked points give two groups of range ratios at
  // initialisation (11 near the true scale, 8 about 2.4x off). Putting the start off only loses
  // motion (tracks die, the reference restarts); the ground plane picks the group at once.
  SyntheticOptions o;
  const auto seq = makeSyntheticSequence(o);
  const auto r = run(seq);
  expectAllFinite(r);
  EXPECT_TRUE(noted(r, "the group that the ground plane agrees with"));
  EXPECT_FALSE(noted(r, "put off"));
  const SE3 T_true = truthRel(seq, seq.frames.size() - 1);
  const double scale = r.trajectory.back().T_W_B.translation().norm() / T_true.translation().norm();
  EXPECT_NEAR(scale, 1.0, 0.03);
}

/// RMS position (m) and rotation (deg) errors against the truth (W = B at frame 0) of the frames
/// from `first` on.
struct PoseRmse {
  double position_m = 0.0, rotation_deg = 0.0;
};

PoseRmse poseRmse(const SyntheticSequence& seq, const Trajectory& traj, std::size_t first) {
  double sum_p = 0.0, sum_r = 0.0;
  for (std::size_t i = first; i < seq.frames.size(); ++i) {
    const SE3 truth = truthRel(seq, i);
    sum_p += (traj[i].T_W_B.translation() - truth.translation()).squaredNorm();
    const double a = so3::angle(traj[i].T_W_B.linear().transpose() * truth.linear());
    sum_r += a * a;
  }
  const double n = static_cast<double>(seq.frames.size() - first);
  return {std::sqrt(sum_p / n), std::sqrt(sum_r / n) * 180.0 / M_PI};
}

TEST(WindowCore, FullRefinementMatchesTheOnlineWindow) {
  // 12 s drives, most keyframes marginalised online, with tracks that creep (0.2 px per
  // sqrt(frame)); the batch has an outlier pass. With anchor factors the batch cuts tracks into
  // pieces of at most 40 frames; with bearing steps, which model the creep, it keeps them whole.
  // One draw decides little (the batch's RMSE over seeds 2..6 ranges 0.006 to 0.033 m), so the
  // claims are checked over five, and no drive leaves the product's bound (ATE 0.5 % of the
  // path). Before wave 2's #40 the batch matched the online window with the same factors
  // (anchors/anchors sums 0.087 online, 0.083 batch; steps/steps 0.069 and 0.053). The test
  // fails with steps if the batch cuts tracks after 40 frames, and with the ground beams' raw
  // ranges (window.lidar_ground_beams=raw, biased long) even with anchor factors.
  struct Models {
    bool online_steps, refine_steps;
    const char* name;
    double max_ratio;      // batch sum / online sum
    double max_rot_ratio;  // the same for the rotation RMSE
  };
  // Since the online window gates outliers in sigmas, keeps far points at infinity and gives its
  // frames the gyro's rotation (wave 2, #40), it beats the batch with anchor factors: measured
  // position sums online / batch 0.0683 / 0.0809 m (anchors/anchors), 0.0677 / 0.0889 m
  // (steps/anchors), 0.0677 / 0.0436 m (steps/steps); rotation 0.393 / 0.667 deg (steps/anchors),
  // 0.393 / 0.423 deg (steps/steps). With the time offset estimated online (wave 2, #42; the
  // batch estimates it too) the online window with bearing steps gained again: 0.0754 / 0.0966 m
  // (anchors/anchors), 0.0524 / 0.0915 m (steps/anchors), 0.0524 / 0.0576 m (steps/steps). With
  // the gyro and the scans fed up to an image's time on the gyro clock when the offset found is
  // negative (these straight drives leave it loose by some milliseconds), the online window with
  // anchor factors gained (seed 4: 0.029 -> 0.017 m) and its batch lost (seeds 3 and 4: 0.017 ->
  // 0.024 and 0.018 -> 0.033 m): 0.0674 / 0.1103 m (anchors/anchors). With the accelerometer's
  // tilt factors (issue 60, in both) the online window gained again and the batch did not:
  // 0.0596 / 0.0783 m (anchors/anchors), 0.0498 / 0.0947 m (steps/anchors, 1.90), 0.0498 /
  // 0.0575 m (steps/steps, 1.15); rotation 0.49 / 0.94 deg (anchors/anchors, 1.91). The bounds
  // hold those ratios with a tenth to spare (a known weakness of the batch's anchor factors over
  // 40-frame tracks, not a target).
  for (const Models m : {Models{false, false, "anchors/anchors", 1.8, 2.2},
                         Models{true, false, "steps/anchors", 2.1, 2.2},
                         Models{true, true, "steps/steps", 1.3, 1.3}}) {
    SCOPED_TRACE(m.name);
    double online_sum = 0.0, full_sum = 0.0, rot_online_sum = 0.0, rot_full_sum = 0.0;
    const std::vector<std::uint32_t> seeds = {2, 3, 4, 5, 6};
    for (const std::uint32_t seed : seeds) {
      SCOPED_TRACE(seed);
      SyntheticOptions o;
      o.duration_s = 12.0;
      o.track_creep_px = 0.2;  // as measured on the simulated rows' tracks
      o.seed = seed;
      const auto seq = makeSyntheticSequence(o);
      WindowOptions options;
      options.bearing_steps = m.online_steps;
      const auto online = run(seq, options);
      WindowOptions refine = options;
      refine.refine = RefineMode::kFull;
      refine.refine_bearing_steps = m.refine_steps;
      WindowCore core(seq.setup, refine);
      test::feedSequence(seq, core, [](std::size_t, const FrameEstimate&) {});
      const Trajectory full = core.trajectory();
      ASSERT_EQ(full.size(), seq.frames.size());
      for (const auto& p : full) ASSERT_TRUE(allFinite(p.T_W_B));
      const auto refined = core.stats().refine;  // what metrics.json reports
      ASSERT_TRUE(refined.has_value());
      const RefineInfo& info = *refined;
      EXPECT_TRUE(info.usable) << info.message;
      EXPECT_EQ(info.keyframes, core.stats().keyframes);
      EXPECT_EQ(info.passes, refine.refine_passes);
      EXPECT_GT(info.lidar_factors, 0);
      EXPECT_GT(info.ground_factors, 0);
      EXPECT_LT(info.final_cost, info.initial_cost);

      // From the initialisation on (before it both hold or interpolate the same way).
      std::size_t first = 0;
      while (first < online.estimates.size() && online.estimates[first].status != "initialized")
        ++first;
      ASSERT_LT(first, seq.frames.size() / 2);
      const PoseRmse online_rmse = poseRmse(seq, online.trajectory, first);
      const PoseRmse full_rmse = poseRmse(seq, full, first);
      std::printf(
          "%s, seed %u: position RMSE online %.4f m, full %.4f m (path %.1f m); rotation "
          "RMSE online %.3f deg, full %.3f deg\n",
          m.name, seed, online_rmse.position_m, full_rmse.position_m, pathLength(seq),
          online_rmse.rotation_deg, full_rmse.rotation_deg);
      EXPECT_LT(full_rmse.position_m, 0.005 * pathLength(seq));
      online_sum += online_rmse.position_m;
      full_sum += full_rmse.position_m;
      rot_online_sum += online_rmse.rotation_deg;
      rot_full_sum += full_rmse.rotation_deg;
    }
    EXPECT_LT(full_sum, m.max_ratio * online_sum);
    EXPECT_LE(rot_full_sum, m.max_rot_ratio * rot_online_sum + 0.02 * seeds.size());
  }
}

TEST(WindowCore, WithoutGyroUsesVisionOnlyRotationAndSaysSo) {
  SyntheticOptions o;
  const auto seq = makeSyntheticSequence(o);
  WindowOptions options;
  options.use_gyro = false;
  const auto r = run(seq, options);
  expectAllFinite(r);
  EXPECT_TRUE(noted(r, "no gyro"));
  const SE3 T_true = truthRel(seq, seq.frames.size() - 1);
  EXPECT_LT((r.trajectory.back().T_W_B.translation() - T_true.translation()).norm(),
            0.05 * pathLength(seq));
}

TEST(WindowCore, BothSightingModelsFollowTheTracksCreep) {
  // Tracks that creep 0.2 px per sqrt(frame) share their walk in every error against the anchor;
  // tied to the previous sighting instead, each factor sees one step of it. Anchor factors model
  // the walk in their sigma (growing with the square root of the frames since the anchor), and the
  // outlier gate, in sigmas of each factor's own noise, keeps the long tracks' late sightings.
  // Measured over seeds 2..7 of the 12 s creep drive (position RMSE sums): anchor factors 0.0750
  // m, steps 0.0834 m (0.0701 and 0.0705 with window.bearing_sigma_from_camera). Before, with a
  // fixed 0.5 deg gate that pruned the late sightings of long tracks, anchor factors gave
  // 0.0996 m and steps 0.0816 m. With the time offset estimated (wave 2, #42: the drives hold
  // little angular acceleration, and the estimate wanders by 1-4 ms about the true 0) anchor
  // factors give 0.0874 m and steps 0.0679 m.
  double anchor_sum = 0.0, steps_sum = 0.0;
  for (std::uint32_t seed = 2; seed <= 7; ++seed) {
    SyntheticOptions o;
    o.duration_s = 12.0;
    o.track_creep_px = 0.2;
    o.seed = seed;
    const auto seq = makeSyntheticSequence(o);
    WindowOptions anchors, steps;
    anchors.bearing_steps = false;
    steps.bearing_steps = true;
    const auto a = run(seq, anchors), b = run(seq, steps);
    expectAllFinite(b);
    std::size_t first = 0;
    while (first < a.estimates.size() && a.estimates[first].status != "initialized") ++first;
    const double ra = poseRmse(seq, a.trajectory, first).position_m;
    const double rb = poseRmse(seq, b.trajectory, first).position_m;
    std::printf("seed %u: position RMSE anchor factors %.4f m, bearing steps %.4f m\n", seed, ra,
                rb);
    anchor_sum += ra;
    steps_sum += rb;
  }
  EXPECT_LT(anchor_sum, 0.095);
  EXPECT_LT(steps_sum, 0.08);
}

}  // namespace
}  // namespace ovo::estimator
