// Kannala-Brandt and pinhole radial-tangential models: agreement with OpenCV, round trips,
// analytic Jacobians against numeric ones, the variant front end.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <opencv2/calib3d.hpp>
#include <random>

#include "camera/camera.hpp"
#include "common/error.hpp"
#include "tests/test_support.hpp"

namespace ovo::camera {
namespace {

// TUM-VI cam0 (openvins_tumvi/kalibr_imucam_chain.yaml), 195 degree field of view.
KannalaBrandtCamera tumviCamera() {
  return KannalaBrandtCamera({.fx = 190.97847715128717,
                              .fy = 190.9733070521226,
                              .cx = 254.93170605935475,
                              .cy = 256.8974428996504,
                              .k1 = 0.0034823894022493434,
                              .k2 = 0.0007150348452162257,
                              .k3 = -0.0020532361418706202,
                              .k4 = 0.00020293673591811182,
                              .width = 512,
                              .height = 512});
}

// EuRoC cam0 (mav0/cam0/sensor.yaml) with an added k3.
PinholeRadtanCamera eurocCamera(double k3 = 0.0) {
  return PinholeRadtanCamera({.fx = 458.654,
                              .fy = 457.296,
                              .cx = 367.215,
                              .cy = 248.375,
                              .k1 = -0.28340811,
                              .k2 = 0.07395907,
                              .p1 = 0.00019359,
                              .p2 = 1.76187114e-05,
                              .k3 = k3,
                              .width = 752,
                              .height = 480});
}

Vec3 rayAt(double off_axis, double azimuth, double range) {
  return range * Vec3(std::sin(off_axis) * std::cos(azimuth),
                      std::sin(off_axis) * std::sin(azimuth), std::cos(off_axis));
}

template <typename Model>
void expectJacobians(const Model& cam, double max_off_axis, int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> az(-std::numbers::pi, std::numbers::pi),
      off(0.0, max_off_axis), range(0.3, 30.0);
  for (int i = 0; i < n; ++i) {
    // Sequenced draws, the last component first (see draw3 in tests/test_support.hpp).
    const double r = range(rng), a = az(rng), o = off(rng);
    const Vec3 p = rayAt(o, a, r);
    Eigen::Matrix<double, 2, 3> J;
    ASSERT_TRUE(cam.project(p, &J)) << p.transpose();
    const Eigen::MatrixXd J_num = test::numericJacobian(
        [&](const Eigen::VectorXd& x) -> Eigen::VectorXd { return *cam.project(Vec3(x)); }, p);
    SCOPED_TRACE(::testing::Message() << "p = " << p.transpose());
    OVO_EXPECT_JACOBIAN_NEAR(J, J_num, 1e-6);
  }
}

TEST(KannalaBrandt, MatchesOpenCvFisheyeProjectPoints) {
  const KannalaBrandtCamera cam = tumviCamera();
  const auto& p = cam.params();
  const cv::Matx33d K(p.fx, 0, p.cx, 0, p.fy, p.cy, 0, 0, 1);
  const cv::Vec4d D(p.k1, p.k2, p.k3, p.k4);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> az(-std::numbers::pi, std::numbers::pi), off(0.0, 1.5),
      range(0.5, 20.0);  // cv::fisheye works on x/z: z > 0 only
  std::vector<cv::Point3d> pts;
  for (int i = 0; i < 500; ++i) {
    // Sequenced draws, the last component first (see draw3 in tests/test_support.hpp).
    const double r = range(rng), a = az(rng), o = off(rng);
    const Vec3 q = rayAt(o, a, r);
    pts.emplace_back(q.x(), q.y(), q.z());
  }
  std::vector<cv::Point2d> px_cv;
  cv::fisheye::projectPoints(pts, px_cv, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const auto px = cam.project(Vec3(pts[i].x, pts[i].y, pts[i].z));
    ASSERT_TRUE(px);
    EXPECT_NEAR(px->x(), px_cv[i].x, 1e-8);
    EXPECT_NEAR(px->y(), px_cv[i].y, 1e-8);
  }
}

TEST(KannalaBrandt, RoundTripAndJacobiansBeyond90Degrees) {
  const KannalaBrandtCamera cam = tumviCamera();
  EXPECT_GT(cam.maxOffAxisRad(), std::numbers::pi / 2 + 0.2);
  expectJacobians(cam, cam.maxOffAxisRad() - 1e-3, 300, 5);
  // Exactly on and next to the axis.
  expectJacobians(cam, 1e-5, 5, 6);
  int beyond_90 = 0;
  for (int v = 0; v < cam.height(); v += 4)
    for (int u = 0; u < cam.width(); u += 4) {
      const Vec2 px(u, v);
      if (!cam.isValid(px)) continue;
      const Vec3 b = *cam.unproject(px);
      EXPECT_NEAR(b.norm(), 1.0, 1e-12);
      beyond_90 += b.z() < 0.0;
      EXPECT_LT((*cam.project(b) - px).norm(), 1e-7) << px.transpose();
    }
  EXPECT_GT(beyond_90, 100);  // the 195 degree lens sees behind its image plane in the corners
}

TEST(KannalaBrandt, OrientationOfPixelsAndRays) {
  const KannalaBrandtCamera cam = tumviCamera();
  const Vec2 c(cam.params().cx, cam.params().cy);
  EXPECT_GT(cam.unproject(c)->z(), 0.999999);
  EXPECT_GT(cam.unproject(c + Vec2(50, 0))->x(), 0.2);
  EXPECT_GT(cam.unproject(c + Vec2(0, 50))->y(), 0.2);
  EXPECT_FALSE(cam.project(Vec3(0, 0, -1)).has_value());  // 180 degrees: beyond its range
}

TEST(PinholeRadtan, MatchesOpenCvProjectPoints) {
  for (double k3 : {0.0, 0.01}) {
    const PinholeRadtanCamera cam = eurocCamera(k3);
    const auto& p = cam.params();
    const cv::Matx33d K(p.fx, 0, p.cx, 0, p.fy, p.cy, 0, 0, 1);
    const std::vector<double> D{p.k1, p.k2, p.p1, p.p2, p.k3};
    std::mt19937 rng(12);
    std::uniform_real_distribution<double> xy(-0.7, 0.7), depth(0.5, 20.0);
    std::vector<cv::Point3d> pts;
    for (int i = 0; i < 500; ++i) {
      const double z = depth(rng);
      // Sequenced draws, the last component first (see draw3 in tests/test_support.hpp).
      const double y = xy(rng), x = xy(rng);
      pts.emplace_back(x * z, y * z, z);
    }
    std::vector<cv::Point2d> px_cv;
    cv::projectPoints(pts, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D, px_cv);
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const auto px = cam.project(Vec3(pts[i].x, pts[i].y, pts[i].z));
      ASSERT_TRUE(px);
      EXPECT_NEAR(px->x(), px_cv[i].x, 1e-8);
      EXPECT_NEAR(px->y(), px_cv[i].y, 1e-8);
    }
  }
}

TEST(PinholeRadtan, RoundTripAndJacobians) {
  const PinholeRadtanCamera cam = eurocCamera(0.01);
  expectJacobians(cam, 0.7, 300, 7);
  for (int v = 0; v < cam.height(); v += 4)
    for (int u = 0; u < cam.width(); u += 4) {
      const Vec2 px(u, v);
      ASSERT_TRUE(cam.isValid(px)) << px.transpose();
      EXPECT_LT((*cam.project(*cam.unproject(px)) - px).norm(), 1e-8) << px.transpose();
    }
}

TEST(PinholeRadtan, IdealPinholeFromKittiProjection) {
  // KITTI 07 P0: fx = fy = 707.0912, cx = 601.8873, cy = 183.1104, 1226x370.
  const PinholeRadtanCamera cam(707.0912, 707.0912, 601.8873, 183.1104, 1226, 370);
  EXPECT_FALSE(cam.hasDistortion());
  const Vec2 px = *cam.project(Vec3(1.0, -0.5, 10.0));
  EXPECT_NEAR(px.x(), 601.8873 + 70.70912, 1e-9);
  EXPECT_NEAR(px.y(), 183.1104 - 35.35456, 1e-9);
  expectJacobians(cam, 0.9, 100, 8);
  EXPECT_FALSE(cam.project(Vec3(1, 0, 0)).has_value());
  EXPECT_FALSE(cam.project(Vec3(0, 0, -1)).has_value());
  EXPECT_FALSE(cam.isValid(Vec2(-1, 10)));
  EXPECT_FALSE(cam.isValid(Vec2(10, 370)));
}

TEST(CameraVariant, DispatchesToTheModel) {
  const Camera kb = tumviCamera(), pin = eurocCamera();
  EXPECT_EQ(modelName(kb), "kannala_brandt");
  EXPECT_EQ(modelName(pin), "pinhole_radtan");
  EXPECT_EQ(width(kb), 512);
  EXPECT_EQ(height(pin), 480);
  EXPECT_NEAR(focalPx(pin), 457.975, 1e-9);
  Eigen::Matrix<double, 2, 3> J;
  const Vec3 p(0.2, -0.1, 1.0);
  EXPECT_EQ(*project(pin, p, &J), *std::get<PinholeRadtanCamera>(pin).project(p));
  EXPECT_TRUE(isValid(kb, Vec2(256, 256)));
  EXPECT_NEAR((*unproject(kb, *project(kb, p)) - p.normalized()).norm(), 0.0, 1e-9);
}

TEST(CameraModels, ConstructorsRejectUnusableParameters) {
  EXPECT_THROW(PinholeRadtanCamera(0.0, 1.0, 0, 0, 10, 10), Error);
  EXPECT_THROW(PinholeRadtanCamera(1.0, 1.0, 0, 0, 0, 10), Error);
  KannalaBrandtParams kb;
  kb.fx = -1.0;
  kb.fy = 1.0;
  kb.width = kb.height = 10;
  EXPECT_THROW(KannalaBrandtCamera{kb}, Error);
  OcamParams ocam;
  ocam.ss = {1.0, 0.0};  // a0 > 0: forward rays would point backwards
  ocam.width = ocam.height = 10;
  EXPECT_THROW(OcamCamera{ocam}, Error);
}

}  // namespace
}  // namespace ovo::camera
