// How the window core starts a window: the two-view reference it waits on, the frames before
// initialisation (posed by the gyro or the reference, positioned by the ground chain), and the
// window built from the initialiser's geometry (keyframes, landmarks, gauge and bias prior, the
// frames since the reference placed between its two keyframes).
#include <algorithm>
#include <cmath>
#include <unordered_set>

#include "estimator/window/core.hpp"
#include "estimator/window/keyframe_policy.hpp"

namespace ovo::estimator {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

}  // namespace

void WindowCore::startReference(const VisualFrame& frame, const SE3& T_W_B) {
  reference_ = makeReference(frame, T_W_B);
}

Reference WindowCore::makeReference(const VisualFrame& frame, const SE3& T_W_B) const {
  Reference r;
  r.t_ns = frame.t_ns;
  r.T_W_B = T_W_B;
  std::unordered_set<TrackId> near_beams;
  for (const auto& c : lidar_.candidates(frame.observations, scanFor(frame.t_ns, T_W_B)))
    near_beams.insert(c.track_id);
  for (const auto& o : selectSpread(frame.observations, {}, near_beams, options_))
    r.obs[o.track_id] = o;
  r.frame_index = static_cast<int>(frames_.size());
  return r;
}

int WindowCore::processBeforeInit(const VisualFrame& frame, const Prediction& pred,
                                  FrameEstimate& e) {
  int ref_kf = -1;
  if (!reference_) startReference(frame, pred.T_W_B);
  velocity_W_ *= std::pow(options_.velocity_decay_per_s, pred.dt);
  SE3 T_ref = pred.T_W_B;
  T_ref.linear() = initializer_.rotationFromReference(*reference_, frame, pred.T_W_B,
                                                      ground_chain_ ? &*ground_chain_ : nullptr);
  if (ground_chain_) {
    bool measured = false;
    T_ref = ground_chain_->step(frame, T_ref, &measured);
    if (measured) velocity_W_ = ground_chain_->velocityW();
  }
  e.T_W_B = T_ref;
  if (tryInitialize(frame, T_ref, &e)) {
    ref_kf = map_.keyframes.back()->id;
  } else {
    e.tracked = false;
    e.status = "initializing";
    if (reference_) reference_->keepSightings(static_cast<int>(frames_.size()), frame);
  }
  return ref_kf;
}

bool WindowCore::tryInitialize(const VisualFrame& frame, const SE3& T_W_B_pred,
                               FrameEstimate* out) {
  InitialGeometry g;
  const auto outcome = initializer_.attempt(
      *reference_, frame, T_W_B_pred,
      [this](Timestamp t_ns, const SE3& T_W_B) { return scanFor(t_ns, T_W_B); },
      [&] { return canReference(frame.t_ns); }, &g);
  if (outcome == WindowInitializer::Outcome::kRestartReference) startReference(frame, T_W_B_pred);
  if (outcome != WindowInitializer::Outcome::kReady) return false;
  startWindow(frame, g);
  out->T_W_B = map_.keyframes.back()->pose();
  out->tracked = true;
  out->is_keyframe = true;
  out->status = "initialized";
  return true;
}

