// The spike test of each gyro sample against the last accepted one.
#include "estimator/common/gyro_spike_filter.hpp"

#include <cmath>

namespace ovo::estimator {

bool GyroSpikeFilter::accept(const ImuSample& s) {
  if (!s.gyro_radps.allFinite()) {
    ++rejected_;
    return false;
  }
  if (max_jump_radps_ <= 0.0 || !have_last_) {
    have_last_ = true;
    last_ = s;
    return true;
  }
  const double jump = (s.gyro_radps - last_.gyro_radps).cwiseAbs().maxCoeff();
  if (jump > max_jump_radps_) {
    if (rejecting_since_ < 0) rejecting_since_ = s.t_ns;
    if (s.t_ns - rejecting_since_ <= max_reject_ns_) {
      ++rejected_;
      return false;
    }
  }
  rejecting_since_ = -1;
  last_ = s;
  return true;
}

}  // namespace ovo::estimator
