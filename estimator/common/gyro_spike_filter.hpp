// The gyro's spikes: samples whose rate jumps from the last accepted one by more than a ground
// robot can turn in one sample period (a clipped or corrupted reading, e.g. a few samples at the
// sensor's full scale). They are rejected for a short while; a jump that persists is accepted as
// real motion, and so is the return from it to the rate before. The robot is taken to start from
// rest (the first sample is judged against a zero rate).
#pragma once

#include "common/types.hpp"

namespace ovo::estimator {

class GyroSpikeFilter {
 public:
  /// max_jump_radps: the largest change of any axis' rate from the last accepted sample (<= 0:
  /// no filter); max_reject_s: how long a jump may be rejected before it is taken as real.
  GyroSpikeFilter(double max_jump_radps, double max_reject_s)
      : max_jump_radps_(max_jump_radps), max_reject_ns_(fromSeconds(max_reject_s)) {}

  /// True when the sample is to be used.
  bool accept(const ImuSample& s);
  int rejected() const { return rejected_; }

 private:
  double max_jump_radps_;
  Timestamp max_reject_ns_;
  bool have_last_ = false;
  ImuSample last_;
  Timestamp rejecting_since_ = -1;  // first rejected sample of the current run (-1: none)
  bool after_lasting_jump_ = false;  // a jump lasted max_reject_s and was taken as real ...
  Vec3 before_jump_radps_ = Vec3::Zero();  // ... from this rate: a return to it is accepted
  Timestamp returned_at_ns_ = -1;  // the last return (-1: none); remembered for max_reject_s
  int rejected_ = 0;
};

}  // namespace ovo::estimator
