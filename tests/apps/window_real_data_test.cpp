// The default estimator on real data, scored against the ground truth: `ovo run` (window) on the
// first 160 frames of KITTI 07 (no gyro, no LiDAR: ground-plane scale) and on the EuRoC micro
// sequence (a real gyro, no LiDAR, no camera height), with the gyro bias it writes.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "io/dataset.hpp"
#include "io/trajectory_io.hpp"
#include "tests/test_support.hpp"

namespace ovo::test {
namespace {

namespace fs = std::filesystem;

// `ovo run --quiet [extra] --dataset ../shared/data/<dataset>` (the window, the default) into a
// fresh folder (*out_dir, if given); its metrics.json.
nlohmann::json runWindow(const std::string& dataset, const std::string& extra = "",
                         fs::path* out_dir = nullptr) {
  const fs::path out = tempDir() / ("window_" + dataset);
  if (out_dir) *out_dir = out;
  EXPECT_EQ(runOvo("run --quiet " + extra + " --dataset '" + sharedData(dataset).string() +
                   "' --out '" + out.string() + "'"),
            0);
  std::ifstream in(out / "metrics.json");
  return nlohmann::json::parse(in);
}

TEST(KittiWindow, FollowsTheFirstTurnAndHoldsTheGroundPlaneScale) {
  // The car pulls away turning left (about 95 deg in the first 5 s): the window initialises only
  // after 3.3 s, as the reference's tracks run out twice before. Measured: ATE 0.59 m (0.65 % of
  // the 90.6 m; Sim(3) 0.35 m), final yaw 0.09 deg, scale -1.7 % (vo: 0.77 m, Sim(3) 0.37 m,
  // 0.17 deg, -2.4 %). Without the frontend's Lucas-Kanade step (frontend.track_refine false):
  // 1.20 m (1.32 %; Sim(3) 0.34 m), 0.27 deg, -4.0 %: the step mostly mends the scale. Before: the
  // turn before initialisation lost, 45 deg of final yaw; the tight ground gate, scale -32 %; the
  // positions before the start held (no ground chain), ATE 1.91 m; the rotation held where the old
  // reference's tracks ran out, 1.75 deg; ground planes tilted up to 20 deg in the chain and the
  // camera-height factors, 1.44 m.
  OVO_REQUIRE_DATA("kitti07-first160/image_0/000000.png");
  const auto m = runWindow("kitti07-first160");
  EXPECT_EQ(m.at("frames").get<int>(), 160);
  EXPECT_LT(m.at("final_yaw_err_deg").get<double>(), 1.0);
  EXPECT_LT(m.at("ate_pct").get<double>(), 1.0);
  EXPECT_LT(std::abs(m.at("scale_err_pct").get<double>()), 10.0);
  // Issue 43's costs, where they are paid (values not asserted: no timing in tests).
  const auto& t = m.at("timing");
  EXPECT_GT(m.at("keyframes").get<int>(), 0);
  EXPECT_GE(t.at("keyframe_ms_max").get<double>(), t.at("keyframe_ms_p90").get<double>());
  EXPECT_GE(t.at("keyframe_ms_p90").get<double>(), t.at("keyframe_ms_median").get<double>());
  EXPECT_GT(t.at("cpu_s").get<double>(), 0.0);
  EXPECT_GT(t.at("peak_rss_mb").get<double>(), 0.0);
}

TEST(KittiWindow, AStartWithoutAScaleTakesTheGroundPlanesOnceTheyAgree) {
  // With 16 features per matching cell and class (frontend.bin_max_features) the ground-plane
  // scale does not come before the reference's tracks run out, and the window starts at a unit
  // baseline (7x short). The ground and camera-height gates, made for a window at its scale, then
  // rejected every plane: ATE 16 %, scale -49 %. Now the window takes the scale of its keyframes'
  // ground planes once two agree (WindowCore::rescaleToGround). Measured: 0.51 %, scale -1.4 %.
  OVO_REQUIRE_DATA("kitti07-first160/image_0/000000.png");
  const auto m = runWindow("kitti07-first160", "--set frontend.bin_max_features=16");
  const auto notes = m.at("notes").dump();
  ASSERT_NE(notes.find("unit baseline"), std::string::npos) << notes;  // the case under test
  EXPECT_NE(notes.find("rescaled to the ground plane"), std::string::npos) << notes;
  EXPECT_LT(m.at("ate_pct").get<double>(), 1.5);
  EXPECT_LT(std::abs(m.at("scale_err_pct").get<double>()), 5.0);
}

TEST(KittiWindow, FullRefinementKeepsTheGroundPlaneScale) {
  // `--refine full` without a LiDAR: only the camera-height factors hold the batch's scale. With
  // keyframe planes tilted up to 20 deg from the body's up they pulled it to -8.9 % (ATE 2.57 m,
  // worse than the online window); within 5 deg: ATE 0.81 m (0.89 %), scale -2.7 %, final yaw
  // 0.12 deg, from the online window with anchor factors. From the default online window (bearing
  // steps, the frontend's Lucas-Kanade step; 0.65 %, scale -1.7 %, yaw 0.09 deg) the batch (anchor
  // factors) ends at 1.16 %, scale -3.6 %, yaw 0.18 deg, though its shape is better (Sim(3) 0.21
  // against 0.35 m): it labels other ground points (308 camera-height factors), and the scale
  // follows them (without the Lucas-Kanade step: 1.27 %, -3.9 %, 0.11 deg, 300 factors; then
  // converged both times: the same answers at a function tolerance of 1e-12, and with 3 to 5
  // passes 1.11 to 1.22 %). Since issue 40 (sighting gate in sigmas, far points at infinity) the
  // batch ends at 1.35 %, scale -4.2 %, with the centre focal length's sigma (the default, which
  // gives the online window 0.63 % and the simulated runs their best sum) and at 1.20 %, -3.7 %
  // with the camera's per-bearing sigma (window.bearing_sigma_from_camera): the bound is 1.4 %.
  OVO_REQUIRE_DATA("kitti07-first160/image_0/000000.png");
  const auto m = runWindow("kitti07-first160", "--refine full");
  EXPECT_LT(m.at("final_yaw_err_deg").get<double>(), 0.5);
  EXPECT_LT(m.at("ate_pct").get<double>(), 1.4);
  EXPECT_LT(std::abs(m.at("scale_err_pct").get<double>()), 5.0);
}

TEST(EurocWindow, ARealGyroWithALargeBiasHoldsTheYawWhileTheMavHardlyMoves) {
  // The first 4.75 s of V1_01: the MAV sits on the floor (1.5 cm of motion in all); the gyro's
  // scatter rises after 0.25 s (motors). The gyro reads 0.08 rad/s at rest: before the standstill
  // test looked at the samples' scatter it never saw the still start, the window started at a
  // unit baseline on no parallax and its yaw ended 3.0 deg off, 0.22 deg a frame (kf 0.03 deg,
  // vo 0.01). Measured now: 0.05 deg, 0.004 deg a frame.
  OVO_REQUIRE_DATA("euroc-v101-micro/mav0/cam0/data.csv");
  fs::path out;
  const auto m = runWindow("euroc-v101-micro", "", &out);
  EXPECT_EQ(m.at("frames").get<int>(), 95);
  EXPECT_LT(m.at("final_yaw_err_deg").get<double>(), 0.5);
  EXPECT_LT(m.at("rpe_rot_deg_per_frame_median").get<double>(), 0.05);

  // gyro_bias.csv: the estimate at every frame. As the MAV sits still its final value is the
  // gyro's mean rate over the frames (-0.0020, 0.0209, 0.0782 rad/s; measured: within 5e-4).
  const io::Dataset data = io::loadDataset(sharedData("euroc-v101-micro"));
  std::ifstream csv(out / "gyro_bias.csv");
  std::string line;
  ASSERT_TRUE(std::getline(csv, line));
  EXPECT_EQ(line, "#timestamp [ns],b_x [rad s^-1],b_y [rad s^-1],b_z [rad s^-1]");
  const auto bias = io::readGyroBiasCsv(out / "gyro_bias.csv");  // throws on a malformed row
  ASSERT_EQ(bias.size(), data.images.size());
  for (std::size_t i = 0; i < bias.size(); ++i) EXPECT_EQ(bias[i].first, data.images[i].t_ns);
  Vec3 mean_rate = Vec3::Zero();
  int n = 0;
  for (const ImuSample& s : data.imu)
    if (s.t_ns >= bias.front().first && s.t_ns <= bias.back().first) mean_rate += s.gyro_radps, ++n;
  mean_rate /= n;
  EXPECT_LT((bias.back().second - mean_rate).norm(), 3e-3)
      << bias.back().second.transpose() << " vs " << mean_rate.transpose();
}

TEST(EurocWindow, VoWritesNoGyroBias) {
  OVO_REQUIRE_DATA("euroc-v101-micro/mav0/cam0/data.csv");
  fs::path out;
  runWindow("euroc-v101-micro", "--estimator vo", &out);
  EXPECT_TRUE(fs::exists(out / "trajectory.txt"));
  EXPECT_FALSE(fs::exists(out / "gyro_bias.csv"));
}

}  // namespace
}  // namespace ovo::test
