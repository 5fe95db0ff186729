#include "estimator/window/starter.hpp"

#include <algorithm>
#include <cmath>

#include "common/so3.hpp"
#include "estimator/common/lidar_scale.hpp"

namespace ovo::estimator {
namespace {

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
  pending.emplace_back(frame_record, std::move(seen));
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

WindowInitializer::WindowInitializer(const SensorSetup& setup, const WindowOptions& options,
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

Mat3 WindowInitializer::rotationFromReference(const Reference& ref, const VisualFrame& frame,
                                              const SE3& T_W_B_pred,
                                              const GroundChain* chain) const {
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

std::optional<InitialGeometry> WindowInitializer::twoView(const Reference& ref,
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

WindowInitializer::Outcome WindowInitializer::attempt(
    const Reference& ref, const VisualFrame& frame, const SE3& T_W_B_pred,
    const ScanLookup& scan_for, const std::function<bool()>& can_reference, InitialGeometry* out) {
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
      // a wrong scale for good (10x on a spin with 60 tracks a keyframe); a new reference here
      // loses the motion since the old one, and the scale comes with a later frame.
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

}  // namespace ovo::estimator
