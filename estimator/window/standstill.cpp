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

void StandstillBias::Sums::add(const Sample& s) {
  rotation_rad += s.rotation_rad;
  time_s += s.dt_s;
  rotation2_over_dt += s.rotation_rad.squaredNorm() / s.dt_s;
  ++frames;
}

void StandstillBias::add(Timestamp t_ns, const Vec3& rotation_rad, double dt_s) {
  if (!(dt_s > 0.0)) return;
  recent_.push_back({t_ns, rotation_rad, dt_s});
  ++open_frames_;
  // A frame more than trim_s before the newest is kept whenever the streak ends.
  const Timestamp trim_ns = fromSeconds(trim_s_);
  while (!recent_.empty() && recent_.front().t_ns <= t_ns - trim_ns) {
    counted_.add(recent_.front());
    recent_.pop_front();
  }
}

void StandstillBias::endStreak() {
  if (open_frames_ == 0) return;
  open_frames_ = 0;
  if (recent_.empty()) return;  // (trim_s 0: every frame counted already)
  const Timestamp keep_until = recent_.back().t_ns - fromSeconds(trim_s_);
  for (const Sample& s : recent_)
    if (s.t_ns <= keep_until) counted_.add(s);
  recent_.clear();
}

std::optional<StandstillBias::Estimate> StandstillBias::estimate(double min_time_s) const {
  Sums all = counted_;
  for (const Sample& s : recent_) all.add(s);
  Estimate e;
  e.time_s = all.time_s;
  if (!(e.time_s > 0.0) || e.time_s < min_time_s) return std::nullopt;
  e.bias_radps = all.rotation_rad / e.time_s;
  // A frame's mean rate has the variance noise_density^2 / dt per axis: chi2 is the sum over the
  // frames of |rotation / dt - bias|^2 dt / noise_density^2, from the sums.
  const double scatter = all.rotation2_over_dt - 2.0 * e.bias_radps.dot(all.rotation_rad) +
                         e.bias_radps.squaredNorm() * all.time_s;
  const double chi2 = std::max(0.0, scatter) / (noise_density_ * noise_density_);
  e.chi2_dof = all.frames > 1 ? chi2 / (3.0 * (all.frames - 1)) : 1.0;
  e.sigma_radps = std::sqrt(noise_density_ * noise_density_ / e.time_s +
                            bias_random_walk_ * bias_random_walk_ * e.time_s) *
                  std::sqrt(std::max(1.0, e.chi2_dof));
  return e;
}

void StandstillBias::reset() {
  counted_ = {};
  recent_.clear();
  open_frames_ = 0;
}

}  // namespace ovo::estimator