void WindowCore::startWindow(const VisualFrame& frame, const InitialGeometry& g) {
  const Reference& ref = *reference_;
  lidar_scale_ = g.lidar_scale;
  scale_known_ = g.scale_known;
  // The first keyframe's bias prior: a standstill before this initialisation (its mean rate),
  // a recent one before a restart, or the previous segment's estimate after a loss (whichever
  // is the tighter); else the loose first-start prior around the current bias.
  double bias_sigma_radps = -1.0;
  const char* bias_note = nullptr;
  if (auto still = still_bias_.estimate(options_.standstill_min_bias_s)) {
    bias_ = still->bias_radps;
    bias_sigma_radps = still->sigma_radps;
    bias_note = "standstill before initialisation: gyro bias from its mean rate (zero-rate update)";
  } else {
    if (carried_bias_) {
      // A new segment after a loss: the bias has only walked since the last segment's keyframe.
      const double dt_s = std::max(0.0, toSeconds(ref.t_ns - carried_bias_->first));
      bias_ = carried_bias_->second;
      bias_sigma_radps = walkedBiasSigma(options_.reinit_bias_sigma_radps, dt_s);
      bias_note =
          "re-initialised after a loss: the gyro bias carried over from the previous segment";
    }
    if (recent_zero_rate_) {
      const double dt_s = std::abs(toSeconds(ref.t_ns - recent_zero_rate_->first));
      const double sigma = walkedBiasSigma(recent_zero_rate_->second.sigma_radps, dt_s);
      if (bias_sigma_radps <= 0.0 || sigma < bias_sigma_radps) {
        bias_ = recent_zero_rate_->second.bias_radps;
        bias_sigma_radps = sigma;
        bias_note = "re-initialised after a standstill: the gyro bias from its mean rate";
      }
    }
  }
  std::unordered_map<TrackId, TrackObservation> keep1;
  for (const auto& o : frame.observations)
    if (ref.obs.count(o.track_id)) keep1[o.track_id] = o;
  Keyframe* kf0 = addKeyframe(ref.t_ns, ref.T_W_B, bias_, sortedObservations(ref.obs), nullptr);
  Keyframe* kf1 = addKeyframe(frame.t_ns, g.T_W_B1, bias_, frame.observations, &keep1);
  const TwoViewResult& tv = g.two_view;
  for (std::size_t k = 0; k < tv.points_index.size(); ++k) {
    const double depth = g.scale * tv.depth0[k];
    if (depth < options_.landmark_min_depth_m) continue;
    Landmark lm;
    lm.id = g.ids[tv.points_index[k]];
    lm.anchor_kf = kf0->id;
    lm.bearing_anchor_C = g.b0[tv.points_index[k]];
    lm.rho[0] = depth > options_.landmark_max_depth_m ? 0.0 : 1.0 / depth;  // far: at infinity
    map_.landmarks[lm.id] = lm;
  }
  gauge_ = {};
  gauge_.kf_id = kf0->id;
  gauge_.T_W_B = ref.T_W_B;
  gauge_.b_g = bias_;
  gauge_.b_g_sigma_radps = bias_sigma_radps;
  if (bias_note) note(bias_note);
  if (options_.refine == RefineMode::kFull) segment_gauges_.push_back(gauge_);
  carried_bias_.reset();
  recent_zero_rate_.reset();
  still_bias_.reset();
  associateLidar();
  initialized_ = true;
  if (ground_chain_) ground_chain_->reset();
  solveWindow();

  // Frames between the reference and now: positions interpolated in time, against kf0.
  const SE3 T_W_K0 = kf0->pose();
  const SE3 T_W_K1 = kf1->pose();
  // (The frames since the reference are open records: settling stops at the reference.)
  for (std::size_t i = static_cast<std::size_t>(ref.frame_index); i < frames_.size(); ++i) {
    FrameRecord* record = frames_.record(i);
    if (record == nullptr) continue;
    FrameRecord& r = *record;
    const double a =
        std::clamp(toSeconds(r.t_ns - ref.t_ns) / toSeconds(frame.t_ns - ref.t_ns), 0.0, 1.0);
    r.T_W_B.translation() = (1.0 - a) * T_W_K0.translation() + a * T_W_K1.translation();
    if (i == static_cast<std::size_t>(ref.frame_index)) r.T_W_B = T_W_K0;
    r.ref_kf = kf0->id;
    r.T_kf_B = T_W_K0.inverse() * r.T_W_B;
    r.is_keyframe = i == static_cast<std::size_t>(ref.frame_index);
  }
  // Time is a poor guide when the robot drives off from a stop: refine those frames against the
  // first landmarks (their gyro rotation as the prior), keeping the interpolation where that fails.
  for (const auto& [index, seen] : ref.pending) {
    FrameRecord* record = frames_.record(static_cast<std::size_t>(index));
    if (index <= ref.frame_index || record == nullptr) continue;
    std::vector<Vec3> points_W, bearings_C;
    for (const TrackObservation& o : seen) {
      if (auto p = map_.pointW(o.track_id, setup_.T_B_C)) {
        points_W.push_back(*p);
        bearings_C.push_back(o.bearing_C);
      }
    }
    if (static_cast<int>(points_W.size()) < options_.min_landmark_observations) continue;
    FrameRecord& r = *record;
    const auto refined = refinePose(
        points_W, bearings_C, r.T_W_B, r.T_W_B.linear(), options_.rotation_prior_sigma_rad, model_,
        options_.motion_only_iterations, options_.outlier_angle_deg * kDegToRad);
    if (!refined || refined->num_inliers < options_.min_landmark_observations) continue;
    r.T_W_B = refined->T_W_B;
    r.T_kf_B = T_W_K0.inverse() * r.T_W_B;
  }
  velocity_W_ = (T_W_K1.translation() - T_W_K0.translation()) / toSeconds(frame.t_ns - kf0->t_ns);
  reference_.reset();
  lost_frames_ = 0;
}

}  // namespace ovo::estimator
