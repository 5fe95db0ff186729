#include "sim/imu.hpp"

#include <algorithm>
#include <cmath>

#include "sim/random.hpp"

namespace ovo::sim {

std::vector<ImuSample> simulateImu(const BodyTrajectory& trajectory, const ImuOptions& o,
                                   double duration_s, Timestamp t_start_ns, std::uint64_t seed,
                                   std::vector<GyroBiasSample>* true_gyro_bias) {
  Rng rng(subSeed(seed, 5));
  const double period_ns = 1e9 / o.rate_hz;
  const double dt = 1.0 / o.rate_hz;
  const int n = static_cast<int>(std::floor(duration_s * o.rate_hz + 1e-9)) + 1;
  // One draw a statement (sim/random.hpp): z first, then y, then x.
  const auto draw = [&rng](double sigma) {
    const double z = rng.normal();
    const double y = rng.normal();
    const double x = rng.normal();
    return Vec3(sigma * x, sigma * y, sigma * z);
  };
  Vec3 b_g = Vec3::Zero(), b_a = Vec3::Zero();
  if (o.noise) {
    b_g = draw(o.gyro_initial_bias_dps * M_PI / 180.0);
    b_a = draw(o.accel_initial_bias);
  }
  const double sg = o.gyro_noise_density / std::sqrt(dt),
               sa = o.accel_noise_density / std::sqrt(dt);
  const double wg = o.gyro_bias_random_walk * std::sqrt(dt),
               wa = o.accel_bias_random_walk * std::sqrt(dt);
  // Stamp jitter: its own stream, so the samples do not change with it.
  Rng jitter_rng(subSeed(seed, 11));
  std::vector<ImuSample> out;
  out.reserve(n);
  if (true_gyro_bias) true_gyro_bias->clear();
  for (int k = 0; k < n; ++k) {
    const Timestamp offset_ns = static_cast<Timestamp>(std::llround(k * period_ns));
    const double t = static_cast<double>(offset_ns) * 1e-9;
    const BodyState s = trajectory.state(t);
    ImuSample sample;
    sample.t_ns = t_start_ns + offset_ns;
    const Timestamp true_t_ns = sample.t_ns;
    if (o.time_jitter_s > 0.0)
      sample.t_ns += fromSeconds(o.time_jitter_s * std::clamp(jitter_rng.normal(), -3.0, 3.0));
    sample.gyro_radps = s.omega_B;
    sample.accel_mps2 = s.T_W_B.linear().transpose() * (s.a_W - gravityW());
    if (o.noise) {
      sample.gyro_radps += b_g + draw(sg);
      sample.accel_mps2 += b_a + draw(sa);
    }
    out.push_back(sample);
    if (true_gyro_bias) true_gyro_bias->push_back({true_t_ns, b_g});
    if (o.noise) {
      b_g += draw(wg);
      b_a += draw(wa);
    }
  }
  return out;
}

}  // namespace ovo::sim
