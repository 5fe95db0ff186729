// The one gyro front of every estimator: each sample checked (finite, later than the last),
// cleaned of spikes (GyroSpikeFilter), kept in time order (GyroBuffer), integrated over an
// interval of image time or of the gyro's own clock (image stamps run ahead of the gyro clock by
// the camera-gyro time offset), and trimmed to what later intervals need. The window and the kf
// own one for their estimator stage; FrontendGyro gives the frontend stage's matching prior its
// own, behind a mutex, so that the prior sees the same cleaned samples as the estimator.
#pragma once

#include <deque>
#include <mutex>
#include <optional>
#include <span>
#include <utility>
#include <vector>

#include "common/types.hpp"
#include "estimator/common/gyro_buffer.hpp"
#include "estimator/common/gyro_spike_filter.hpp"
#include "factors/gyro_preintegration.hpp"

namespace ovo::estimator {

struct GyroFrontOptions {
  // A sample whose rate jumps by more than this from the last accepted one, on any axis, is a
  // spike (<= 0: no spike filter), rad/s ...
  double max_jump_radps = 10.0;
  double max_spike_s = 0.05;  // ... for at most this long (a jump that lasts is real), s
  factors::GyroPreintegrationOptions preintegration;
};

class GyroFront {
 public:
  enum class Intake {
    kAccepted,
    kInvalid,  // not finite, or not later than the last sample taken
    kSpike,    // a spike (GyroSpikeFilter)
  };

  explicit GyroFront(const GyroFrontOptions& options = {});

  Intake add(const ImuSample& sample);

  /// The rotation over [t0, t1] of image time: the gyro's interval [t0 - shift, t1 - shift]
  /// (shift_ns: how far the image stamps run ahead of the gyro clock); nullopt without samples or
  /// for an empty interval.
  std::optional<factors::GyroPreintegration> preintegrate(Timestamp t0_ns, Timestamp t1_ns,
                                                          const Vec3& bias_radps,
                                                          Timestamp shift_ns = 0) const;

  /// Samples from the last one at or before t0 to the first one at or after t1 (gyro clock).
  std::span<const ImuSample> around(Timestamp t0_ns, Timestamp t1_ns) const {
    return buffer_.around(t0_ns, t1_ns);
  }
  /// True when some sample is at or after t / at or before t (gyro clock).
  bool covers(Timestamp t_ns) const { return buffer_.covers(t_ns); }
  bool reaches(Timestamp t_ns) const { return buffer_.reaches(t_ns); }
  bool empty() const { return buffer_.empty(); }
  const std::vector<ImuSample>& samples() const { return buffer_.samples(); }
  /// Forgets the samples older than t (keeping one before it for interpolation).
  void dropBefore(Timestamp t_ns) { buffer_.dropBefore(t_ns); }

  int spikes() const { return spikes_.rejected(); }

 private:
  GyroFrontOptions options_;
  GyroSpikeFilter spikes_;
  GyroBuffer buffer_;
};

/// The gyro as the frontend stage sees it: samples fed from any thread (ahead of the estimator
/// stage) through a GyroFront of its own, and the biases the estimator stage published after each
/// frame. The prior for the interval from frame k-1 to frame k uses the bias published for frame
/// k-1-lead (the newest one published at or before that frame's time; zero before there is such
/// a frame): when the stages run on two threads, track(k) may run while update(k-lead) ..
/// update(k-1) do, so a newer bias would make the result depend on which thread is faster. Run in
/// sequence, or in two threads with track(k) started after update(k-1-lead), the poses are the
/// same (estimator::kFrontendLeadFrames).
class FrontendGyro {
 public:
  /// What the rotation prior from t0 to t1 needs: GyroFront::around(t0, t1) and the bias.
  struct Window {
    std::vector<ImuSample> samples;
    Vec3 bias_radps = Vec3::Zero();
  };

  /// lead_frames >= 0: how many frames the frontend stage may be ahead of the estimator stage.
  explicit FrontendGyro(int lead_frames, const GyroFrontOptions& options = {});

  GyroFront::Intake add(const ImuSample& s);
  /// The estimator stage's bias after the frame at t_frame (frames in time order).
  void publishBias(Timestamp t_frame_ns, const Vec3& bias_radps);
  /// The prior's inputs for the frontend's frame at t1 after its frame at t0: copies the samples
  /// around [t0, t1] and the bias published for the frame lead_frames before t0's, then forgets
  /// the samples and biases no later call needs (the frontend's frames come in time order, so t0
  /// is never earlier next time).
  Window take(Timestamp t0_ns, Timestamp t1_ns);

 private:
  const int lead_frames_;
  std::mutex mutex_;
  GyroFront gyro_;
  std::deque<std::pair<Timestamp, Vec3>> biases_;  // (frame time, bias), time order
  std::deque<Timestamp> frames_;                   // the frontend's last lead_frames + 1 frames
};

}  // namespace ovo::estimator
