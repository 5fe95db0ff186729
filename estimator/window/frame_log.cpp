// The window's frame log: records, settling, and the output trajectories.
#include "estimator/window/frame_log.hpp"

#include <algorithm>
#include <limits>

#include "common/so3.hpp"

namespace ovo::estimator {
namespace {

SettledPose settled(Timestamp t_ns, const SE3& T) {
  return {t_ns, Eigen::Quaterniond(T.linear()), T.translation()};
}

SE3 pose(const SettledPose& p) {
  SE3 T = SE3::Identity();
  T.linear() = p.q_W_B.toRotationMatrix();
  T.translation() = p.p_W_B;
  return T;
}

}  // namespace

Mat3 GyroSpan::at(const Vec3& bias_radps) const {
  return dR * so3::exp(J_bias * (bias_radps - bias_lin_radps));
}

Mat3 GyroSpan::at(const Vec3& bias_radps, double shift_s_now) const {
  const double d = shift_s_now - shift_s;
  if (d == 0.0) return at(bias_radps);
  return so3::exp(rate_start_radps * d) * at(bias_radps) * so3::exp(-rate_end_radps * d);
}

std::optional<KeyframeState> FrameLog::keptState(int kf_id) const {
  auto it = kf_states_.find(kf_id);
  if (it == kf_states_.end()) return std::nullopt;
  return it->second;
}

FrameRecord* FrameLog::record(std::size_t index) {
  if (index < settled_count_ || index >= size()) return nullptr;
  return &open_[index - settled_count_];
}

SE3 FrameLog::finalPose(const FrameRecord& r, const KeyframeLookup& keyframe_state) const {
  SE3 T = r.T_W_B;
  if (r.ref_kf >= 0) {
    if (const auto kf = keyframe_state(r.ref_kf)) {
      // The offset was measured against the keyframe's vision pose (recordFrame): the position
      // follows from that pose, the orientation from the body's (the output's) times the offset's
      // rotation, or the gyro's. (The body's pose times the whole offset would turn the offset by
      // the vision/gyro-chain disagreement.)
      T.translation() = kf->vision * r.T_kf_B.translation();
      T.linear() = r.gyro ? so3::orthonormalize(kf->body.linear() *
                                                r.gyro->at(kf->bias_radps, shift_s_))
                          : Mat3(kf->body.linear() * r.T_kf_B.linear());
    }
  }
  return allFinite(T) ? T : r.T_W_B;
}

void FrameLog::settle(Timestamp before_ns, const KeyframeLookup& keyframe_state) {
  while (!open_.empty() && open_.front().t_ns < before_ns) {
    const FrameRecord& r = open_.front();
    // Its keyframe may still move (what matters only when its pose is kept).
    if (keep_history_ && r.ref_kf >= 0 && kf_states_.count(r.ref_kf) == 0) break;
    if (keep_history_) settled_.push_back(settled(r.t_ns, finalPose(r, keyframe_state)));
    open_.pop_front();
    ++settled_count_;
  }
  // Keyframes no open frame refers to (ids grow with time) and older than before_ns.
  int first_ref = std::numeric_limits<int>::max();
  for (const FrameRecord& r : open_)
    if (r.ref_kf >= 0) first_ref = std::min(first_ref, r.ref_kf);
  for (auto it = kf_states_.begin(); it != kf_states_.end() && it->first < first_ref;) {
    const auto t = kf_times_.find(it->first);
    if (t != kf_times_.end() && t->second >= before_ns) break;
    if (keep_history_ && t != kf_times_.end())
      settled_keyframes_.push_back(settled(t->second, it->second.body));
    if (t != kf_times_.end()) kf_times_.erase(t);
    it = kf_states_.erase(it);
  }
  if (!keep_history_)
    while (!bias_.empty() && bias_.front().first < before_ns) bias_.pop_front();
}

Vec3 FrameLog::positionAt(Timestamp t_ns, Timestamp t_now_ns, const Vec3& p_now_W,
                          const Vec3& fallback_W) const {
  Timestamp t1 = t_now_ns;
  Vec3 p1 = p_now_W;
  for (auto it = open_.rbegin(); it != open_.rend() && it->t_ns < t1; ++it) {
    if (it->t_ns <= t_ns) {
      const double a = static_cast<double>(t_ns - it->t_ns) / (t1 - it->t_ns);
      return (1.0 - a) * it->T_W_B.translation() + a * p1;
    }
    t1 = it->t_ns;
    p1 = it->T_W_B.translation();
  }
  return fallback_W;
}

Trajectory FrameLog::trajectory(const KeyframeLookup& keyframe_pose) const {
  Trajectory out;
  out.reserve(settled_.size() + open_.size());
  for (const SettledPose& p : settled_) out.push_back({p.t_ns, pose(p)});
  for (const FrameRecord& r : open_) out.push_back({r.t_ns, finalPose(r, keyframe_pose)});
  return out;
}

Trajectory FrameLog::keyframes(const KeyframeLookup& keyframe_pose) const {
  Trajectory out;
  for (const SettledPose& p : settled_keyframes_) out.push_back({p.t_ns, pose(p)});
  for (const auto& [id, t_ns] : kf_times_)
    if (const auto kf = keyframe_pose(id)) out.push_back({t_ns, kf->body});
  return out;
}

}  // namespace ovo::estimator
