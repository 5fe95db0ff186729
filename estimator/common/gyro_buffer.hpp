// Time-ordered store of gyro samples (GyroFront's): hands out the samples around an interval (for
// preintegration) and drops what no estimator state needs any more; and the mean and scatter of a
// frame's samples (the standstill tests).
#pragma once

#include <algorithm>
#include <cmath>
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
  /// True when add() would take the sample: finite and later than the last one.
  bool accepts(const ImuSample& s) const {
    return s.gyro_radps.allFinite() && (samples_.empty() || s.t_ns > samples_.back().t_ns);
  }
  /// Appends a sample; samples out of time order or with non-finite values are rejected (false).
  bool add(const ImuSample& s) {
    if (!accepts(s)) return false;
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

}  // namespace ovo::estimator
