// The frame log's output: a frame recorded against a keyframe's vision pose is placed by that pose
// when the keyframe's body (gyro-chain) orientation differs from its vision orientation.
#include "estimator/window/frame_log.hpp"

#include <gtest/gtest.h>

#include "common/so3.hpp"

namespace ovo::estimator {
namespace {

TEST(FrameLog, AFramesOffsetIsNotTurnedByTheKeyframesVisionGyroDisagreement) {
  // The keyframe at (2, 1, 0): vision and gyro chain disagree by 10 deg in yaw; the frame was
  // tracked 1 m ahead of the keyframe along the vision's x and turned 5 deg by vision.
  KeyframeState kf;
  kf.vision = SE3::Identity();
  kf.vision.translation() = Vec3(2.0, 1.0, 0.0);
  kf.body = kf.vision;
  kf.body.linear() = so3::exp(Vec3(0.0, 0.0, 10.0 * M_PI / 180.0));
  FrameRecord r;
  r.t_ns = 1;
  r.ref_kf = 4;
  r.T_kf_B = SE3::Identity();
  r.T_kf_B.translation() = Vec3(1.0, 0.0, 0.0);
  r.T_kf_B.linear() = so3::exp(Vec3(0.0, 0.0, 5.0 * M_PI / 180.0));
  r.T_W_B = kf.vision * r.T_kf_B;
  FrameLog log;
  log.add(r);
  const auto lookup = [&](int id) -> std::optional<KeyframeState> {
    if (id == 4) return kf;
    return std::nullopt;
  };
  const Trajectory t = log.trajectory(lookup);
  ASSERT_EQ(t.size(), 1u);
  EXPECT_LT((t[0].T_W_B.translation() - Vec3(3.0, 1.0, 0.0)).norm(), 1e-12)
      << t[0].T_W_B.translation().transpose();
  // The orientation is the body's and the frame's own turn: 15 deg.
  EXPECT_NEAR(so3::angle(t[0].T_W_B.linear()), 15.0 * M_PI / 180.0, 1e-12);
}

// A frame's gyro rotation integrated with one time offset and re-timed to a later estimate: the
// same as integrating at the later offset. The rate ramps about z (w = a t) and turns at a
// constant 0.2 rad/s about x, so the span's rotation depends on where it starts.
TEST(GyroSpan, ASpanRetimedToALaterOffsetIsTheSpanIntegratedThere) {
  const double a = 0.8;  // rad/s^2
  const auto rotation = [&](double t0, double t1) {
    const int n = 20000;
    Mat3 R = Mat3::Identity();
    const double dt = (t1 - t0) / n;
    for (int i = 0; i < n; ++i) {
      const double t = t0 + (i + 0.5) * dt;
      R = R * so3::exp(Vec3(0.2, 0.0, a * t) * dt);
    }
    return R;
  };
  const double t0 = 1.0, t1 = 1.6, s_then = 0.01, s_now = 0.034;
  GyroSpan span;
  span.dR = rotation(t0 - s_then, t1 - s_then);
  span.shift_s = s_then;
  span.rate_start_radps = Vec3(0.2, 0.0, a * (t0 - s_then));
  span.rate_end_radps = Vec3(0.2, 0.0, a * (t1 - s_then));
  const Mat3 expected = rotation(t0 - s_now, t1 - s_now);
  const double before = so3::angle(span.at(Vec3::Zero()).transpose() * expected);
  const double after = so3::angle(span.at(Vec3::Zero(), s_now).transpose() * expected);
  EXPECT_GT(before, 0.01);  // 24 ms at a rate that changes by 0.48 rad/s over the span
  EXPECT_LT(after, 0.02 * before);
  EXPECT_EQ(span.at(Vec3::Zero(), s_then), span.at(Vec3::Zero()));
}

}  // namespace
}  // namespace ovo::estimator
