// Gyroscope and accelerometer model of the body B (= IMU frame): exact body rate and specific force
// from the trajectory's analytic derivatives, plus a bias random walk and white noise
// (continuous-time densities discretised at the sample rate, as in Kalibr's IMU noise model).
#pragma once

#include <cstdint>
#include <vector>

#include "common/types.hpp"
#include "sim/scenario.hpp"
#include "sim/trajectory.hpp"

namespace ovo::sim {

/// The true gyro bias at one sample time.
struct GyroBiasSample {
  Timestamp t_ns = 0;
  Vec3 bias_radps = Vec3::Zero();
};

/// Gravity in W (m/s^2): z up.
inline Vec3 gravityW() { return Vec3(0.0, 0.0, -9.81); }

/// IMU samples at t_start_ns + k / rate for every time in [0, duration_s] of the trajectory:
/// gyro = omega_B + b_g + n_g, accel = R_W_B^T (a_W - g_W) + b_a + n_a.
/// Discretisation: n ~ N(0, density^2 * rate), b_{k+1} = b_k + N(0, walk^2 / rate).
/// With options.time_jitter_s > 0 each stamp is off its sample's true time by a Gaussian draw of
/// that std (cut at 3 std); the samples and `true_gyro_bias` stay at the true times.
std::vector<ImuSample> simulateImu(const BodyTrajectory& trajectory, const ImuOptions& options,
                                   double duration_s, Timestamp t_start_ns, std::uint64_t seed,
                                   std::vector<GyroBiasSample>* true_gyro_bias = nullptr);

}  // namespace ovo::sim
