// The ground chain: positions before the start from short baselines and the ground plane.
#include "estimator/window/ground_chain.hpp"

#include <algorithm>
#include <cmath>

#include "estimator/estimator.hpp"
#include "estimator/vo/chain.hpp"

namespace ovo::estimator {

GroundChain::GroundChain(const SE3& T_B_C, double camera_height_m, double inlier_rad,
                         const GroundPlaneOptions& ground, const GroundChainOptions& options)
    : T_B_C_(T_B_C), height_m_(camera_height_m), ground_(ground), options_(options) {
  two_view_.inlier_rad = inlier_rad;
  two_view_.min_parallax_deg = options.min_point_parallax_deg;
  two_view_.min_points = ground.min_inliers;
}

void GroundChain::restart(const VisualFrame& frame, const SE3& T_W_B) {
  Anchor a;
  a.t_ns = frame.t_ns;
  a.T_W_B = T_W_B;
  // Oldest tracks first (they live on), spread over the image.
  std::vector<const TrackObservation*> order;
  for (const auto& o : frame.observations) order.push_back(&o);
  std::stable_sort(order.begin(), order.end(),
                   [](const TrackObservation* x, const TrackObservation* y) {
                     return x->age != y->age ? x->age > y->age : x->track_id < y->track_id;
                   });
  std::vector<Vec2> px;
  for (const TrackObservation* o : order) px.push_back(o->px);
  for (std::size_t i : thinToGrid(px, options_.cell_px, options_.per_cell))
    a.bearing_C[order[i]->track_id] = order[i]->bearing_C;
  anchor_ = std::move(a);
}

std::optional<SE3> GroundChain::sharedWithAnchor(const VisualFrame& frame, std::vector<Vec3>* b0,
                                                 std::vector<Vec3>* b1) const {
  if (!anchor_) return std::nullopt;
  for (const auto& o : frame.observations) {
    auto it = anchor_->bearing_C.find(o.track_id);
    if (it == anchor_->bearing_C.end()) continue;
    b0->push_back(it->second);
    b1->push_back(o.bearing_C);
  }
  return anchor_->T_W_B;
}

SE3 GroundChain::step(const VisualFrame& frame, const SE3& T_W_B_in, bool* measured) {
  if (measured) *measured = false;
  if (!anchor_) {
    restart(frame, T_W_B_in);
    return T_W_B_in;
  }
  Anchor& a = *anchor_;
  ++a.frames;
  std::vector<Vec3> b0, b1;
  sharedWithAnchor(frame, &b0, &b1);
  const double dt = toSeconds(frame.t_ns - a.t_ns);
  if (static_cast<int>(b0.size()) < two_view_.min_points || !(dt > 0.0)) {
    restart(frame, T_W_B_in);  // the anchor's tracks ran out: a new one where the frame is put
    return T_W_B_in;
  }
  const Mat3 R_B_C = T_B_C_.linear();
  const Mat3 R_C1_C0 = R_B_C.transpose() * T_W_B_in.linear().transpose() * a.T_W_B.linear() * R_B_C;
  // Too little parallax for a step: measured later from the same anchor (as libviso2 keeps its
  // reference frame).
  if (medianParallaxDeg(b0, b1, R_C1_C0) < options_.min_parallax_deg &&
      a.frames < options_.max_frames)
    return T_W_B_in;
  const auto tv = twoViewKnownRotation(b0, b1, R_C1_C0, two_view_);
  if (!tv) {
    restart(frame, T_W_B_in);
    return T_W_B_in;
  }
  std::optional<double> scale;
  if (auto plane = fitGroundPlane(tv->p_C0, bodyUpIn(T_B_C_), ground_))
    if (plane->height > 1e-9) {
      const double s = height_m_ / plane->height;
      if (std::isfinite(s) && s <= options_.max_speed_mps * dt) scale = s;
    }
  if (scale) {
    speed_mps_ = *scale / dt;
  } else if (speed_mps_) {
    scale = *speed_mps_ * dt;  // no plane this step: the last speed along the measured direction
  } else {
    restart(frame, T_W_B_in);
    return T_W_B_in;
  }
  SE3 T_C1_C0 = SE3::Identity();
  T_C1_C0.linear() = R_C1_C0;
  T_C1_C0.translation() = *scale * tv->t_C1_C0;
  SE3 T_W_B = a.T_W_B * T_B_C_ * T_C1_C0.inverse() * T_B_C_.inverse();
  T_W_B.linear() = T_W_B_in.linear();
  if (!allFinite(T_W_B)) {
    restart(frame, T_W_B_in);
    return T_W_B_in;
  }
  velocity_W_ = (T_W_B.translation() - a.T_W_B.translation()) / dt;
  restart(frame, T_W_B);
  if (measured) *measured = true;
  return T_W_B;
}

}  // namespace ovo::estimator
