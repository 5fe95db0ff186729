// The standstill test of a frame and the zero-rate update's bias estimate.
#include "estimator/window/standstill.hpp"

#include <algorithm>
#include <cmath>

namespace ovo::estimator {

bool isStill(const StillEvidence& e, bool use_gyro, bool initialized,
             const WindowOptions& options) {
  bool gyro_quiet = !use_gyro || e.rate_radps < options.standstill_gyro_radps;
  if (use_gyro && e.gyro_samples >= 3)
    gyro_quiet = e.gyro_spread_radps <= options.standstill_gyro_std_radps &&
                 (!initialized || e.rate_radps < options.standstill_gyro_radps);
  return e.has_observations && e.flow_px < options.standstill_flow_px && gyro_quiet;
}

std::optional<double> medianFlowPx(const std::unordered_map<TrackId, TrackObservation>& obs,
                                   const std::unordered_map<TrackId, TrackObservation>& last_obs) {
  std::vector<double> flows;
  for (const auto& [id, o] : obs) {
    auto it = last_obs.find(id);
    if (it != last_obs.end()) flows.push_back((o.px - it->second.px).norm());
  }
  if (flows.size() < 10) return std::nullopt;
  auto mid = flows.begin() + static_cast<long>(flows.size() / 2);
  std::nth_element(flows.begin(), mid, flows.end());
  return *mid;
}

void addZeroRate(Keyframe& kf, const Vec3& bias_radps, double sigma_radps) {
  if (!kf.zero_rate) {
    kf.zero_rate = Keyframe::ZeroRate{bias_radps, sigma_radps};
    return;
  }
  const double w0 = 1.0 / (kf.zero_rate->sigma_radps * kf.zero_rate->sigma_radps);
  const double w1 = 1.0 / (sigma_radps * sigma_radps);
  kf.zero_rate->bias_radps = (w0 * kf.zero_rate->bias_radps + w1 * bias_radps) / (w0 + w1);
  kf.zero_rate->sigma_radps = 1.0 / std::sqrt(w0 + w1);
}

void StandstillBias::add(Timestamp t_ns, const Vec3& rotation_rad, double dt_s) {
  if (dt_s > 0.0) open_.push_back({t_ns, rotation_rad, dt_s});
}

void StandstillBias::endStreak() {
  if (open_.empty()) return;
  const Timestamp keep_until = open_.back().t_ns - fromSeconds(trim_s_);
  for (const Sample& s : open_)
    if (s.t_ns <= keep_until) ended_.push_back(s);
  open_.clear();
}

std::optional<StandstillBias::Estimate> StandstillBias::estimate(double min_time_s) const {
  Estimate e;
  Vec3 rotation = Vec3::Zero();
  for (const auto* samples : {&ended_, &open_})
    for (const Sample& s : *samples) {
      rotation += s.rotation_rad;
      e.time_s += s.dt_s;
    }
  if (!(e.time_s > 0.0) || e.time_s < min_time_s) return std::nullopt;
  e.bias_radps = rotation / e.time_s;
  // A frame's mean rate has the variance noise_density^2 / dt per axis.
  double chi2 = 0.0;
  int n = 0;
  for (const auto* samples : {&ended_, &open_})
    for (const Sample& s : *samples) {
      chi2 += (s.rotation_rad / s.dt_s - e.bias_radps).squaredNorm() * s.dt_s /
              (noise_density_ * noise_density_);
      ++n;
    }
  e.chi2_dof = n > 1 ? chi2 / (3.0 * (n - 1)) : 1.0;
  e.sigma_radps = std::sqrt(noise_density_ * noise_density_ / e.time_s +
                            bias_random_walk_ * bias_random_walk_ * e.time_s) *
                  std::sqrt(std::max(1.0, e.chi2_dof));
  return e;
}

void StandstillBias::reset() {
  ended_.clear();
  open_.clear();
}

}  // namespace ovo::estimator
