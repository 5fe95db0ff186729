// The window estimator's record of every frame it was given (its pose as returned online and
// relative to the keyframe it was placed against), the keyframes' poses once they leave the window,
// and the gyro bias over time: what trajectory(), keyframes() and biasHistory() are built from.
// A frame whose keyframe has left the window for good is settled: its final pose is kept in a
// compact form (64 bytes), or dropped when the history is not kept (a long online run that
// streams its poses), so that memory does not grow with the run.
#pragma once

#include <deque>
#include <functional>
#include <map>
#include <optional>
#include <utility>
#include <vector>

#include "common/types.hpp"
#include "estimator/window/map.hpp"

namespace ovo::estimator {

/// The gyro's rotation from a keyframe to a frame, with what re-evaluates it at a later bias and
/// a later camera-gyro time offset: dR(b) = dR Exp(J_b (b - b_lin))
/// (factors::GyroPreintegration's first-order correction), and, the span [t0 - s, t1 - s] of the
/// gyro clock moved by a change d of the offset s, Exp(w0 d) dR(b) Exp(-w1 d) with the rates w0,
/// w1 at its ends (exact for a rate that changes linearly about one axis).
struct GyroSpan {
  Mat3 dR = Mat3::Identity();
  Mat3 J_bias = Mat3::Zero();  // s
  Vec3 bias_lin_radps = Vec3::Zero();
  double shift_s = 0.0;                 // the offset it was integrated with
  Vec3 rate_start_radps = Vec3::Zero();  // bias-corrected rates at its two ends
  Vec3 rate_end_radps = Vec3::Zero();
  Mat3 at(const Vec3& bias_radps) const;
  Mat3 at(const Vec3& bias_radps, double shift_s_now) const;
};

/// One frame as the window placed it.
struct FrameRecord {
  Timestamp t_ns = 0;
  SE3 T_W_B = SE3::Identity();   // as returned online
  int ref_kf = -1;               // keyframe the pose is expressed against (-1: none)
  SE3 T_kf_B = SE3::Identity();  // pose relative to that keyframe
  // The rotation from that keyframe by the gyro: the frame's orientation is the keyframe's
  // (gyro chain's) times it, at the keyframe's final bias, in place of T_kf_B's (the frame's own
  // vision refinement, some ten times noisier than the gyro over the frames since a keyframe).
  std::optional<GyroSpan> gyro;
  bool tracked = false;
  bool is_keyframe = false;
};

/// A keyframe's states as the output needs them.
struct KeyframeState {
  SE3 vision = SE3::Identity();  // Keyframe::pose (the frames' reference)
  SE3 body = SE3::Identity();    // Keyframe::bodyPose (the output)
  Vec3 bias_radps = Vec3::Zero();
};

/// A settled pose: final, stored compactly.
struct SettledPose {
  Timestamp t_ns = 0;
  Eigen::Quaterniond q_W_B = Eigen::Quaterniond::Identity();
  Vec3 p_W_B = Vec3::Zero();
};

class FrameLog {
 public:
  /// A keyframe's states now (window, archive or kept here), nullopt when unknown.
  using KeyframeLookup = std::function<std::optional<KeyframeState>(int kf_id)>;

  void add(const FrameRecord& r) { open_.push_back(r); }
  /// Frames recorded so far (settled and open); a frame's index counts from the first.
  std::size_t size() const { return settled_count_ + open_.size(); }
  /// The open record of frame `index`, nullptr once it is settled (or beyond the last).
  FrameRecord* record(std::size_t index);
  /// The records not settled yet, oldest first.
  std::deque<FrameRecord>& open() { return open_; }
  const std::deque<FrameRecord>& open() const { return open_; }

  /// false: settled frames, keyframes and biases are dropped instead of kept (trajectory(),
  /// keyframes() and biasHistory() then hold only the recent part the window may still change).
  void keepHistory(bool keep) { keep_history_ = keep; }
  bool keepsHistory() const { return keep_history_; }
  /// Settles the frames before `before_ns` whose keyframe's states are kept (it left the window for
  /// good), oldest first, up to the first that is not (without the history: every frame before
  /// it, whose pose is dropped either way); then the kept keyframes older than every open frame's
  /// and `before_ns`, and the biases before it.
  void settle(Timestamp before_ns, const KeyframeLookup& keyframe_state);

  /// The camera-gyro time offset now (s): the frames' gyro spans are re-timed to it (GyroSpan).
  void setTimeShift(double shift_s) { shift_s_ = shift_s; }
  /// Keeps a keyframe's poses as they are when it leaves the window (or at the end).
  void keepPoses(const Keyframe& kf) { kf_states_[kf.id] = {kf.pose(), kf.bodyPose(), kf.bias()}; }
  std::optional<KeyframeState> keptState(int kf_id) const;
  void addKeyframeTime(int kf_id, Timestamp t_ns) { kf_times_[kf_id] = t_ns; }
  void addBias(Timestamp t_ns, const Vec3& bias_radps) { bias_.emplace_back(t_ns, bias_radps); }
  std::vector<std::pair<Timestamp, Vec3>> biasHistory() const {
    return {bias_.begin(), bias_.end()};
  }

  /// The body's position at t (before the frame at t_now whose position is p_now), interpolated
  /// between the recorded frames around t; `fallback` when no recorded frame is at or before t.
  Vec3 positionAt(Timestamp t_ns, Timestamp t_now_ns, const Vec3& p_now_W,
                  const Vec3& fallback_W) const;

  /// Every frame's body pose: its position from its keyframe's final vision pose (which the
  /// offset was measured against) times its offset, its orientation the keyframe's final body
  /// orientation times the offset's rotation (the gyro's where recorded).
  Trajectory trajectory(const KeyframeLookup& keyframe_pose) const;
  /// Every keyframe's final body pose.
  Trajectory keyframes(const KeyframeLookup& keyframe_pose) const;

 private:
  SE3 finalPose(const FrameRecord& r, const KeyframeLookup& keyframe_state) const;

  double shift_s_ = 0.0;          // setTimeShift
  std::deque<FrameRecord> open_;  // frames not settled, oldest first
  std::size_t settled_count_ = 0;
  std::vector<SettledPose> settled_;  // the settled frames' poses (kept history)
  std::vector<SettledPose> settled_keyframes_;
  bool keep_history_ = true;
  std::map<int, KeyframeState> kf_states_;  // id -> its states when it left the window
  std::map<int, Timestamp> kf_times_;
  std::deque<std::pair<Timestamp, Vec3>> bias_;
};

}  // namespace ovo::estimator
