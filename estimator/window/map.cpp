// The window's keyframes and landmarks: poses, points, lookups, gyro re-propagation.
#include "estimator/window/map.hpp"

#include <algorithm>

#include "common/so3.hpp"
#include "factors/parameterization.hpp"

namespace ovo::estimator {

SE3 Keyframe::pose() const {
  SE3 T = SE3::Identity();
  T.linear() = factors::quatFromBlock(q_W_B).toRotationMatrix();
  T.translation() = Vec3(p_W_B[0], p_W_B[1], p_W_B[2]);
  return T;
}

SE3 Keyframe::bodyPose() const {
  SE3 T = pose();
  T.linear() = factors::quatFromBlock(q_W_G).toRotationMatrix();
  return T;
}

SE3 Readout::cameraAt(double row_s, const SE3& T_B_C) const {
  if (row_s == 0.0) return T_B_C;
  SE3 T_B0_B = SE3::Identity();  // the body at the row's time, in the frame's body frame
  T_B0_B.linear() = so3::exp(rate_B * row_s);
  T_B0_B.translation() = velocity_B * row_s;
  return T_B0_B * T_B_C;
}

void Keyframe::setPose(const SE3& T_W_B) {
  factors::quatToBlock(Quat(T_W_B.linear()).normalized(), q_W_B);
  std::copy_n(q_W_B, 4, q_W_G);
  for (int i = 0; i < 3; ++i) p_W_B[i] = T_W_B.translation()[i];
}

void Keyframe::copyStates(const Keyframe& from) {
  std::copy_n(from.q_W_B, 4, q_W_B);
  std::copy_n(from.q_W_G, 4, q_W_G);
  std::copy_n(from.p_W_B, 3, p_W_B);
  std::copy_n(from.b_g, 3, b_g);
  std::copy_n(from.terrain, 3, terrain);
  terrain_set = from.terrain_set;
  height_offset_m[0] = from.height_offset_m[0];
}

void Keyframe::setBias(const Vec3& b) {
  for (int i = 0; i < 3; ++i) b_g[i] = b[i];
}

Keyframe* WindowMap::find(int kf_id) {
  for (auto& kf : keyframes)
    if (kf->id == kf_id) return kf.get();
  return nullptr;
}

const Keyframe* WindowMap::find(int kf_id) const {
  for (const auto& kf : keyframes)
    if (kf->id == kf_id) return kf.get();
  return nullptr;
}

std::optional<Vec3> landmarkPointW(const Keyframe& anchor, const Landmark& lm, const SE3& T_B_C) {
  if (!(lm.rho[0] > 1e-9)) return std::nullopt;
  const Vec3 p_W =
      anchor.pose() * (anchor.cameraAt(lm.anchor_row_s, T_B_C) * (lm.bearing_anchor_C / lm.rho[0]));
  if (!p_W.allFinite()) return std::nullopt;
  return p_W;
}

std::optional<Vec3> WindowMap::pointW(const Landmark& lm, const SE3& T_B_C) const {
  const Keyframe* anchor = find(lm.anchor_kf);
  if (anchor == nullptr) return std::nullopt;
  return landmarkPointW(*anchor, lm, T_B_C);
}

std::optional<Vec3> WindowMap::pointW(TrackId id, const SE3& T_B_C) const {
  const auto lm = landmarks.find(id);
  if (lm == landmarks.end()) return std::nullopt;
  return pointW(lm->second, T_B_C);
}

int WindowMap::observationCount(TrackId id) const {
  int n = 0;
  for (const auto& kf : keyframes) n += kf->observations.count(id) ? 1 : 0;
  return n;
}

void WindowMap::rememberPoints(const SE3& T_B_C) {
  for (const auto& [id, lm] : landmarks)
    if (auto p = pointW(lm, T_B_C)) last_point_W[id] = *p;
}

void repropagateGyro(const std::vector<Keyframe*>& keyframes) {
  for (std::size_t k = 1; k < keyframes.size(); ++k) {
    auto& pi = keyframes[k]->preint_from_prev;
    if (pi && pi->needsRepropagation(keyframes[k - 1]->bias(), 0.002))
      pi->repropagate(keyframes[k - 1]->bias());
  }
}

std::unordered_map<int, Keyframe*> keyframesById(const std::vector<Keyframe*>& keyframes) {
  std::unordered_map<int, Keyframe*> out;
  for (Keyframe* kf : keyframes) out[kf->id] = kf;
  return out;
}

}  // namespace ovo::estimator
