#include "estimator/window_frames.hpp"

#include "common/so3.hpp"

namespace ovo::estimator {

Mat3 GyroSpan::at(const Vec3& bias_radps) const {
  return dR * so3::exp(J_bias * (bias_radps - bias_lin_radps));
}

std::optional<KeyframeState> FrameLog::keptState(int kf_id) const {
  auto it = kf_states_.find(kf_id);
  if (it == kf_states_.end()) return std::nullopt;
  return it->second;
}

Vec3 FrameLog::positionAt(Timestamp t_ns, Timestamp t_now_ns, const Vec3& p_now_W,
                          const Vec3& fallback_W) const {
  Timestamp t1 = t_now_ns;
  Vec3 p1 = p_now_W;
  for (auto it = frames_.rbegin(); it != frames_.rend() && it->t_ns < t1; ++it) {
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
  out.reserve(frames_.size());
  for (const FrameRecord& r : frames_) {
    SE3 T = r.T_W_B;
    if (r.ref_kf >= 0) {
      if (const auto kf = keyframe_pose(r.ref_kf)) {
        T = kf->body * r.T_kf_B;
        if (r.gyro)
          T.linear() = so3::orthonormalize(kf->body.linear() * r.gyro->at(kf->bias_radps));
      }
    }
    if (!allFinite(T)) T = r.T_W_B;
    out.push_back({r.t_ns, T});
  }
  return out;
}

Trajectory FrameLog::keyframes(const KeyframeLookup& keyframe_pose) const {
  Trajectory out;
  for (const auto& [id, t_ns] : kf_times_)
    if (const auto kf = keyframe_pose(id)) out.push_back({t_ns, kf->body});
  return out;
}

}  // namespace ovo::estimator
