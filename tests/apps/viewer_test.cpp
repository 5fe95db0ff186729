// The viewer: LiDAR beams projected with T_C_L land where the geometry says, the canvas shows
// the image, tracks, LiDAR points and top view, snapshots round-trip, and (when xvfb-run exists)
// `ovo run --viewer` opens its real window under Xvfb and saves a screenshot.
#include "apps/viewer.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "common/error.hpp"
#include "tests/apps/online_test_data.hpp"
#include "tests/test_support.hpp"

namespace ovo::app {
namespace {

namespace fs = std::filesystem;

// Body x forward, y left, z up; camera x right, y down, z forward, looking along body x.
SE3 cameraLookingForward() {
  SE3 T_B_C = SE3::Identity();
  T_B_C.linear() << 0, 0, 1,  //
      -1, 0, 0,               //
      0, -1, 0;
  return T_B_C;
}

estimator::SensorSetup pinholeSetup(const SE3& T_B_L) {
  estimator::SensorSetup s{.camera = camera::PinholeRadtanCamera(500, 500, 320, 240, 640, 480)};
  s.T_B_C = cameraLookingForward();
  s.T_B_L = T_B_L;
  s.has_lidar = true;
  return s;
}

LidarScan scanOf(std::vector<double> angles_deg, double range_m) {
  LidarScan scan;
  scan.angle_min_rad = angles_deg.front() * M_PI / 180.0;
  scan.angle_increment_rad =
      angles_deg.size() > 1 ? (angles_deg[1] - angles_deg[0]) * M_PI / 180.0 : 0.0;
  scan.range_min_m = 0.1;
  scan.range_max_m = 30.0;
  scan.ranges_m.assign(angles_deg.size(), range_m);
  return scan;
}

TEST(ViewerProjection, ABeamStraightAheadLandsOnThePrincipalPoint) {
  const auto setup = pinholeSetup(SE3::Identity());
  const SE3 T_C_L = setup.T_B_C.inverse() * setup.T_B_L;
  const auto beams = projectScan(scanOf({0.0}, 5.0), T_C_L, setup.camera);
  ASSERT_EQ(beams.size(), 1u);
  EXPECT_NEAR(beams[0].px.x(), 320.0, 1e-9);
  EXPECT_NEAR(beams[0].px.y(), 240.0, 1e-9);
  EXPECT_EQ(beams[0].range_m, 5.0);
}

TEST(ViewerProjection, BeamsToTheLeftAppearLeftAndALowerLidarAppearsLower) {
  // LiDAR 0.5 m below the camera: its plane projects 0.5 / 5 * 500 = 50 px below the centre.
  SE3 T_B_L = SE3::Identity();
  T_B_L.translation() = Vec3(0, 0, -0.5);
  const auto setup = pinholeSetup(T_B_L);
  const SE3 T_C_L = setup.T_B_C.inverse() * setup.T_B_L;
  // -10, 0, +10 degrees (positive = to the left, about z up) and one behind (180).
  LidarScan scan = scanOf({-10.0, 0.0, 10.0}, 5.0);
  const auto beams = projectScan(scan, T_C_L, setup.camera);
  ASSERT_EQ(beams.size(), 3u);
  EXPECT_GT(beams[0].px.x(), 320.0);  // to the right
  EXPECT_NEAR(beams[1].px.x(), 320.0, 1e-9);
  EXPECT_LT(beams[2].px.x(), 320.0);  // to the left
  EXPECT_NEAR(beams[2].px.x(), 320.0 - 500.0 * std::tan(10.0 * M_PI / 180.0), 1e-6);
  EXPECT_NEAR(beams[1].px.y(), 290.0, 1e-9);
  const auto behind = projectScan(scanOf({180.0}, 5.0), T_C_L, setup.camera);
  EXPECT_TRUE(behind.empty());
  scan.ranges_m[1] = 100.0;  // out of range: no return
  EXPECT_EQ(projectScan(scan, T_C_L, setup.camera).size(), 2u);
}

TEST(Viewer, CanvasShowsTheImageTracksLidarPointsAndTopView) {
  const auto setup = pinholeSetup(SE3::Identity());
  ViewerOptions options;
  options.show_window = false;
  Viewer viewer(setup, "vo", options);
  Trajectory gt;
  for (int i = 0; i < 50; ++i) {
    StampedPose p;
    p.t_ns = i * 50'000'000LL;
    p.T_W_B.translation() = Vec3(0.1 * i, 0.02 * i * i * 0.05, 0);
    gt.push_back(p);
  }
  viewer.setGroundTruth(gt);
  const cv::Mat grey(480, 640, CV_8UC1, cv::Scalar(128));
  for (int i = 0; i < 40; ++i) {
    estimator::FrameEstimate f;
    f.t_ns = gt[i].t_ns;
    f.T_W_B = gt[i].T_W_B;
    f.tracked = true;
    f.tracks.push_back({7, Vec2(100 + i, 100), i + 2});  // an old track, moving right
    f.tracks.push_back({static_cast<std::uint64_t>(100 + i), Vec2(500, 400), 2});  // a new one
    LidarScan scan = scanOf({0.0}, 5.0);
    scan.t_ns = f.t_ns;
    viewer.addScan(scan);
    viewer.addFrame(f, grey, {3, 42.0});
  }
  const cv::Mat canvas = viewer.renderCanvas();
  // Status line 30 px, 640x480 image panel (scale 1) and a 480x480 top view.
  ASSERT_EQ(canvas.rows, 30 + 480);
  ASSERT_EQ(canvas.cols, 640 + 480);
  auto at = [&](int x, int y) { return canvas.at<cv::Vec3b>(30 + y, x); };
  // The LiDAR beam straight ahead is magenta at the principal point.
  EXPECT_EQ(at(320, 240), cv::Vec3b(255, 0, 255));
  // The old track (age 41) is drawn in a warm colour, the new one (age 2) in a cold colour.
  const cv::Vec3b old_track = at(139, 100), new_track = at(500, 400);
  EXPECT_GT(old_track[2], old_track[0]) << old_track;
  EXPECT_GT(new_track[0], new_track[2]) << new_track;
  // Away from any drawing the image is its own grey.
  EXPECT_EQ(at(600, 60), cv::Vec3b(128, 128, 128));
  // The top view holds the estimate in orange (B, G, R) = (0, 140, 255).
  int orange = 0;
  for (int y = 30; y < canvas.rows; ++y)
    for (int x = 640; x < canvas.cols; ++x)
      if (canvas.at<cv::Vec3b>(y, x) == cv::Vec3b(0, 140, 255)) ++orange;
  EXPECT_GT(orange, 50);

  const fs::path png = test::tempDir() / "viewer.png";
  viewer.saveSnapshot(png);
  const cv::Mat back = cv::imread(png.string());
  ASSERT_FALSE(back.empty());
  EXPECT_EQ(cv::norm(back, canvas, cv::NORM_INF), 0.0);
  EXPECT_THROW(viewer.saveSnapshot("/nonexistent-dir/x.png"), Error);
}

TEST(Viewer, WindowRunsUnderXvfbAndSavesAScreenshot) {
  if (std::system("command -v xvfb-run >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "xvfb-run not installed (Debian package `xvfb`; scripts/setup.sh installs it)";
  OVO_REQUIRE_DATA("kitti07-first160/image_0/000000.png");
  if (!fs::exists(test::ovoBinaryPath())) GTEST_SKIP() << "ovo not built";
  const fs::path dir = test::tempDir();
  const fs::path data = test::makeMiniKitti(dir / "kitti", 12);
  const fs::path png = dir / "viewer.png";
  const std::string cmd =
      "xvfb-run -a -s '-screen 0 1600x900x24' '" + test::ovoBinaryPath().string() +
      "' run --dataset '" + data.string() +
      "' --estimator vo --quiet --realtime --rate 4 --viewer --viewer-snapshot '" + png.string() +
      "' --out '" + (dir / "out").string() + "' > '" + (dir / "log.txt").string() + "' 2>&1";
  const int code = std::system(cmd.c_str());
  std::ifstream log(dir / "log.txt");
  const std::string text((std::istreambuf_iterator<char>(log)), {});
  ASSERT_EQ(code, 0) << text;
  const cv::Mat shot = cv::imread(png.string());
  ASSERT_FALSE(shot.empty()) << text;
  EXPECT_EQ(shot.rows, 30 + 480);
  EXPECT_GT(shot.cols, 480);
}

TEST(Viewer, RefusesToOpenAWindowWithoutADisplay) {
  const char* display = std::getenv("DISPLAY");
  const std::string saved = display ? display : "";
  unsetenv("DISPLAY");
  const char* wayland = std::getenv("WAYLAND_DISPLAY");
  const std::string saved_wayland = wayland ? wayland : "";
  unsetenv("WAYLAND_DISPLAY");
  EXPECT_THROW(Viewer::checkDisplay(), Error);
  if (!saved.empty()) setenv("DISPLAY", saved.c_str(), 1);
  if (!saved_wayland.empty()) setenv("WAYLAND_DISPLAY", saved_wayland.c_str(), 1);
}

}  // namespace
}  // namespace ovo::app
