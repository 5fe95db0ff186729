#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>

#include "camera/calib_io.hpp"
#include "frontend/features.hpp"
#include "sim/renderer.hpp"
#include "sim/simulation.hpp"
#include "sim/world.hpp"
#include "tests/sim/sim_test_support.hpp"

namespace ovo::sim {
namespace {

TEST(Render, WorldPointLandsWhereTheCameraModelProjectsIt) {
  const camera::Camera cam =
      camera::loadCamera(::ovo::test::sourcePath("configs/cameras/romovi_ocam.txt"));
  Scenario s = test::exactScenario();
  s.world.num_rows = 0;
  s.world.backdrop = false;
  VineyardWorld world(s.world, 1);
  const Renderer renderer(cam, s.render);
  SE3 T_W_C = SE3::Identity();
  T_W_C.linear() = cameraMountTransform(s.camera.mount).linear();
  T_W_C.translation() = Vec3(0.0, 0.0, 1.0);
  // Targets 2.5 m away along the bearings of pixels from the centre to the edges, where the fisheye
  // looks more than 90 degrees off its axis; all above the ground (the camera looks 12 deg down).
  const Vec2 pixels[] = {
      {348.0, 214.0}, {100.0, 150.0}, {600.0, 100.0}, {15.0, 235.0}, {630.0, 200.0}};
  for (const Vec2& pick : pixels) {
    const auto bearing = camera::unproject(cam, pick);
    ASSERT_TRUE(bearing);
    const Vec3 p_C = 2.5 * *bearing;
    const auto px = camera::project(cam, p_C);
    ASSERT_TRUE(px && camera::isValid(cam, *px)) << pick.transpose();
    const double off_axis_deg = std::acos(bearing->z()) * 180.0 / M_PI;
    const Vec3 p_W = T_W_C * p_C;
    // Render a white and a black marker: their difference is the marker's coverage alone.
    world.setMarkers({{p_W, 0.04, 1.0f}});
    const cv::Mat white = renderer.renderRadiance(world, T_W_C, 0.0);
    world.setMarkers({{p_W, 0.04, 0.0f}});
    const cv::Mat black = renderer.renderRadiance(world, T_W_C, 0.0);
    const auto centroid = test::diffCentroid(white, black, *px, 20);
    ASSERT_TRUE(centroid) << off_axis_deg;
    EXPECT_LT((*centroid - *px).norm(), 0.5)
        << "off-axis " << off_axis_deg << " deg: rendered at " << centroid->transpose()
        << ", projected at " << px->transpose();
  }
}

TEST(Render, CameraMountIsAppliedCameraToBody) {
  // A marker ahead of the robot, to its left and below the camera: with T_B_C applied in the right
  // direction it shows left of and below the principal point, where project(T_C_B p_B) says.
  Scenario s = test::exactScenario();
  s.world.num_rows = 0;
  s.world.backdrop = false;
  s.trajectory.jitter = 0.0;
  s.frames = 1;
  Simulation sim(s);
  const Vec3 p_B(3.0, 0.8,
                 -0.2);  // 0.1 m above the ground, the camera is 1 m up looking 12 deg down
  const Vec3 p_W = sim.trajectory().T_W_B(0.0) * p_B;
  const Vec3 p_C = sim.T_B_C().inverse() * p_B;
  const auto px = camera::project(sim.camera(), p_C);
  ASSERT_TRUE(px);
  const auto& ocam = std::get<camera::OcamCamera>(sim.camera());
  EXPECT_LT(px->x(), ocam.params().center_col - 50.0);  // left
  EXPECT_GT(px->y(), ocam.params().center_row + 20.0);  // below
  sim.world().setMarkers({{p_W, 0.05, 1.0f}});
  const cv::Mat white = sim.renderFrame(0);
  sim.world().setMarkers({{p_W, 0.05, 0.0f}});
  const cv::Mat black = sim.renderFrame(0);
  const auto centroid = test::diffCentroid(white, black, *px, 25);
  ASSERT_TRUE(centroid);
  EXPECT_LT((*centroid - *px).norm(), 0.5) << centroid->transpose() << " vs " << px->transpose();
}

// Image motion between two renders by least squares on the brightness-constancy equation
// (Lucas-Kanade over the whole patch), b(u) = a(u - d), on Gaussian-blurred copies so that the
// finite-difference gradients are exact enough (blurring commutes with a shift).
Vec2 measuredShift(const cv::Mat& a_in, const cv::Mat& b_in) {
  cv::Mat a, b;
  cv::GaussianBlur(a_in, a, cv::Size(0, 0), 2.0);
  cv::GaussianBlur(b_in, b, cv::Size(0, 0), 2.0);
  Eigen::Matrix2d H = Eigen::Matrix2d::Zero();
  Vec2 g = Vec2::Zero();
  for (int v = 8; v + 8 < a.rows; ++v)
    for (int u = 8; u + 8 < a.cols; ++u) {
      const auto m = [&](int uu, int vv) {
        return 0.5 * (a.at<float>(vv, uu) + b.at<float>(vv, uu));
      };
      const Vec2 grad(0.5 * (m(u + 1, v) - m(u - 1, v)), 0.5 * (m(u, v + 1) - m(u, v - 1)));
      H += grad * grad.transpose();
      g += grad * (b.at<float>(v, u) - a.at<float>(v, u));
    }
  return -H.ldlt().solve(g);
}

TEST(Render, SubPixelCameraRotationShiftsTheImageSmoothly) {
  // Anti-aliasing: a rotation worth a quarter or half a pixel moves the textured image by that much
  // (an aliased renderer snaps or sparkles instead), measured on an ideal pinhole view along the
  // inter-row. Rotating the camera about its +y axis moves the scene towards -u.
  Scenario s = test::exactScenario();
  s.camera.model = "pinhole";
  s.camera.pinhole_width = 320;
  s.camera.pinhole_height = 240;
  s.camera.pinhole_hfov_deg = 60.0;
  const camera::Camera cam = makeCamera(s.camera);
  const double f = camera::focalPx(cam);
  const VineyardWorld world(s.world, 5);
  const Renderer renderer(cam, s.render);
  SE3 T_W_C = SE3::Identity();
  T_W_C.linear() = cameraMountTransform(s.camera.mount).linear();
  T_W_C.translation() = Vec3(12.0, world.interrowY(2), 1.0);
  const cv::Rect centre(110, 70, 100, 100);
  const cv::Mat a = renderer.renderRadiance(world, T_W_C, 0.0)(centre).clone();
  for (double shift_px : {0.25, 0.5}) {
    SE3 T = T_W_C;
    T.linear() = T_W_C.linear() * Eigen::AngleAxisd(shift_px / f, Vec3::UnitY()).toRotationMatrix();
    const cv::Mat b = renderer.renderRadiance(world, T, 0.0)(centre).clone();
    const Vec2 d = measuredShift(a, b);
    EXPECT_NEAR(d.x(), -shift_px, 0.03) << d.transpose();
    EXPECT_NEAR(d.y(), 0.0, 0.03) << d.transpose();
  }
}

TEST(Render, FramesHaveHundredsOfLibviso2StyleFeatures) {
  // In the rows (frame 0) and in the headland turn (frame 400): blob and corner extrema of the 5x5
  // filters with |response| >= 50 after non-maximum suppression (frontend defaults).
  const Simulation sim(test::defaultScenario());
  for (int k : {0, 400}) {
    frontend::FeatureFrame features;
    frontend::extractFeatures(sim.renderFrame(k), frontend::DetectorOptions{},
                              sim.renderer().validMask(), &features);
    RecordProperty("features_frame_" + std::to_string(k), features.size());
    EXPECT_GT(features.size(), 300) << "frame " << k;
  }
}

}  // namespace
}  // namespace ovo::sim
