// The accelerometer as a tilt reference: what it measured between three keyframes against the
// acceleration their positions imply and gravity (optional; WindowOptions::accel_sigma_mps2).
//
// The window holds no velocities, so the accelerometer is compared with the second divided
// difference of three keyframe positions p0, p1, p2 (times t0 < t1 < t2), which is exactly the
// body's acceleration averaged with the hat weight M(t) (rising from t0 to t1, falling to t2,
// integral 1):
//   c ((p2 - p1) / dt2 - (p1 - p0) / dt1) = int M(t) a_W(t) dt,  c = 2 / (dt1 + dt2).
// The accelerometer measures f = R_W_B(t)^T (a_W - g_W) + b_a, so the same weighting of its
// samples, each turned into the middle keyframe's body frame by the gyro, gives
//   R_W_B1 (F - b_a) = int M a_W dt - g_W,   F = int M(t) R_B1_B(t) f(t) dt.
// F is built from two halves, each made when its later keyframe enters the window
// (AccelInterval, from the same samples as the keyframe's gyro factor). What this measures is the
// gravity direction in the keyframe's body frame: the roll and pitch that vision and gyro alone
// cannot tell from a slow drift. Gravity's direction in the window's world frame (the first
// keyframe's, not levelled) and the accelerometer bias are states of the whole run (GravityState).
#pragma once

#include <ceres/sized_cost_function.h>

#include <optional>
#include <span>

#include "common/types.hpp"

namespace ovo::factors {

/// The accelerometer over one keyframe interval [t0, t1] of the gyro clock, weighted for the hat
/// of the acceleration factor: rise = int (t - t0)/T R_B1_B(t) f dt (in the later keyframe's
/// frame), fall = int (t1 - t)/T R_B0_B(t) f dt (in the earlier one's); T = t1 - t0.
struct AccelInterval {
  Vec3 rise_B1 = Vec3::Zero();  // m/s
  Vec3 fall_B0 = Vec3::Zero();  // m/s
  double dt_s = 0.0;
};

/// Integrates the samples (gyro clock, bias-corrected gyro turning them) over [t0, t1]; nullopt
/// when the samples do not cover both ends, a step between them is longer than max_gap_s, or no
/// sample has an accelerometer reading (a gyro-only IMU writes zeros).
std::optional<AccelInterval> integrateAccel(std::span<const ImuSample> samples, Timestamp t0_ns,
                                            Timestamp t1_ns, const Vec3& gyro_bias_radps,
                                            double max_gap_s = 0.05);

/// The run's gravity and accelerometer states, one block of kGravityStateSize:
/// [alpha, beta, b_ax, b_ay, b_az]: gravity in W is g Rx(alpha) Ry(beta) (0, 0, -1) (the window's
/// world frame is its first keyframe's, tilted like the robot was), the bias in B (m/s^2).
constexpr int kGravityStateSize = 5;
/// The unit gravity direction in W of the state's angles.
Vec3 gravityDirection(const double* state);
/// The angles (alpha, beta) of a unit gravity direction in W, written into state[0..1].
void setGravityDirection(const Vec3& down_W, double* state);

/// r = [F / int M - b_a - R_W_B1^T (c ((p2 - p1)/dt2 - (p1 - p0)/dt1) - g d(alpha, beta))] / sigma
/// (m/s^2 over sigma, in the body frame B1: a turn of the whole world, gravity with it, leaves it
/// unchanged). Blocks: q_W_B1[4], p_W_B0[3], p_W_B1[3], p_W_B2[3], gravity state[5].
class AccelerationFactor final : public ceres::SizedCostFunction<3, 4, 3, 3, 3, kGravityStateSize> {
 public:
  /// first: the interval [t0, t1] (its rise is in B1); second: [t1, t2] (its fall is in B1).
  /// sigma_mps2: the specific force's own noise (vibration, the sensor); position_sigma_m: the
  /// keyframes' positions' noise, which the second difference turns into an acceleration noise
  /// that grows as the keyframes get closer (sqrt(6) sigma_p / (dt1 dt2) for equal steps).
  AccelerationFactor(const AccelInterval& first, const AccelInterval& second, double gravity_mps2,
                     double sigma_mps2, double position_sigma_m = 0.0);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Vec3 f_mean_B1_;  // F / int M: the weighted mean specific force in B1, m/s^2
  double dt1_, dt2_, gravity_, inv_sigma_;
};

/// r = b_a / sigma on the gravity state's bias part (the direction is free). Block: state[5].
class AccelBiasPriorFactor final : public ceres::SizedCostFunction<3, kGravityStateSize> {
 public:
  explicit AccelBiasPriorFactor(double sigma_mps2);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  double inv_sigma_;
};

}  // namespace ovo::factors
