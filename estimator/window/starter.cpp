// Starting the window: the two-view reference the core waits on, each attempt to initialise from
// it and a later frame (WindowStarter: the geometry, its metric scale and when to put it off), the
// frames before initialisation (posed by the gyro or the reference, positioned by the ground
// chain), and the window built from the starter's geometry (keyframes, landmarks, gauge and bias
// prior, the frames since the reference placed between its two keyframes).
#include "estimator/window/starter.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_set>

#include "common/so3.hpp"
#include "estimator/common/lidar_scale.hpp"
#include "estimator/window/core.hpp"
#include "estimator/window/keyframe_policy.hpp"

namespace ovo::estimator {
namespace {

constexpr double kDegToRad = M_PI / 180.0;
constexpr int kMinReferenceTracks = 20;  // shared tracks to measure a rotation before the start

}  // namespace

std::vector<TrackObservation> sortedObservations(
    const std::unordered_map<TrackId, TrackObservation>& m) {
  std::vector<TrackObservation> v;
  v.reserve(m.size());
  for (const auto& [id, o] : m) v.push_back(o);
  std::sort(v.begin(), v.end(), [](const TrackObservation& a, const TrackObservation& b) {
    return a.track_id < b.track_id;
  });
  return v;
}

void Reference::keepSightings(int frame_record, const VisualFrame& frame) {
  std::vector<TrackObservation> seen;
  for (const auto& o : frame.observations)
    if (obs.count(o.track_id)) seen.push_back(o);
  if (!seen.empty()) pending.emplace_back(frame_record, std::move(seen));
}

void Reference::forgetSightingsBefore(int frame_record) {
  std::erase_if(pending, [&](const auto& p) { return p.first < frame_record; });
}

void Reference::sharedBearings(const VisualFrame& frame, std::vector<Vec3>* b0,
                               std::vector<Vec3>* b1, std::vector<TrackId>* ids) const {
  for (const auto& o : frame.observations) {
    auto it = obs.find(o.track_id);
    if (it == obs.end()) continue;
    b0->push_back(it->second.bearing_C);
    b1->push_back(o.bearing_C);
    if (ids) ids->push_back(o.track_id);
  }
}

WindowStarter::WindowStarter(const SensorSetup& setup, const WindowOptions& options,
                             const GroundPlaneOptions& ground_options,
                             const frontend::RelativePoseOptions& relpose_options,
                             double inlier_rad, const WindowLidar& lidar, bool use_gyro,
                             bool use_lidar, Note note)
    : setup_(setup),
      options_(options),
      ground_options_(ground_options),
      inlier_rad_(inlier_rad),
      lidar_(lidar),
      use_gyro_(use_gyro),
      use_lidar_(use_lidar),
      note_(std::move(note)) {
  if (!use_gyro_) relpose_ = std::make_unique<frontend::RelativePoseEstimator>(relpose_options);
}

Mat3 WindowStarter::rotationFromReference(const Reference& ref, const VisualFrame& frame,
                                          const SE3& T_W_B_pred, const GroundChain* chain) const {
  if (use_gyro_) return T_W_B_pred.linear();
  // The frame's rotation from a view it shares tracks with (the 8-point), nullopt when that fails.
  auto fromView = [&](const SE3& T_W_B0, const std::vector<Vec3>& b0,
                      const std::vector<Vec3>& b1) -> std::optional<Mat3> {
    if (static_cast<int>(b0.size()) < kMinReferenceTracks) return std::nullopt;
    const auto rp = relpose_->estimate(b0, b1);
    using S = frontend::RelativePoseResult::Status;
    if (rp.status != S::kOk && rp.status != S::kLowParallax) return std::nullopt;
    const Mat3 R_B_C = setup_.T_B_C.linear();
    const Mat3 R_W_B = T_W_B0.linear() * R_B_C * rp.R_cur_prev.transpose() * R_B_C.transpose();
    if (!R_W_B.allFinite()) return std::nullopt;
    return so3::orthonormalize(R_W_B);
  };
  std::vector<Vec3> b0, b1;
  ref.sharedBearings(frame, &b0, &b1);
  if (auto R = fromView(ref.T_W_B, b0, b1)) return *R;
  // The reference's tracks ran out (it restarts at this frame): the ground chain's recent anchor
  // still shares many, else the turn of this frame would be lost for good.
  if (chain) {
    b0.clear();
    b1.clear();
    if (auto T_W_A = chain->sharedWithAnchor(frame, &b0, &b1))
      if (auto R = fromView(*T_W_A, b0, b1)) return *R;
  }
  return T_W_B_pred.linear();
}

std::optional<InitialGeometry> WindowStarter::twoView(const Reference& ref,
                                                      const VisualFrame& frame,
                                                      const SE3& T_W_B_pred,
                                                      double min_parallax_deg) const {
  InitialGeometry g;
  std::vector<Vec3> b1;
  ref.sharedBearings(frame, &g.b0, &b1, &g.ids);
  const Mat3 R_B_C = setup_.T_B_C.linear();
  TwoViewOptions tvo;
  tvo.min_parallax_deg = options_.landmark_min_parallax_deg;
  tvo.min_points = std::max(10, options_.init_min_tracks / 2);
  tvo.inlier_rad = inlier_rad_;
  std::optional<TwoViewResult> tv;
  if (use_gyro_) {
    const Mat3 R_C1_C0 =
        R_B_C.transpose() * T_W_B_pred.linear().transpose() * ref.T_W_B.linear() * R_B_C;
    if (medianParallaxDeg(g.b0, b1, R_C1_C0) < min_parallax_deg) return std::nullopt;
    tv = twoViewKnownRotation(g.b0, b1, R_C1_C0, tvo);
  } else {
    const auto rp = relpose_->estimate(g.b0, b1);
    if (rp.status != frontend::RelativePoseResult::Status::kOk) return std::nullopt;
    if (medianParallaxDeg(g.b0, b1, rp.R_cur_prev) < min_parallax_deg) return std::nullopt;
    auto t = triangulateTwoView(g.b0, b1, rp.R_cur_prev, rp.t_cur_prev, &rp.inliers,
                                tvo.min_parallax_deg);
    if (static_cast<int>(t.p_C0.size()) >= tvo.min_points) tv = std::move(t);
  }
  if (!tv) return std::nullopt;
  g.two_view = std::move(*tv);
  return g;
}

WindowStarter::Outcome WindowStarter::attempt(const Reference& ref, const VisualFrame& frame,
                                              const SE3& T_W_B_pred, const ScanLookup& scan_for,
                                              const std::function<bool()>& can_reference,
                                              InitialGeometry* out) {
  std::size_t shared = 0;
  for (const auto& o : frame.observations) shared += ref.obs.count(o.track_id);
  if (static_cast<int>(shared) < options_.init_min_tracks)
    return static_cast<int>(frame.observations.size()) >= options_.init_min_tracks
               ? Outcome::kRestartReference
               : Outcome::kNotYet;
  // Waiting long without enough parallax (slow or far scene): accept half the parallax.
  const bool waited = toSeconds(frame.t_ns - ref.t_ns) > options_.init_max_wait_s;
  auto geometry =
      twoView(ref, frame, T_W_B_pred, options_.init_parallax_deg * (waited ? 0.5 : 1.0));
  if (!geometry) return Outcome::kNotYet;
  const TwoViewResult& tv = geometry->two_view;
  const std::vector<TrackId>& ids = geometry->ids;

  // Metric scale: LiDAR ranges against the unit-baseline points, else the ground plane.
  // Putting off is only safe while the shared tracks are plentiful: once they run out the
  // reference restarts at the current frame and the motion since the old one is lost.
  const bool can_defer = scale_deferrals_ < kMaxScaleDeferrals &&
                         static_cast<int>(ids.size()) >= 4 * options_.init_min_tracks;
  std::optional<double> scale;
  std::optional<double> ground_scale;
  if (setup_.camera_height_m) {
    const Vec3 up_C0 = bodyUpIn(setup_.T_B_C);
    if (auto plane = fitGroundPlane(tv.p_C0, up_C0, ground_options_))
      if (plane->height > 1e-9) ground_scale = *setup_.camera_height_m / plane->height;
  }
  bool lidar_scale = false;
  if (use_lidar_) {
    std::unordered_map<TrackId, int> point_of;
    for (std::size_t k = 0; k < tv.points_index.size(); ++k)
      point_of[ids[tv.points_index[k]]] = static_cast<int>(k);
    std::vector<double> ratios;
    for (int view = 0; view < 2; ++view) {
      const auto scan =
          view == 0 ? scan_for(ref.t_ns, ref.T_W_B) : scan_for(frame.t_ns, T_W_B_pred);
      if (!scan) continue;
      const auto beams = lidar_.usableBeams(*scan);
      const auto& observations = view == 0 ? sortedObservations(ref.obs) : frame.observations;
      for (const BeamMatch& m : associateBeams(beams, observations, options_.lidar_radius_px)) {
        auto it = point_of.find(m.track_id);
        if (it == point_of.end()) continue;
        const Vec3& p0 = tv.p_C0[it->second];
        const double unit = view == 0 ? p0.norm() : (tv.R_C1_C0 * p0 + tv.t_C1_C0).norm();
        if (unit > 1e-6) ratios.push_back(m.beam_dist_C / unit);
      }
    }
    using Vote = LidarScaleVote::Outcome;
    const LidarScaleVote vote =
        voteLidarScale(std::move(ratios), ground_scale, options_.lidar_min_associations, can_defer);
    switch (vote.outcome) {
      case Vote::kAgreed:
        break;
      case Vote::kGroundSettled:
        note_(
            "LiDAR scale ambiguous at an initialisation: the group that the ground plane agrees "
            "with");
        break;
      case Vote::kPutOff:
        ++scale_deferrals_;
        note_("LiDAR scale ambiguous at an initialisation (two groups of range ratios): put off");
        return Outcome::kNotYet;
      case Vote::kForced:
        note_("LiDAR scale stayed ambiguous at an initialisation: the nearest surfaces");
        break;
      case Vote::kOverruled:
        note_(
            "LiDAR range ratios disagreed with the ground plane at an initialisation: "
            "ground-plane scale there");
        break;
      case Vote::kTooFew:
        note_("LiDAR associated too few points at an initialisation: ground-plane scale there");
        break;
    }
    scale = vote.scale;
    lidar_scale = vote.scale.has_value();
  }
  if (!scale) scale = ground_scale;
  // A window started at a wrong scale keeps it: the LiDAR and ground gates then reject every
  // measurement that would correct it. With a scale sensor, wait for a frame that gives a scale.
  const bool can_scale = use_lidar_ || setup_.camera_height_m.has_value();
  if (!scale && can_scale) {
    if (!scale_wait_since_) scale_wait_since_ = frame.t_ns;
    if (can_defer) {
      ++scale_deferrals_;
      note_("no LiDAR or ground-plane scale at an initialisation: put off");
      return Outcome::kNotYet;
    }
    if (toSeconds(frame.t_ns - *scale_wait_since_) < kMaxScaleWaitS) {
      // The shared tracks run out (or the reference waited long). A unit baseline now would keep
      // a wrong scale for good (far off on a spin); a new reference here loses the motion since
      // the old one, and the scale comes with a later frame.
      if (!can_reference()) return Outcome::kNotYet;
      note_(
          "no LiDAR or ground-plane scale at an initialisation as the shared tracks ran out: "
          "the two-view reference restarted");
      scale_deferrals_ = 0;
      return Outcome::kRestartReference;
    }
  }
  scale_deferrals_ = 0;
  scale_wait_since_.reset();
  const bool scale_known = scale.has_value();
  if (!scale) {
    scale = 1.0;
    note_("initialisation without LiDAR or ground-plane scale: unit baseline");
  }
  SE3 T_C1_C0 = SE3::Identity();
  T_C1_C0.linear() = tv.R_C1_C0;
  T_C1_C0.translation() = *scale * tv.t_C1_C0;
  geometry->T_W_B1 = ref.T_W_B * setup_.T_B_C * T_C1_C0.inverse() * setup_.T_B_C.inverse();
  geometry->scale = *scale;
  geometry->lidar_scale = lidar_scale;
  geometry->scale_known = scale_known;
  *out = std::move(*geometry);
  return Outcome::kReady;
}

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
  T_ref.linear() = starter_.rotationFromReference(*reference_, frame, pred.T_W_B,
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
  const auto outcome = starter_.attempt(
      *reference_, frame, T_W_B_pred,
      [this](Timestamp t_ns, const SE3& T_W_B) { return scanFor(t_ns, T_W_B); },
      [&] { return canReference(frame.t_ns); }, &g);
  if (outcome == WindowStarter::Outcome::kRestartReference) startReference(frame, T_W_B_pred);
  if (outcome != WindowStarter::Outcome::kReady) return false;
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
    if (const auto o = kf0->observations.find(lm.id); o != kf0->observations.end())
      lm.anchor_row_s = o->second.row_s;
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
    FrameRecord& r = *record;
    std::vector<Vec3> points_W, bearings_C;
    std::vector<SE3> cameras_B;
    const Readout readout = readoutAt(r.t_ns, r.T_W_B, bias_);
    for (const TrackObservation& o : seen) {
      if (auto p = map_.pointW(o.track_id, setup_.T_B_C)) {
        points_W.push_back(*p);
        bearings_C.push_back(o.bearing_C);
        cameras_B.push_back(readout.cameraAt(o.row_s, setup_.T_B_C));
      }
    }
    if (static_cast<int>(points_W.size()) < options_.min_landmark_observations) continue;
    const auto refined = refinePose(
        points_W, bearings_C, cameras_B, r.T_W_B, r.T_W_B.linear(), options_.rotation_prior_sigma_rad, model_,
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
