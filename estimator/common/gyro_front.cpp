// The gyro front's intake and preintegration, and the frontend stage's locked copy.
#include "estimator/common/gyro_front.hpp"

#include <algorithm>

namespace ovo::estimator {

GyroFront::GyroFront(const GyroFrontOptions& options)
    : options_(options), spikes_(options.max_jump_radps, options.max_spike_s) {}

GyroFront::Intake GyroFront::add(const ImuSample& sample) {
  // Order and finiteness first: a sample the buffer refuses must not become the spike filter's
  // reference.
  if (!buffer_.accepts(sample)) return Intake::kInvalid;
  if (!spikes_.accept(sample)) return Intake::kSpike;
  buffer_.add(sample);
  return Intake::kAccepted;
}

std::optional<factors::GyroPreintegration> GyroFront::preintegrate(Timestamp t0_ns, Timestamp t1_ns,
                                                                   const Vec3& bias_radps,
                                                                   Timestamp shift_ns) const {
  const Timestamp t0 = t0_ns - shift_ns, t1 = t1_ns - shift_ns;
  if (buffer_.empty() || t1 <= t0) return std::nullopt;
  return factors::GyroPreintegration(buffer_.around(t0, t1), t0, t1, bias_radps,
                                     options_.preintegration);
}

FrontendGyro::FrontendGyro(int lead_frames, const GyroFrontOptions& options)
    : lead_frames_(std::max(lead_frames, 0)), gyro_(options) {}

GyroFront::Intake FrontendGyro::add(const ImuSample& s) {
  std::lock_guard lock(mutex_);
  return gyro_.add(s);
}

void FrontendGyro::publishBias(Timestamp t_frame_ns, const Vec3& bias_radps) {
  std::lock_guard lock(mutex_);
  if (!biases_.empty() && t_frame_ns <= biases_.back().first) return;
  biases_.emplace_back(t_frame_ns, bias_radps);
}

FrontendGyro::Window FrontendGyro::take(Timestamp t0_ns, Timestamp t1_ns) {
  std::lock_guard lock(mutex_);
  const auto span = gyro_.around(t0_ns, t1_ns);
  Window w{{span.begin(), span.end()}, Vec3::Zero()};
  gyro_.dropBefore(t0_ns);
  if (frames_.empty() || t0_ns > frames_.back()) frames_.push_back(t0_ns);
  while (static_cast<int>(frames_.size()) > lead_frames_ + 1) frames_.pop_front();
  if (static_cast<int>(frames_.size()) <= lead_frames_) return w;  // no frame that far back yet
  auto after = std::upper_bound(biases_.begin(), biases_.end(), frames_.front(),
                                [](Timestamp t, const auto& b) { return t < b.first; });
  if (after != biases_.begin()) {
    --after;  // the newest published at or before frame k-1-lead
    w.bias_radps = after->second;
    biases_.erase(biases_.begin(), after);
  }
  return w;
}

}  // namespace ovo::estimator
