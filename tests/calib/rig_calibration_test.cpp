// Rig calibration: R_B_C, the camera-gyro time offset and the gyro bias recovered from camera
// rotations against gyro samples of a known motion, and from a short rendered sequence through
// the frontend; motions that cannot determine them are refused with a reason.
#include "calib/rig_calibration.hpp"

#include <gtest/gtest.h>

#include <random>

#include "common/config.hpp"
#include "common/so3.hpp"
#include "sim/scenario.hpp"
#include "sim/simulation.hpp"
#include "tests/test_support.hpp"

namespace ovo::calib {
namespace {

constexpr double kDeg = M_PI / 180.0;

// A smooth body angular velocity (rad/s, body frame): a turn plus rocking about x and y.
Vec3 omega(double t, bool single_axis) {
  const double z = 0.5 + 0.4 * std::sin(0.9 * t);
  if (single_axis) return Vec3(0, 0, z);
  return Vec3(0.35 * std::sin(3.1 * t) + 0.1 * std::sin(7.3 * t),
              0.3 * std::sin(2.3 * t + 1.0) + 0.1 * std::cos(6.1 * t), z);
}

struct Synthetic {
  std::vector<ImuSample> gyro;
  std::vector<CameraRotation> rotations;
};

// Gyro at 200 Hz (bias + white noise) and camera rotations at 20 Hz stamped t + t_d, with
// `rot_noise_deg` of noise on each.
Synthetic synthesize(const Mat3& R_B_C, double t_d, const Vec3& bias, bool single_axis,
                     double rot_noise_deg, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  Synthetic s;
  const double duration = 30.0, step = 1e-4;
  const Timestamp t0 = 1'000'000'000;
  // Body orientation by fine integration, kept every millisecond, past the last camera pair's
  // end (0.5 s + 596 pairs of 0.05 s: 30.35 s; it stopped at 30 s and the last pairs read past
  // the vector's end, which ASan's libstdc++ assertions caught).
  std::vector<Mat3> R_W_B{Mat3::Identity()};
  Mat3 R = Mat3::Identity();
  for (int i = 1; i <= static_cast<int>((duration + 1.0) / step); ++i) {
    const double t = (i - 0.5) * step;
    R = R * so3::exp(omega(t, single_axis) * step);
    if (i % 10 == 0) R_W_B.push_back(R);
  }
  const auto orientation = [&](double t) {
    return R_W_B.at(static_cast<std::size_t>(std::lround(t * 1000.0)));
  };
  for (int i = 0; i <= static_cast<int>(duration * 200); ++i) {
    const double t = i / 200.0;
    ImuSample g;
    g.t_ns = t0 + fromSeconds(t);
    g.gyro_radps =
        omega(t, single_axis) + bias + 1.7e-4 * std::sqrt(200.0) * ovo::test::draw3(n01, rng);
    s.gyro.push_back(g);
  }
  for (int k = 0; k + 1 < static_cast<int>(duration * 20) - 2; ++k) {
    const double ta = 0.5 + k * 0.05, tb = ta + 0.05;
    const Mat3 R_C0_C1 = R_B_C.transpose() * orientation(ta).transpose() * orientation(tb) * R_B_C;
    const Mat3 noise = so3::exp(rot_noise_deg * kDeg * ovo::test::draw3(n01, rng));
    s.rotations.push_back({t0 + fromSeconds(ta + t_d), t0 + fromSeconds(tb + t_d),
                           (R_C0_C1 * noise).transpose(), 100});
  }
  return s;
}

const Mat3 kR_B_C =
    (so3::exp(Vec3(0.05, -0.08, 0.12)) * (Mat3() << 0, 0, 1, -1, 0, 0, 0, -1, 0).finished()).eval();

TEST(RigCalibration, RecoversRotationOffsetAndBiasFromRotations) {
  const Vec3 bias(0.004, -0.006, 0.003);
  const Synthetic s = synthesize(kR_B_C, 0.0173, bias, false, 0.01, 1);
  const RigCalibration r = calibrateRigFromRotations(s.rotations, s.gyro, {});
  EXPECT_LT(so3::angle(r.R_B_C.transpose() * kR_B_C) / kDeg, 0.05);
  EXPECT_NEAR(r.time_offset_s, 0.0173, 2e-4);
  EXPECT_NEAR(r.coarse_offset_s, 0.0173, 2e-3);
  EXPECT_LT((r.gyro_bias_radps - bias).norm(), 5e-4);
  EXPECT_GT(r.correlation, 0.9);
}

TEST(RigCalibration, NegativeOffsetsToo) {
  const Synthetic s = synthesize(kR_B_C, -0.041, Vec3::Zero(), false, 0.01, 2);
  const RigCalibration r = calibrateRigFromRotations(s.rotations, s.gyro, {});
  EXPECT_NEAR(r.time_offset_s, -0.041, 2e-4);
  EXPECT_LT(so3::angle(r.R_B_C.transpose() * kR_B_C) / kDeg, 0.05);
}

// Every other pair gets 0.3 deg of extra noise along one axis of the camera (as a short
// baseline's rotation does, trading with its translation), and says so in its covariance: the
// weighted fit leans on the sharp pairs; weighting every pair alike (no covariances) does not
// (seed 6: 0.011 deg against 0.32).
TEST(RigCalibration, TheCovariancesLetTheSharpPairsDecide) {
  Synthetic s = synthesize(kR_B_C, 0.0173, Vec3::Zero(), false, 0.01, 6);
  std::mt19937 rng(16);
  std::normal_distribution<double> n01(0.0, 1.0);
  const Vec3 axis = Vec3(0.3, 1.0, 0.2).normalized();
  const double sharp = 0.01 * kDeg, wide = 0.3 * kDeg;
  for (std::size_t k = 0; k < s.rotations.size(); ++k) {
    CameraRotation& r = s.rotations[k];
    r.covariance = sharp * sharp * Mat3::Identity();
    if (k % 2 == 1) {
      const Vec3 extra = wide * n01(rng) * axis;
      r.R_C1_C0 = (r.R_C1_C0.transpose() * so3::exp(extra)).transpose();
      r.covariance += wide * wide * axis * axis.transpose();
    }
  }
  const RigCalibration weighted = calibrateRigFromRotations(s.rotations, s.gyro, {});
  for (CameraRotation& r : s.rotations) r.covariance.setZero();
  const RigCalibration alike = calibrateRigFromRotations(s.rotations, s.gyro, {});
  const double weighted_deg = so3::angle(weighted.R_B_C.transpose() * kR_B_C) / kDeg;
  const double alike_deg = so3::angle(alike.R_B_C.transpose() * kR_B_C) / kDeg;
  EXPECT_LT(weighted_deg, 0.03);
  EXPECT_LT(weighted_deg, 0.5 * alike_deg) << "alike: " << alike_deg;
  EXPECT_NEAR(weighted.time_offset_s, 0.0173, 2e-4);
}

TEST(RigCalibration, RefusesRotationAboutOneAxis) {
  const Synthetic s = synthesize(kR_B_C, 0.01, Vec3::Zero(), true, 0.02, 3);
  const std::string e = test::errorOf([&] { calibrateRigFromRotations(s.rotations, s.gyro, {}); });
  EXPECT_NE(e.find("one axis"), std::string::npos) << e;
}

TEST(RigCalibration, RefusesAnOffsetBeyondTheSearch) {
  const Synthetic s = synthesize(kR_B_C, 0.25, Vec3::Zero(), false, 0.02, 4);
  RigCalibrationOptions options;
  options.max_offset_s = 0.1;
  const std::string e =
      test::errorOf([&] { calibrateRigFromRotations(s.rotations, s.gyro, options); });
  EXPECT_NE(e.find("max-offset"), std::string::npos) << e;
}

TEST(RigCalibration, RefusesTooFewPairs) {
  Synthetic s = synthesize(kR_B_C, 0.0, Vec3::Zero(), false, 0.02, 5);
  s.rotations.resize(10);
  const std::string e = test::errorOf([&] { calibrateRigFromRotations(s.rotations, s.gyro, {}); });
  EXPECT_NE(e.find("usable frame pairs"), std::string::npos) << e;
}

// The whole path on rendered images: a small pinhole camera on a rocking turn, mounted turned
// away from the nominal mount, its frames stamped 8 ms late.
TEST(RigCalibration, FrontendRotationsOfARenderedTurn) {
  const Config config = Config::fromString(R"(
seed: 3
frames: 70
trajectory: {kind: spin, lead_in_m: 0, lead_out_m: 0, start_hold_s: 0.2, spin_deg: 120,
             spin_rate_dps: 45, ramp_s: 0.4, vibration_sigma_deg: 1.5, vibration_knot_s: 0.1}
camera: {model: pinhole, pinhole: {width: 320, height: 240, hfov_deg: 110},
         mount: {yaw_deg: 4, pitch_down_deg: 8, roll_deg: -3}}
nuisance: {exposure_changes: false}
)",
                                           "rig_test");
  const sim::Scenario scenario = sim::readScenario(config);
  const sim::Simulation sim(scenario);
  const Timestamp t_d = 8'000'000;
  RigInput input;
  input.camera = &sim.camera();
  input.frontend = frontend::readFrontendOptions(Config());
  input.frame_count = sim.frameCount();
  input.frame_stamp = [&](std::size_t k) { return sim.frameStamp(static_cast<int>(k)) + t_d; };
  input.frame_image = [&](std::size_t k) { return sim.renderFrame(static_cast<int>(k)); };
  input.gyro = sim.imu();
  RigCalibrationOptions options;
  options.max_offset_s = 0.05;
  const RigCalibration r = calibrateRig(input, options);
  const double rot_err = so3::angle(r.R_B_C.transpose() * sim.T_B_C().linear()) / kDeg;
  std::printf("rendered turn: R_B_C error %.3f deg, offset %.2f ms (truth 8), %d pairs\n", rot_err,
              r.time_offset_s * 1e3, r.pairs_used);
  EXPECT_LT(rot_err, 0.4);  // 320x240 pinhole, 3.5 s: the full-size measurement is in the README
  EXPECT_NEAR(r.time_offset_s, 0.008, 1e-3);
}

}  // namespace
}  // namespace ovo::calib
