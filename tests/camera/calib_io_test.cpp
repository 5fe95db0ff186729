// Calibration files: EuRoC sensor.yaml, Kalibr camchains, writers and their round trips, errors.
#include "camera/calib_io.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "common/error.hpp"
#include "tests/test_support.hpp"

namespace ovo::camera {
namespace {

constexpr const char* kEurocSensor = "euroc-v101-micro/mav0/cam0/sensor.yaml";
constexpr const char* kEurocKalibr = "euroc-v101-micro/calib/openvins_kalibr_imucam_chain.yaml";
constexpr const char* kTumviKalibr = "fisheye-calib-refs/openvins_tumvi/kalibr_imucam_chain.yaml";

TEST(CalibIo, LoadsEurocSensorYamlAsPinholeRadtan) {
  OVO_REQUIRE_DATA(kEurocSensor);
  const Camera cam = loadCamera(test::sharedData(kEurocSensor));
  ASSERT_EQ(modelName(cam), "pinhole_radtan");
  const auto& p = std::get<PinholeRadtanCamera>(cam).params();
  EXPECT_EQ(p.fx, 458.654);
  EXPECT_EQ(p.cy, 248.375);
  EXPECT_EQ(p.k1, -0.28340811);
  EXPECT_EQ(p.p2, 1.76187114e-05);
  EXPECT_EQ(p.k3, 0.0);
  EXPECT_EQ(p.width, 752);
  EXPECT_EQ(p.height, 480);
}

TEST(CalibIo, ReadsSensorYamlExtrinsicsAsCameraToBody) {
  OVO_REQUIRE_DATA(kEurocSensor);
  const auto T_B_C = readSensorYamlExtrinsics(test::sharedData(kEurocSensor));
  ASSERT_TRUE(T_B_C);
  EXPECT_NEAR(T_B_C->translation().x(), -0.0216401454975, 1e-12);
  EXPECT_NEAR(T_B_C->translation().y(), -0.064676986768, 1e-12);
  EXPECT_NEAR(T_B_C->linear()(0, 1), -0.999880929698, 1e-6);
  // The Kalibr chain of the same camera stores T_imu_cam: the same transform.
  const auto T_kalibr = readSensorYamlExtrinsics(test::sharedData(kEurocKalibr));
  ASSERT_TRUE(T_kalibr);
  EXPECT_LT((T_kalibr->matrix() - T_B_C->matrix()).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(CalibIo, LoadsKalibrCamchains) {
  OVO_REQUIRE_DATA(kTumviKalibr);
  const Camera kb = loadCamera(test::sharedData(kTumviKalibr));
  ASSERT_EQ(modelName(kb), "kannala_brandt");
  EXPECT_EQ(std::get<KannalaBrandtCamera>(kb).params().k4, 0.00020293673591811182);
  EXPECT_EQ(width(kb), 512);
  // TUM-VI stores T_cam_imu: T_B_C is its inverse.
  const auto T_B_C = readSensorYamlExtrinsics(test::sharedData(kTumviKalibr));
  ASSERT_TRUE(T_B_C);
  const Vec3 p_C_of_imu(0.04727988224914392, -0.047443232143367084, -0.0681999605066297);
  EXPECT_LT((T_B_C->inverse().translation() - p_C_of_imu).norm(), 1e-9);
  const Camera radtan = loadCamera(test::sharedData(kEurocKalibr));
  EXPECT_EQ(modelName(radtan), "pinhole_radtan");
}

TEST(CalibIo, SensorYamlWriteReadRoundTrip) {
  const SE3 T_B_C =
      Eigen::Translation3d(0.1, -0.2, 0.3) * Eigen::AngleAxisd(0.4, Vec3(1, 2, 3).normalized());
  const Camera cams[] = {PinholeRadtanCamera({.fx = 320.5,
                                              .fy = 321.25,
                                              .cx = 319.5,
                                              .cy = 239.5,
                                              .k1 = -0.1,
                                              .k2 = 0.01,
                                              .p1 = 1e-4,
                                              .p2 = -2e-4,
                                              .k3 = 0.001,
                                              .width = 640,
                                              .height = 480}),
                         KannalaBrandtCamera({.fx = 190.1,
                                              .fy = 190.2,
                                              .cx = 255.3,
                                              .cy = 256.4,
                                              .k1 = 0.0035,
                                              .k2 = 7e-4,
                                              .k3 = -2e-3,
                                              .k4 = 2e-4,
                                              .width = 512,
                                              .height = 512})};
  for (const Camera& cam : cams) {
    const auto file = test::tempDir() / "sensor.yaml";
    writeSensorYaml(file, cam, T_B_C, 20.0);
    const Camera back = loadCamera(file);
    ASSERT_EQ(modelName(back), modelName(cam));
    for (const Vec3& p : {Vec3(0.3, -0.2, 1.0), Vec3(-1.0, 0.5, 2.0)})
      EXPECT_EQ(*project(back, p), *project(cam, p));
    const auto T = readSensorYamlExtrinsics(file);
    ASSERT_TRUE(T);
    EXPECT_LT((T->matrix() - T_B_C.matrix()).cwiseAbs().maxCoeff(), 1e-12);
  }
  EXPECT_THROW(writeSensorYaml(test::tempDir() / "x.yaml",
                               OcamCamera(OcamParams{.ss = {-300.0, 0.0, 1e-3},
                                                     .invpol = {},
                                                     .center_row = 240,
                                                     .center_col = 320,
                                                     .c = 1,
                                                     .d = 0,
                                                     .e = 0,
                                                     .height = 480,
                                                     .width = 640}),
                               T_B_C, 20.0),
               Error);
}

void expectYamlError(const std::string& yaml, const std::string& expected_part) {
  const auto file = test::tempDir() / "bad.yaml";
  std::ofstream(file) << yaml;
  try {
    loadCamera(file);
    ADD_FAILURE() << "no error, expected: " << expected_part;
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(file.string()), std::string::npos) << msg;
    EXPECT_NE(msg.find(expected_part), std::string::npos) << msg;
  }
}

TEST(CalibIo, BadYamlNamesFileAndKey) {
  const std::string head = "%YAML:1.0\ncamera_model: pinhole\nresolution: [752, 480]\n";
  expectYamlError(head + "distortion_model: radtan\ndistortion_coefficients: [1, 2, 3, 4]\n",
                  "intrinsics");
  expectYamlError(head + "intrinsics: [458, 457, abc, 248]\n", "intrinsics");
  expectYamlError(head + "intrinsics: [458, 457, 367]\n", "intrinsics");
  expectYamlError(head +
                      "intrinsics: [458, 457, 367, 248]\ndistortion_model: fov\n"
                      "distortion_coefficients: [1]\n",
                  "distortion_model");
  expectYamlError(head +
                      "intrinsics: [458, 457, 367, 248]\ndistortion_model: equidistant\n"
                      "distortion_coefficients: [1, 2]\n",
                  "distortion_coefficients");
  expectYamlError(head + "intrinsics: [458, 457, .nan, 248]\n", "non-finite");
  expectYamlError(head + "intrinsics: [458, 457, 367, 480]\n", "lies outside the 752x480 image");
  expectYamlError(head + "intrinsics: [458, 457, -1, 248]\n", "principal point (-1, 248)");
  expectYamlError("camera_model: omni\n", "camera_model");
  expectYamlError("camera_model: [pinhole\n", ":2:");
  expectYamlError(head + "intrinsics: [458, 457, 367, 248]\nintrinsics: [1, 1, 376, 240]\n",
                  ":5: key 'intrinsics' given twice (first on line 4)");
  EXPECT_THROW(loadCamera(test::tempDir() / "absent.yaml"), Error);
  // A Kalibr cam0 that is a value, not a mapping: yaml-cpp's BadSubscript escaped (fuzzing).
  expectYamlError("cam0:\n  T_imu_cam:90\n", "'cam0' must be a mapping");
  expectYamlError("cam0: [1, 2]\n", "'cam0' must be a mapping");
  // A side beyond int's range was converted to int first (undefined; UBSan under fuzzing).
  const std::string intr = "intrinsics: [458, 457, 367, 248]\n";
  expectYamlError("camera_model: pinhole\nresolution: [5.5e59, 480]\n" + intr, "'resolution'");
  expectYamlError("camera_model: pinhole\nresolution: [752, -480]\n" + intr, "'resolution'");
  expectYamlError("camera_model: pinhole\nresolution: [752.5, 480]\n" + intr, "whole numbers");
}

}  // namespace
}  // namespace ovo::camera

namespace ovo::camera {
namespace {

TEST(ShippedCameras, LoadWithTheirDocumentedFieldOfView) {
  const Camera pin = loadCamera(test::sourcePath("configs/cameras/pinhole_640x480.yaml"));
  ASSERT_EQ(modelName(pin), "pinhole_radtan");
  const Vec3 left = *unproject(pin, Vec2(-0.5, 239.5)), right = *unproject(pin, Vec2(639.5, 239.5));
  EXPECT_NEAR(std::acos(left.dot(right)) * 180 / M_PI, 90.0, 1e-9);
  const Camera ocam = loadCamera(test::sourcePath("configs/cameras/romovi_ocam.txt"));
  ASSERT_EQ(modelName(ocam), "ocam");
  EXPECT_EQ(width(ocam), 640);
  EXPECT_FALSE(readSensorYamlExtrinsics(test::sourcePath("configs/cameras/pinhole_640x480.yaml")));
}

}  // namespace
}  // namespace ovo::camera
