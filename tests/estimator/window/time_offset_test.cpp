// The camera-gyro time offset as a state of the window: a simulated headland turn whose image
// stamps run late or early against the gyro clock, with a rig that does not know it (prior 0).
#include <gtest/gtest.h>

#include "tests/estimator/kf/sim_run.hpp"

namespace ovo::test {
namespace {

// headland_turn's first 16 s: the row, the headland entry and the first pivot (30 deg/s), at
// 10 Hz.
SimSequence turnWithOffset(double offset_s) {
  return renderSimSequence("headland_turn", {"duration_s=16", "camera.rate_hz=10",
                                             "camera.time_offset_s=" + std::to_string(offset_s)});
}

struct OffsetRun {
  double ate_m = 1.0;
  double td_s = 0.0;
  bool estimated = false;
  int lidar_ranges = 0;
  double fed_ahead_s = 0.0;  // how far past an image its gyro and scans are fed, at the end
  // The gyro bias history is stamped on the trajectory's clock: the same stamps, frame by frame.
  bool bias_on_the_trajectorys_clock = false;
};

OffsetRun runWindow(const SimSequence& seq, bool estimate) {
  const EstimatorRun run = runEstimator(
      "window", seq, {std::string("window.estimate_time_offset=") + (estimate ? "true" : "false")});
  OffsetRun out;
  EXPECT_TRUE(allPosesFinite(run.trajectory));
  if (const auto s = scoreRun(seq, run.trajectory)) out.ate_m = s->ate_m;
  out.estimated = run.stats.time_offset_s.has_value();
  out.lidar_ranges = run.stats.lidar_ranges;
  out.fed_ahead_s = toSeconds(run.fed_ahead_ns);
  out.td_s = run.stats.time_offset_s.value_or(0.0);
  out.bias_on_the_trajectorys_clock = !run.bias_history.empty() &&
                                      run.bias_history.size() == run.trajectory.size();
  for (std::size_t k = 0; out.bias_on_the_trajectorys_clock && k < run.trajectory.size(); ++k)
    out.bias_on_the_trajectorys_clock = run.bias_history[k].first == run.trajectory[k].t_ns;
  return out;
}

TEST(WindowTimeOffset, IsEstimatedOnlineAndTheTrajectoryComesOutOnTheGyroClock) {
  for (double offset_s : {0.03, -0.04}) {
    SCOPED_TRACE("camera.time_offset_s " + std::to_string(offset_s));
    const SimSequence seq = turnWithOffset(offset_s);
    const OffsetRun on = runWindow(seq, true), off = runWindow(seq, false);
    RecordProperty("td_ms_" + std::to_string(offset_s), std::to_string(on.td_s * 1e3));
    RecordProperty("ate_mm_on_" + std::to_string(offset_s), std::to_string(on.ate_m * 1e3));
    RecordProperty("ate_mm_off_" + std::to_string(offset_s), std::to_string(off.ate_m * 1e3));
    ASSERT_TRUE(on.estimated);
    EXPECT_FALSE(off.estimated);
    EXPECT_NEAR(on.td_s, offset_s, 0.003);
    EXPECT_TRUE(on.bias_on_the_trajectorys_clock);
    // Ignoring the offset costs the window (the gyro's rotation over the wrong interval, and the
    // poses stamped at the wrong times); the estimate buys that back.
    EXPECT_LT(on.ate_m, 0.6 * off.ate_m);
  }
}

// A camera whose stamps run early: the image stamped t was exposed at t + 40 ms of the gyro
// clock, with the scan of that instant. Fed by image stamp, that scan and the gyro up to it come
// after the image; the keyframes then go without their scans. The measurements of the exposure
// must reach the window before its image, so the LiDAR keeps (nearly) all its ranges.
TEST(WindowTimeOffset, ACameraThatRunsEarlyKeepsItsLidarRanges) {
  const OffsetRun early = runWindow(turnWithOffset(-0.04), true);
  const OffsetRun zero = runWindow(turnWithOffset(0.0), true);
  RecordProperty("lidar_ranges_early", early.lidar_ranges);
  RecordProperty("lidar_ranges_zero", zero.lidar_ranges);
  ASSERT_GT(zero.lidar_ranges, 100);
  // Fed by image stamp the keyframes kept none (0 of 757); fed ahead, 685 of 757 with Ceres'
  // steps and 682 of 759 with the solve's stopping rule: the count moves by a percent with the
  // solver's details, so the bound sits well below it and far above the failure.
  EXPECT_GE(early.lidar_ranges, 0.8 * zero.lidar_ranges);
  EXPECT_NEAR(early.td_s, -0.04, 0.003);
  // The exposure's gyro and scan are fed before the image: the offset found, plus the scans'
  // time tolerance (4 ms); the clocks that agree are fed as before.
  EXPECT_NEAR(early.fed_ahead_s, -early.td_s + 0.004, 0.001);
  EXPECT_EQ(zero.fed_ahead_s, 0.0);
}

TEST(WindowTimeOffset, StaysNearZeroWhenTheClocksAgree) {
  const SimSequence seq = turnWithOffset(0.0);
  const OffsetRun on = runWindow(seq, true), off = runWindow(seq, false);
  RecordProperty("td_ms", std::to_string(on.td_s * 1e3));
  EXPECT_NEAR(on.td_s, 0.0, 0.002);
  EXPECT_LT(on.ate_m, 1.2 * off.ate_m + 0.001);
}

}  // namespace
}  // namespace ovo::test
