// Rolling shutter: each row rendered at its own time, with the pose of that time.
#include <gtest/gtest.h>

#include <cmath>

#include "sim/renderer.hpp"
#include "sim/simulation.hpp"
#include "sim/world.hpp"
#include "tests/sim/sim_test_support.hpp"

namespace ovo::sim {
namespace {

constexpr double kDeg = M_PI / 180.0;

// Camera 3 m up, looking along +x (level), turned about the world's z axis by yaw.
SE3 cameraAt(double yaw) {
  SE3 T_W_C = SE3::Identity();
  T_W_C.linear() = Eigen::AngleAxisd(yaw, Vec3::UnitZ()).toRotationMatrix() *
                   cameraMountTransform(MountOptions{}).linear();
  T_W_C.translation() = Vec3(0.0, 0.0, 3.0);
  return T_W_C;
}

TEST(RollingShutter, PureYawLeansAVerticalLineOfMarkersByTheRateTimesTheReadout) {
  // A pinhole camera turning left at 60 deg/s with a 30 ms readout. Three markers on one vertical
  // line 4 m ahead: with a global shutter they share a column; with the rolling shutter each is
  // seen at its row's time, so the line leans by f * omega * readout / rows pixels per row (the
  // scene moves right, +u, as the camera turns left), and each marker lands where the camera
  // model projects it from the pose of its row's time.
  Scenario s = test::exactScenario();
  s.camera.model = "pinhole";
  s.camera.pinhole_width = 320;
  s.camera.pinhole_height = 240;
  s.camera.pinhole_hfov_deg = 60.0;
  s.world.num_rows = 0;
  s.world.backdrop = false;
  const camera::Camera cam = makeCamera(s.camera);
  const double f = camera::focalPx(cam);
  const int rows = camera::height(cam);
  VineyardWorld world(s.world, 1);
  const Renderer renderer(cam, s.render);
  const double omega = 60.0 * kDeg, readout = 0.03;
  std::vector<SE3> poses(rows);
  std::vector<double> times(rows);
  for (int v = 0; v < rows; ++v) {
    times[v] = readout * v / rows;
    poses[v] = cameraAt(omega * times[v]);
  }
  const double heights[] = {4.2, 3.0, 1.8};
  std::vector<Vec2> seen, global;
  for (double z : heights) {
    const Vec3 p_W(4.0, 0.0, z);
    // The row it shows in: project with the pose of the row's time until the row settles.
    Vec2 px = *camera::project(cam, poses[0].inverse() * p_W);
    for (int it = 0; it < 5; ++it) {
      const int v = std::clamp(static_cast<int>(std::lround(px.y())), 0, rows - 1);
      px = *camera::project(cam, poses[v].inverse() * p_W);
    }
    world.setMarkers({{p_W, 0.05, 1.0f}});
    const cv::Mat white = renderer.renderRadiance(world, poses, times);
    const cv::Mat white_global = renderer.renderRadiance(world, poses[0], 0.0);
    world.setMarkers({{p_W, 0.05, 0.0f}});
    const cv::Mat black = renderer.renderRadiance(world, poses, times);
    const cv::Mat black_global = renderer.renderRadiance(world, poses[0], 0.0);
    const auto c = test::diffCentroid(white, black, px, 12);
    const auto g = test::diffCentroid(white_global, black_global, px, 16);
    ASSERT_TRUE(c && g) << z;
    EXPECT_LT((*c - px).norm(), 0.3)
        << "z " << z << ": at " << c->transpose() << ", expected " << px.transpose();
    seen.push_back(*c);
    global.push_back(*g);
  }
  // Global shutter: one column. Rolling shutter: the bottom marker right of the top one by the
  // rate times the readout between their rows (small-angle pinhole: f * angle).
  EXPECT_NEAR(global[0].x(), global[2].x(), 0.1);
  const double lean = seen[2].x() - seen[0].x();
  const double expected = f * omega * readout * (seen[2].y() - seen[0].y()) / rows;
  EXPECT_GT(expected, 5.0);  // a clear effect: several pixels
  EXPECT_NEAR(lean, expected, 0.05 * expected);
}

TEST(RollingShutter, SimulatedFrameRowsAreThePosesOfTheirReadoutTimes) {
  // While driving (frame 200, t = 10 s): row v of a rolling-shutter frame is exactly row v of a
  // global-shutter render from the trajectory's pose at rowTime(k, v); the first row is the
  // global-shutter frame's, the last ones differ from it.
  Scenario s = test::exactScenario();
  s.frames = 201;
  s.camera.rolling_shutter_s = 0.03;
  Simulation rs(s);
  Scenario g = s;
  g.camera.rolling_shutter_s = 0.0;
  Simulation gs(g);
  const int k = 200;
  ASSERT_GT(rs.trajectory().state(rs.frameTime(k)).v_W.norm(), 0.5);
  const cv::Mat frame = rs.renderFrame(k), global = gs.renderFrame(k);
  const int rows = rs.renderer().height();
  EXPECT_NEAR(rs.rowTime(k, rows - 1) - rs.frameTime(k), 0.03 * (rows - 1) / rows, 1e-12);
  for (int v : {0, rows / 3, rows - 60}) {
    const double t = rs.rowTime(k, v);
    const cv::Mat radiance =
        rs.renderer().renderRadiance(rs.world(), rs.trajectory().T_W_B(t) * rs.T_B_C(), t);
    int differ = 0;
    for (int u = 0; u < radiance.cols; ++u) {  // renderFrame's conversion without noise, gain 1
      const float g = 255.0f * radiance.at<float>(v, u);
      const auto expected = static_cast<int>(std::clamp(std::lround(g), 0L, 255L));
      if (rs.renderer().validMask().at<std::uint8_t>(v, u) &&
          frame.at<std::uint8_t>(v, u) != expected)
        ++differ;
    }
    EXPECT_EQ(differ, 0) << "row " << v;
  }
  EXPECT_EQ(cv::countNonZero(frame.row(0) != global.row(0)), 0);
  EXPECT_GT(cv::norm(frame.row(rows - 60), global.row(rows - 60), cv::NORM_L1), 100.0);
}

}  // namespace
}  // namespace ovo::sim
