// Time-ordered store of gyro samples shared by the estimators: hands out the samples around an
// interval (for preintegration) and drops what no estimator state needs any more. FrontendGyro is
// the frontend stage's thread-safe copy (for the matching prior).
#pragma once

#include <algorithm>
#include <cmath>
#include <deque>
#include <mutex>
#include <span>
#include <vector>

#include "common/types.hpp"

namespace ovo::estimator {

/// Mean and scatter of a frame's gyro samples (the kf's and the window's standstill tests).
struct GyroScatter {
  Vec3 sum = Vec3::Zero();
  double sq_sum = 0.0;  // sum of squared norms
  int count = 0;
  void add(const Vec3& w) {
    sum += w;
    sq_sum += w.squaredNorm();
    ++count;
  }
  Vec3 mean() const { return sum / count; }
  /// RMS deviation from the mean per axis (rad/s); count >= 1.
  double spread() const {
    return std::sqrt(std::max(0.0, sq_sum / count - mean().squaredNorm()) / 3.0);
  }
};

class GyroBuffer {
 public:
  /// Appends a sample; samples out of time order or with non-finite values are rejected (false).
  bool add(const ImuSample& s) {
    if (!s.gyro_radps.allFinite()) return false;
    if (!samples_.empty() && s.t_ns <= samples_.back().t_ns) return false;
    samples_.push_back(s);
    return true;
  }
  /// Samples from the last one at or before t0 to the first one at or after t1 (what
  /// factors::GyroPreintegration needs to interpolate at both ends).
  std::span<const ImuSample> around(Timestamp t0_ns, Timestamp t1_ns) const {
    auto lo = std::upper_bound(samples_.begin(), samples_.end(), t0_ns,
                               [](Timestamp t, const ImuSample& s) { return t < s.t_ns; });
    if (lo != samples_.begin()) --lo;
    auto hi = std::lower_bound(samples_.begin(), samples_.end(), t1_ns,
                               [](const ImuSample& s, Timestamp t) { return s.t_ns < t; });
    if (hi != samples_.end()) ++hi;
    if (hi < lo) hi = lo;
    return {samples_.data() + (lo - samples_.begin()), static_cast<std::size_t>(hi - lo)};
  }
  /// True when some sample is at or after t (the interval up to t can be integrated fully).
  bool covers(Timestamp t_ns) const { return !samples_.empty() && samples_.back().t_ns >= t_ns; }
  /// True when some sample is at or before t (nothing before t has been dropped yet).
  bool reaches(Timestamp t_ns) const { return !samples_.empty() && samples_.front().t_ns <= t_ns; }
  bool empty() const { return samples_.empty(); }
  const std::vector<ImuSample>& samples() const { return samples_; }
  /// Forgets samples older than t (keeping one before it for interpolation).
  void dropBefore(Timestamp t_ns) {
    auto it = std::lower_bound(samples_.begin(), samples_.end(), t_ns,
                               [](const ImuSample& s, Timestamp t) { return s.t_ns < t; });
    if (it != samples_.begin()) --it;
    samples_.erase(samples_.begin(), it);
  }

 private:
  std::vector<ImuSample> samples_;
};

/// The gyro as the frontend stage sees it: samples fed from any thread (ahead of the estimator
/// stage) and the biases the estimator stage published after each frame. The prior for the
/// interval from frame k-1 to frame k uses the bias published for frame k-1-lead (the newest one
/// published at or before that frame's time; zero before there is such a frame): when the stages
/// run on two threads, track(k) may run while update(k-lead) .. update(k-1) do, so a newer bias
/// would make the result depend on which thread is faster. Run in sequence, or in two threads with
/// track(k) started after update(k-1-lead), the poses are the same
/// (estimator::kFrontendLeadFrames).
class FrontendGyro {
 public:
  /// What the rotation prior from t0 to t1 needs: GyroBuffer::around(t0, t1) and the bias.
  struct Window {
    std::vector<ImuSample> samples;
    Vec3 bias_radps = Vec3::Zero();
  };

  /// lead_frames >= 0: how many frames the frontend stage may be ahead of the estimator stage.
  explicit FrontendGyro(int lead_frames) : lead_frames_(std::max(lead_frames, 0)) {}

  bool add(const ImuSample& s) {
    std::lock_guard lock(mutex_);
    return buffer_.add(s);
  }
  /// The estimator stage's bias after the frame at t_frame (frames in time order).
  void publishBias(Timestamp t_frame_ns, const Vec3& bias_radps) {
    std::lock_guard lock(mutex_);
    if (!biases_.empty() && t_frame_ns <= biases_.back().first) return;
    biases_.emplace_back(t_frame_ns, bias_radps);
  }
  /// The prior's inputs for the frontend's frame at t1 after its frame at t0: copies the samples
  /// around [t0, t1] and the bias published for the frame lead_frames before t0's, then forgets
  /// the samples and biases no later call needs (the frontend's frames come in time order, so t0
  /// is never earlier next time).
  Window take(Timestamp t0_ns, Timestamp t1_ns) {
    std::lock_guard lock(mutex_);
    const auto span = buffer_.around(t0_ns, t1_ns);
    Window w{{span.begin(), span.end()}, Vec3::Zero()};
    buffer_.dropBefore(t0_ns);
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

 private:
  const int lead_frames_;
  std::mutex mutex_;
  GyroBuffer buffer_;
  std::deque<std::pair<Timestamp, Vec3>> biases_;  // (frame time, bias), time order
  std::deque<Timestamp> frames_;                   // the frontend's last lead_frames + 1 frames
};

}  // namespace ovo::estimator
