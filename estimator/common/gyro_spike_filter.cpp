// The spike test of each gyro sample against the last accepted one.
#include "estimator/common/gyro_spike_filter.hpp"

#include <cmath>

namespace ovo::estimator {

bool GyroSpikeFilter::accept(const ImuSample& s) {
  if (!s.gyro_radps.allFinite()) {
    ++rejected_;
    return false;
  }
  if (max_jump_radps_ <= 0.0) return true;
  if (!have_last_) {
    // A robot starts from rest: the first sample is judged against a zero rate, so that a spike
    // at start-up is not the reference every later sample jumps from.
    have_last_ = true;
    last_.t_ns = s.t_ns;
    last_.gyro_radps.setZero();
  }
  const auto jump = [&](const Vec3& from) { return (s.gyro_radps - from).cwiseAbs().maxCoeff(); };
  // A return is remembered for max_reject_s: a return that was itself one bad sample (a dropout
  // to zero in a fast turn) is followed at once by a return to the level it left.
  if (after_lasting_jump_ && returned_at_ns_ >= 0 && s.t_ns - returned_at_ns_ > max_reject_ns_)
    after_lasting_jump_ = false;
  if (jump(last_.gyro_radps) > max_jump_radps_) {
    if (after_lasting_jump_ && jump(before_jump_radps_) <= max_jump_radps_) {
      // The end of a jump that lasted (e.g. a saturation longer than max_reject_s): back to the
      // rate before it, which is no spike.
      before_jump_radps_ = last_.gyro_radps;
      returned_at_ns_ = s.t_ns;
    } else {
      if (rejecting_since_ < 0) rejecting_since_ = s.t_ns;
      if (s.t_ns - rejecting_since_ <= max_reject_ns_) {
        ++rejected_;
        return false;
      }
      after_lasting_jump_ = true;  // taken as real: remember where it came from
      before_jump_radps_ = last_.gyro_radps;
      returned_at_ns_ = -1;
    }
  }
  rejecting_since_ = -1;
  last_ = s;
  return true;
}

}  // namespace ovo::estimator
