#include "estimator/window_core.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <unordered_set>

#include "common/so3.hpp"
#include "estimator/window_lidar.hpp"
#include "estimator/window_refine.hpp"
#include "factors/terrain_plane_factor.hpp"
#include "frontend/triangulation.hpp"

namespace ovo::estimator {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

// Where a landmark that outlives its anchor keyframe is anchored next.
struct Reanchor {
  int kf_id = -1;
  Vec3 bearing_C = Vec3::UnitZ();
  double rho = 0.0;
};

// Seconds of the last velocity that the prediction carries the robot over a gap of dt: all of it
// up to kFullCoastS (dropped frames), then decaying by decay_per_s (the fraction kept per s).
// Nothing measures the motion over a long gap; coasting through an hour at 0.8 m/s would put the
// robot 2.9 km away.
constexpr double kFullCoastS = 1.0;
double coastSeconds(double dt, double decay_per_s) {
  if (dt <= kFullCoastS || decay_per_s >= 1.0) return dt;
  if (decay_per_s <= 0.0) return kFullCoastS;
  return kFullCoastS + (1.0 - std::pow(decay_per_s, dt - kFullCoastS)) / -std::log(decay_per_s);
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  auto mid = v.begin() + static_cast<long>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

std::vector<TrackObservation> toVector(const std::unordered_map<TrackId, TrackObservation>& m) {
  std::vector<TrackObservation> v;
  v.reserve(m.size());
  for (const auto& [id, o] : m) v.push_back(o);
  std::sort(v.begin(), v.end(), [](const TrackObservation& a, const TrackObservation& b) {
    return a.track_id < b.track_id;
  });
  return v;
}

/// Tracks for a keyframe: every one in `keep`, then up to max_priority of `priority`, then the
/// oldest tracks with at most per_cell per grid cell, up to max_total in all.
std::vector<TrackObservation> selectSpread(const std::vector<TrackObservation>& all,
                                           const std::unordered_set<TrackId>& keep,
                                           const std::unordered_set<TrackId>& priority,
                                           const WindowOptions& o) {
  std::vector<TrackObservation> out;
  std::vector<const TrackObservation*> prio, rest;
  for (const auto& ob : all) {
    if (keep.count(ob.track_id))
      out.push_back(ob);
    else if (priority.count(ob.track_id))
      prio.push_back(&ob);
    else
      rest.push_back(&ob);
  }
  std::unordered_map<std::int64_t, int> cells;
  auto cellOf = [&o](const Vec2& px) {
    return (static_cast<std::int64_t>(std::floor(px.x() / o.feature_cell_px)) << 32) +
           static_cast<std::int64_t>(std::floor(px.y() / o.feature_cell_px));
  };
  for (const auto& ob : out) ++cells[cellOf(ob.px)];
  int n_prio = 0;
  for (const TrackObservation* ob : prio) {
    if (n_prio++ >= o.max_lidar_features || static_cast<int>(out.size()) >= o.max_features) break;
    out.push_back(*ob);
  }
  std::stable_sort(
      rest.begin(), rest.end(),
      [](const TrackObservation* a, const TrackObservation* b) { return a->age > b->age; });
  for (const TrackObservation* ob : rest) {
    if (static_cast<int>(out.size()) >= o.max_features) break;
    int& c = cells[cellOf(ob->px)];
    if (c >= o.features_per_cell) continue;
    ++c;
    out.push_back(*ob);
  }
  return out;
}

}  // namespace

WindowCore::WindowCore(const SensorSetup& setup, const WindowOptions& options,
                       const frontend::RelativePoseOptions& relpose_options,
                       const GroundPlaneOptions& ground_options)
    : setup_(setup),
      options_(options),
      ground_options_(ground_options),
      still_bias_(setup.gyro_noise_density,
                  options.gyro_bias_random_walk > 0.0 ? options.gyro_bias_random_walk
                                                      : setup.gyro_bias_random_walk,
                  options.standstill_trim_s) {
  const double pixel_sigma = options.pixel_sigma > 0.0 ? options.pixel_sigma : setup.pixel_sigma;
  model_.T_B_C = setup.T_B_C;
  model_.bearing_sigma_rad = pixel_sigma / camera::focalPx(setup.camera);
  model_.bearing_huber = options.bearing_huber_sigmas;
  model_.bearing_creep_rad = options.track_creep_px / camera::focalPx(setup.camera);
  model_.bearing_steps = useBearingSteps(options.bearing_steps, options);
  model_.step_white_rad = options.track_white_px / camera::focalPx(setup.camera);
  model_.lidar_ground_sigma_m = options.lidar_ground_sigma_m;
  model_.lidar_range_sigma_m =
      options.lidar_range_sigma_m > 0.0 ? options.lidar_range_sigma_m : setup.lidar_range_sigma_m;
  model_.lidar_sigma_m = std::hypot(model_.lidar_range_sigma_m, options.lidar_association_sigma_m);
  model_.lidar_huber = options.lidar_huber_sigmas;
  model_.lidar_cauchy = options.lidar_loss == "cauchy";
  model_.bias_random_walk = options.gyro_bias_random_walk > 0.0 ? options.gyro_bias_random_walk
                                                                : setup.gyro_bias_random_walk;
  model_.bias_prior_sigma_radps = options.gyro_bias_prior_sigma_radps;
  model_.vision_rotation_sigma_rad = options.vision_rotation_sigma_rad;
  model_.gauge_sigma_position_m = options.gauge_sigma_position_m;
  model_.gauge_sigma_rotation_rad = options.gauge_sigma_yaw_rad;
  model_.min_rho = 1.0 / (2.0 * options.landmark_max_depth_m);
  model_.max_rho = 1.0 / (0.5 * options.landmark_min_depth_m);
  use_gyro_ = options.use_gyro && setup.has_gyro;
  use_lidar_ = options.use_lidar && setup.has_lidar;
  // Without a LiDAR the ground is the only scale after the start (KITTI 07: a start from a
  // 12-point plane at 0.6x the scale was kept to the end with the tight gate).
  label_ground_options_ = ground_options;
  if (!use_lidar_) {
    options_.ground_scale_gate = options_.ground_scale_gate_no_lidar;
    // ... and a plane tilted against the body's up biases it: the keyframes' camera-height planes
    // and the ground chain's before the start use a tighter normal than vo.ground's 20 deg (the
    // start's two-view plane keeps that: it needs any plane it can get). KITTI 07: --refine full
    // scale -8.9 % -> -3.1 %; online ATE 1.44 -> 1.19 m.
    label_ground_options_.max_normal_deviation_deg = std::min(
        label_ground_options_.max_normal_deviation_deg, options_.ground_normal_max_deg_no_lidar);
  }
  model_.use_gyro = use_gyro_;
  if (options.use_ground_height && setup.camera_height_m && *setup.camera_height_m > 0.0) {
    model_.camera_height_m = *setup.camera_height_m;
    model_.ground_sigma_m = options.ground_height_sigma_m;
    model_.terrain_planes = options.terrain_planes;
    model_.terrain_slope_walk = options.terrain_slope_walk;
    model_.terrain_height_walk = options.terrain_height_walk;
  }
  if (!use_gyro_) note("no gyro: vision-only rotation (8-point initialisation, no gyro factors)");
  if (!use_lidar_) {
    note(setup.camera_height_m ? "no LiDAR: ground-plane scale at initialisation (camera_height_m)"
                               : "no LiDAR and no camera height: scale is arbitrary");
  }
  if (!use_gyro_) relpose_ = std::make_unique<frontend::RelativePoseEstimator>(relpose_options);
  if (setup.camera_height_m && *setup.camera_height_m > 0.0) {
    GroundChainOptions chain;
    chain.min_parallax_deg = options.landmark_min_parallax_deg;
    chain.min_point_parallax_deg = options.landmark_min_parallax_deg;
    ground_chain_.emplace(setup.T_B_C, *setup.camera_height_m,
                          std::max(3.0 * model_.bearing_sigma_rad, 1e-3), label_ground_options_,
                          chain);
  }
}

WindowCore::~WindowCore() = default;

void WindowCore::note(const std::string& text) {
  if (std::find(stats_.notes.begin(), stats_.notes.end(), text) == stats_.notes.end())
    stats_.notes.push_back(text);
}

void WindowCore::addGyro(const ImuSample& sample) {
  if (!options_.use_gyro) return;
  gyro_.add(sample);
}

void WindowCore::addScan(const LidarScan& scan) {
  if (!use_lidar_) return;
  scans_.push_back(scan);
  // Keep what the window can still use: scans newer than the oldest frame of interest.
  Timestamp keep_from = last_t_ - fromSeconds(5.0);
  if (reference_) keep_from = std::min(keep_from, reference_->t_ns);
  while (scans_.size() > 2 && scans_.front().t_ns < keep_from) scans_.erase(scans_.begin());
}

const LidarScan* WindowCore::scanAt(Timestamp t_ns) const {
  const Timestamp tol = fromSeconds(options_.lidar_scan_time_tol_s);
  const LidarScan* best = nullptr;
  for (const LidarScan& s : scans_)
    if (std::llabs(s.t_ns - t_ns) <= tol &&
        (!best || std::llabs(s.t_ns - t_ns) < std::llabs(best->t_ns - t_ns)))
      best = &s;
  return best;
}

std::optional<WindowCore::ScanChoice> WindowCore::chooseScan(Timestamp t_ns) const {
  if (!use_lidar_) return std::nullopt;
  if (const LidarScan* s = scanAt(t_ns)) return ScanChoice{s, std::nullopt};
  if (!(options_.lidar_scan_max_age_s > 0.0) || !use_gyro_) return std::nullopt;
  const LidarScan* latest = nullptr;  // the latest scan before the frame, within the age
  for (const LidarScan& s : scans_)
    if (s.t_ns < t_ns && t_ns - s.t_ns <= fromSeconds(options_.lidar_scan_max_age_s)) latest = &s;
  if (latest == nullptr) return std::nullopt;
  const auto pi = preintegrate(latest->t_ns, t_ns, bias_);
  if (!pi || pi->status() != factors::GyroPreintegration::Status::kOk) return std::nullopt;
  return ScanChoice{latest, pi->deltaR()};
}

std::optional<WindowCore::FrameScan> WindowCore::scanFor(Timestamp t_ns, const SE3& T_W_B) const {
  const auto choice = chooseScan(t_ns);
  if (!choice) return std::nullopt;
  if (!choice->R_Bscan_Bframe) return FrameScan{choice->scan, setup_.T_B_L};
  const LidarScan* latest = choice->scan;
  // Body at the scan seen from the body at the frame: turned back by the gyro's rotation over the
  // gap; its position interpolated between the two frames around the scan (this frame's and the
  // recorded ones), else moved back by the velocity.
  Vec3 p_W_scan = T_W_B.translation() - velocity_W_ * toSeconds(t_ns - latest->t_ns);
  Timestamp t1 = t_ns;
  Vec3 p1 = T_W_B.translation();
  for (auto it = frames_.rbegin(); it != frames_.rend() && it->t_ns < t1; ++it) {
    if (it->t_ns <= latest->t_ns) {
      const double a = static_cast<double>(latest->t_ns - it->t_ns) / (t1 - it->t_ns);
      p_W_scan = (1.0 - a) * it->T_W_B.translation() + a * p1;
      break;
    }
    t1 = it->t_ns;
    p1 = it->T_W_B.translation();
  }
  SE3 T_Bt_Bs = SE3::Identity();
  T_Bt_Bs.linear() = choice->R_Bscan_Bframe->transpose();
  T_Bt_Bs.translation() = T_W_B.linear().transpose() * (p_W_scan - T_W_B.translation());
  return FrameScan{latest, T_Bt_Bs * setup_.T_B_L};
}

bool WindowCore::scanExpectedAfter(Timestamp t_ns) const {
  if (!use_lidar_ || last_t_ <= 0 || t_ns <= last_t_) return false;
  const Timestamp tol = fromSeconds(options_.lidar_scan_time_tol_s);
  const Timestamp next_frame = t_ns + (t_ns - last_t_);
  // The first scan after this frame when one is buffered already, else the last one plus the
  // last scan period (scans_ is in time order).
  std::optional<Timestamp> next_scan;
  for (const LidarScan& s : scans_)
    if (s.t_ns > t_ns + tol) {
      next_scan = s.t_ns;
      break;
    }
  if (!next_scan && scans_.size() >= 2) {
    const Timestamp last = scans_.back().t_ns, period = last - scans_[scans_.size() - 2].t_ns;
    if (period > 0) next_scan = last + period;
  }
  return next_scan && std::llabs(*next_scan - next_frame) <= tol;
}

std::optional<factors::GyroPreintegration> WindowCore::preintegrate(Timestamp t0, Timestamp t1,
                                                                    const Vec3& bias) const {
  if (!use_gyro_ || gyro_.empty() || t1 <= t0) return std::nullopt;
  return factors::GyroPreintegration(gyro_.around(t0, t1), t0, t1, bias, options_.gyro);
}

std::optional<Mat3> WindowCore::predictRotationCurPrev(Timestamp t_ns) const {
  if (!have_last_) return std::nullopt;
  auto pi = preintegrate(last_t_, t_ns, bias_);
  if (!pi || pi->status() == factors::GyroPreintegration::Status::kNoData) return std::nullopt;
  const Mat3 R_B_C = setup_.T_B_C.linear();
  return R_B_C.transpose() * pi->deltaR().transpose() * R_B_C;
}

std::vector<Keyframe*> WindowCore::windowKeyframes() {
  std::vector<Keyframe*> out;
  for (auto& kf : map_.keyframes) out.push_back(kf.get());
  return out;
}

void WindowCore::startReference(const VisualFrame& frame, const SE3& T_W_B) {
  reference_ = makeReference(frame, T_W_B);
}

void WindowCore::Reference::keepSightings(int frame_record, const VisualFrame& frame) {
  std::vector<TrackObservation> seen;
  for (const auto& o : frame.observations)
    if (obs.count(o.track_id)) seen.push_back(o);
  pending.emplace_back(frame_record, std::move(seen));
}

void WindowCore::Reference::sharedBearings(const VisualFrame& frame, std::vector<Vec3>* b0,
                                           std::vector<Vec3>* b1, std::vector<TrackId>* ids) const {
  for (const auto& o : frame.observations) {
    auto it = obs.find(o.track_id);
    if (it == obs.end()) continue;
    b0->push_back(it->second.bearing_C);
    b1->push_back(o.bearing_C);
    if (ids) ids->push_back(o.track_id);
  }
}

Mat3 WindowCore::rotationFromReference(const VisualFrame& frame, const SE3& T_W_B_pred) const {
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
  reference_->sharedBearings(frame, &b0, &b1);
  if (auto R = fromView(reference_->T_W_B, b0, b1)) return *R;
  // The reference's tracks ran out (it restarts at this frame): the ground chain's recent anchor
  // still shares many, else the turn of this frame would be lost for good.
  if (ground_chain_) {
    b0.clear();
    b1.clear();
    if (auto T_W_A = ground_chain_->sharedWithAnchor(frame, &b0, &b1))
      if (auto R = fromView(*T_W_A, b0, b1)) return *R;
  }
  return T_W_B_pred.linear();
}

WindowCore::Reference WindowCore::makeReference(const VisualFrame& frame, const SE3& T_W_B) const {
  Reference r;
  r.t_ns = frame.t_ns;
  r.T_W_B = T_W_B;
  std::unordered_set<TrackId> near_beams;
  for (const auto& c : lidarCandidates(frame, scanFor(frame.t_ns, T_W_B)))
    near_beams.insert(c.track_id);
  for (const auto& o : selectSpread(frame.observations, {}, near_beams, options_))
    r.obs[o.track_id] = o;
  r.frame_index = static_cast<int>(frames_.size());
  return r;
}

void WindowCore::recordFrame(const FrameEstimate& e, int ref_kf) {
  FrameRecord r;
  r.t_ns = e.t_ns;
  r.T_W_B = e.T_W_B;
  r.tracked = e.tracked;
  r.is_keyframe = e.is_keyframe;
  if (ref_kf >= 0) {
    if (auto T_W_K = keyframePose(ref_kf)) {
      r.ref_kf = ref_kf;
      r.T_kf_B = T_W_K->inverse() * e.T_W_B;
    }
  }
  frames_.push_back(r);
}

std::optional<SE3> WindowCore::keyframePose(int kf_id, bool body) const {
  if (const Keyframe* kf = map_.find(kf_id)) return body ? kf->bodyPose() : kf->pose();
  for (const auto& kf : map_.archive)
    if (kf->id == kf_id) return body ? kf->bodyPose() : kf->pose();
  auto it = kf_poses_.find(kf_id);
  if (it != kf_poses_.end()) return body ? it->second.body : it->second.vision;
  return std::nullopt;
}

FrameEstimate WindowCore::processFrame(const VisualFrame& frame_in) {
  // A failed frontend frame counts as a frame without any track.
  VisualFrame blind;
  if (!frame_in.frontend_ok) blind.t_ns = frame_in.t_ns;
  const VisualFrame& frame = frame_in.frontend_ok ? frame_in : blind;
  const auto t_start = std::chrono::steady_clock::now();
  FrameEstimate e;
  e.t_ns = frame.t_ns;
  // The tracks followed between keyframes: the newest keyframe's and the landmarks (or the
  // initialisation reference's); the frontend's other tracks are only looked at for keyframes.
  std::unordered_set<TrackId> followed;
  if (initialized_ && !map_.empty()) {
    for (const auto& [id, o] : map_.keyframes.back()->observations) followed.insert(id);
    for (const auto& [id, lm] : map_.landmarks) followed.insert(id);
  } else if (reference_) {
    for (const auto& [id, o] : reference_->obs) followed.insert(id);
  }
  std::unordered_map<TrackId, TrackObservation> obs;
  if (frame.frontend_ok)
    for (const auto& o : frame.observations)
      if (!have_last_ || followed.count(o.track_id)) obs[o.track_id] = o;
  ++stats_.frames;

  if (!have_last_) {
    e.T_W_B = SE3::Identity();  // W = B at the first frame
    e.tracked = true;
    e.status = "initializing";
    startReference(frame, e.T_W_B);
    have_last_ = true;
    last_t_ = frame.t_ns;
    last_T_W_B_ = e.T_W_B;
    last_obs_ = std::move(obs);
    recordFrame(e, -1);
    ++stats_.frames_tracked;
    bias_history_.emplace_back(e.t_ns, bias_);
    e.estimator_ms = msSince(t_start);
    return e;
  }
  if (frame.t_ns <= last_t_) {  // out of order: hold
    e.T_W_B = last_T_W_B_;
    e.status = "out_of_order";
    recordFrame(e, -1);
    return e;
  }

  // Prediction: gyro rotation, constant velocity (decaying after a long gap).
  Prediction pred;
  pred.dt = toSeconds(frame.t_ns - last_t_);
  pred.T_W_B = last_T_W_B_;
  pred.rot_sigma = options_.rotation_prior_sigma_rad;
  double rate_radps = 0.0;
  if (auto pi = preintegrate(last_t_, frame.t_ns, bias_)) {
    pred.T_W_B.linear() = so3::orthonormalize(last_T_W_B_.linear() * pi->deltaR());
    pred.rot_sigma = std::sqrt(pi->covariance().trace() / 3.0 + pred.rot_sigma * pred.rot_sigma);
    rate_radps = so3::angle(pi->deltaR()) / pred.dt;
    pred.rotation_prior = pi->status() != factors::GyroPreintegration::Status::kNoData;
    if (pi->status() != factors::GyroPreintegration::Status::kOk) {
      if (!in_gap_) ++stats_.gyro_gaps;
      in_gap_ = true;
    } else {
      in_gap_ = false;
    }
  }
  pred.T_W_B.translation() = last_T_W_B_.translation() +
                             velocity_W_ * coastSeconds(pred.dt, options_.velocity_decay_per_s);

  // Flow to the previous frame (standstill detector).
  std::vector<double> flows;
  for (const auto& [id, o] : obs) {
    auto it = last_obs_.find(id);
    if (it != last_obs_.end()) flows.push_back((o.px - it->second.px).norm());
  }
  const double flow = frame.median_flow_px >= 0.0 ? frame.median_flow_px
                      : flows.size() >= 10        ? median(flows)
                                                  : 1e9;
  // Quiet gyro: the frame's samples scatter no more than sensor noise (no vibration, no turning)
  // and, once the bias is known, their bias-corrected rate is small (no slow steady turn). Before
  // that the mean rate is mostly bias (EuRoC's gyro: 0.08 rad/s): a robot that stands still at the
  // start would never count as still, and its bias would never be measured.
  bool gyro_quiet = !use_gyro_ || rate_radps < options_.standstill_gyro_radps;
  if (use_gyro_) {  // (too few samples, a gap: the rate test alone)
    GyroScatter scatter;
    for (const ImuSample& g : gyro_.around(last_t_, frame.t_ns))
      if (g.t_ns > last_t_ && g.t_ns <= frame.t_ns) scatter.add(g.gyro_radps);
    if (scatter.count >= 3)
      gyro_quiet = scatter.spread() <= options_.standstill_gyro_std_radps &&
                   (!initialized_ || rate_radps < options_.standstill_gyro_radps);
  }
  const bool standstill =
      !frame.observations.empty() && flow < options_.standstill_flow_px && gyro_quiet;

  // The first moving frame after still ones closes the standstill's zero-rate update.
  if (!standstill && still_bias_.inStreak()) endStandstill(frame.t_ns);
  if (!standstill)
    still_since_.reset();
  else if (!still_since_)
    still_since_ = frame.t_ns;
  const int ref_kf = standstill      ? processStill(frame, pred, obs, e)
                     : !initialized_ ? processBeforeInit(frame, pred, e)
                                     : processTracked(frame, pred, obs, e);

  if (!allFinite(e.T_W_B)) {  // never a NaN pose
    e.T_W_B = last_T_W_B_;
    e.tracked = false;
    e.status = "non_finite";
  }
  if (!map_.empty()) bias_ = map_.keyframes.back()->bias();
  e.gyro_bias = bias_;
  if (initialized_ && last_solve_.lidar_factors > 0) lidar_scale_ = true;
  e.scale_source_lidar = initialized_ && lidar_scale_ ? 1.0 : 0.0;
  if (e.tracked) ++stats_.frames_tracked;
  if (initialized_) {
    if (lidar_scale_)
      ++stats_.lidar_scale_frames;
    else
      ++stats_.ground_scale_frames;
  }
  last_t_ = frame.t_ns;
  last_T_W_B_ = e.T_W_B;
  last_obs_ = std::move(obs);
  recordFrame(e, ref_kf);
  bias_history_.emplace_back(e.t_ns, bias_);
  e.estimator_ms = msSince(t_start);
  return e;
}

int WindowCore::processStill(const VisualFrame& frame, const Prediction& pred,
                             const std::unordered_map<TrackId, TrackObservation>& obs,
                             FrameEstimate& e) {
  int ref_kf = -1;
  e.T_W_B = last_T_W_B_;
  // A robot coming to rest creeps on below the flow threshold: for standstill_settle_s the
  // still frames are still placed against the landmarks, then the pose is held (tracks chained
  // over still frames creep while the robot stands).
  if (initialized_ && !map_.empty() &&
      toSeconds(frame.t_ns - *still_since_) < options_.standstill_settle_s) {
    std::vector<TrackId> ids;
    std::size_t landmarks_seen = 0;
    if (const auto ref = refineAgainstMap(obs, pred, &ids, &landmarks_seen)) e.T_W_B = ref->T_W_B;
  }
  e.tracked = initialized_ || !reference_;
  e.status = "standstill";
  velocity_W_.setZero();
  if (initialized_ && !map_.empty()) ref_kf = map_.keyframes.back()->id;
  if (initialized_) still_reference_ = makeReference(frame, e.T_W_B);
  // Zero-rate update: the raw gyro rotation of a still frame is bias * dt plus noise.
  if (auto pi0 = preintegrate(last_t_, frame.t_ns, Vec3::Zero());
      pi0 && pi0->status() == factors::GyroPreintegration::Status::kOk) {
    still_bias_.add(frame.t_ns, so3::log(pi0->deltaR()), pred.dt);
    if (!initialized_)
      if (auto z = still_bias_.estimate(options_.standstill_min_bias_s)) bias_ = z->bias_radps;
  }
  if (!initialized_) {
    // Held before initialisation: the pose is known, and the two-view reference moves to
    // the last still frame so that no translation is lost when the robot starts.
    e.tracked = true;
    if (canReference(frame.t_ns)) startReference(frame, e.T_W_B);
    if (ground_chain_) ground_chain_->restart(frame, e.T_W_B);
    scale_wait_since_.reset();  // waiting while still loses no motion: the wait restarts
  }
  return ref_kf;
}

int WindowCore::processBeforeInit(const VisualFrame& frame, const Prediction& pred,
                                  FrameEstimate& e) {
  int ref_kf = -1;
  if (!reference_) startReference(frame, pred.T_W_B);
  velocity_W_ *= std::pow(options_.velocity_decay_per_s, pred.dt);
  SE3 T_ref = pred.T_W_B;
  T_ref.linear() = rotationFromReference(frame, pred.T_W_B);
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

int WindowCore::processTracked(const VisualFrame& frame, const Prediction& pred,
                               std::unordered_map<TrackId, TrackObservation>& obs,
                               FrameEstimate& e) {
  int ref_kf = -1;
  // Shortly after a standstill, the frames' sightings of the still frame's tracks are kept
  // for a restart from there.
  if (still_reference_) {
    if (toSeconds(frame.t_ns - still_reference_->t_ns) > kStillRestartS) {
      still_reference_.reset();
    } else {
      still_reference_->keepSightings(static_cast<int>(frames_.size()), frame);
    }
  }
  std::vector<TrackId> ids;
  std::size_t landmarks_seen = 0;
  const auto ref = refineAgainstMap(obs, pred, &ids, &landmarks_seen);
  if (ref) {
    lost_frames_ = 0;
    e.T_W_B = ref->T_W_B;
    e.tracked = true;
    const Vec3 v = (ref->T_W_B.translation() - last_T_W_B_.translation()) / pred.dt;
    velocity_W_ = 0.5 * velocity_W_ + 0.5 * v;
    std::unordered_set<TrackId> outliers;
    for (std::size_t i = 0; i < ids.size(); ++i)
      if (!ref->inlier[i]) {
        obs.erase(ids[i]);
        outliers.insert(ids[i]);
      }
    const bool has_scan = use_lidar_ && scanAt(frame.t_ns) != nullptr;
    if (isKeyframe(frame, e.T_W_B, has_scan)) {
      std::vector<TrackObservation> inlier_obs;
      inlier_obs.reserve(frame.observations.size());
      for (const auto& o : frame.observations)
        if (!outliers.count(o.track_id)) inlier_obs.push_back(o);
      Keyframe* kf = addKeyframe(frame.t_ns, e.T_W_B, bias_, inlier_obs, &obs);
      triangulateNewLandmarks(*kf);
      for (auto& k : map_.keyframes) associateLidar(*k, true);
      solveWindow();
      if (rescaleToLidar()) {
        for (auto& k : map_.keyframes) associateLidar(*k, true);
        solveWindow();
      }
      marginalize();
      e.T_W_B = map_.keyframes.back()->pose();
      e.is_keyframe = true;
    }
    ref_kf = map_.keyframes.back()->id;
  } else {
    e.T_W_B = pred.T_W_B;
    e.tracked = false;
    e.status = landmarks_seen < static_cast<std::size_t>(options_.min_landmark_observations)
                   ? "too_few_landmarks"
                   : "refinement_failed";
    velocity_W_ *= std::pow(options_.velocity_decay_per_s, pred.dt);
    if (lost_frames_++ == 0) ++stats_.tracking_losses;
    ref_kf = map_.keyframes.back()->id;
    const bool after_still =
        still_reference_ && toSeconds(frame.t_ns - still_reference_->t_ns) <= kStillRestartS;
    if (after_still) {
      // The tracks crept while the robot stood (each still frame's sub-pixel error adds up
      // along a track) and no longer fit the window's landmarks. The robot was still at the
      // last still frame, so its pose is known: a new segment starts there, not at a guess.
      note(
          "tracks no longer fit the window after a standstill: restarted from the last still "
          "frame");
      resetWindow();
      reference_ = std::move(still_reference_);
      still_reference_.reset();
      ref_kf = -1;
    } else if (lost_frames_ >= options_.reinit_after_lost_frames) {
      resetWindow();
      startReference(frame, pred.T_W_B);
      ref_kf = -1;
    }
  }
  return ref_kf;
}

std::optional<PoseRefinement> WindowCore::refineAgainstMap(
    const std::unordered_map<TrackId, TrackObservation>& obs, const Prediction& pred,
    std::vector<TrackId>* ids, std::size_t* landmarks_seen) const {
  std::vector<Vec3> points_W, bearings_C;
  ids->clear();
  for (const auto& [id, o] : obs) {
    if (auto p = map_.pointW(id, setup_.T_B_C)) {
      points_W.push_back(*p);
      bearings_C.push_back(o.bearing_C);
      ids->push_back(id);
    }
  }
  *landmarks_seen = points_W.size();
  if (static_cast<int>(points_W.size()) < options_.min_landmark_observations) return std::nullopt;
  auto ref = refinePose(
      points_W, bearings_C, pred.T_W_B,
      pred.rotation_prior ? std::optional<Mat3>(pred.T_W_B.linear()) : std::nullopt, pred.rot_sigma,
      model_, options_.motion_only_iterations, options_.outlier_angle_deg * kDegToRad);
  // Enough landmarks fit, and enough of those seen (tracks that crept far during a standstill
  // leave 5-10 % that fit by chance; a good frame fits 60-95 % of them, the first frames after a
  // stop on the simulated rows 22-45 %).
  if (!ref || ref->num_inliers < options_.min_landmark_observations ||
      ref->num_inliers < options_.min_inlier_fraction * static_cast<double>(points_W.size()))
    return std::nullopt;
  return ref;
}

bool WindowCore::isKeyframe(const VisualFrame& frame, const SE3& T_W_B, bool has_scan) const {
  const Keyframe& last = *map_.keyframes.back();
  const Mat3 R_Ck_C = setup_.T_B_C.linear().transpose() * last.pose().linear().transpose() *
                      T_W_B.linear() * setup_.T_B_C.linear();
  std::vector<double> angles;
  for (const auto& o : frame.observations) {
    auto it = last.observations.find(o.track_id);
    if (it == last.observations.end()) continue;
    angles.push_back(
        std::acos(std::clamp((R_Ck_C * o.bearing_C).dot(it->second.bearing_C), -1.0, 1.0)));
  }
  const double parallax_deg = median(angles) / kDegToRad;
  const double alive = last.observations.empty()
                           ? 0.0
                           : static_cast<double>(angles.size()) / last.observations.size();
  const double threshold =
      options_.kf_parallax_deg * (has_scan ? options_.kf_parallax_scan_fraction : 1.0);
  // A keyframe without a scan gets no LiDAR range; when the LiDAR runs at a fraction of the
  // camera rate, keyframes triggered by track loss alone would otherwise lock onto the frames
  // between scans (measured on the simulated rows: every keyframe from 15 to 18 s of
  // vineyard_row was one).
  const double min_alive =
      !has_scan && scanExpectedAfter(frame.t_ns)
          ? std::min(options_.kf_track_fraction_between_scans, options_.kf_track_fraction)
          : options_.kf_track_fraction;
  return angles.size() < 8 || parallax_deg >= threshold || alive < min_alive ||
         toSeconds(frame.t_ns - last.t_ns) >= options_.kf_max_interval_s;
}

std::vector<LidarAssociation> WindowCore::lidarCandidates(
    const VisualFrame& frame, const std::optional<FrameScan>& scan) const {
  std::vector<LidarAssociation> out;
  if (!scan) return out;
  for (const BeamMatch& m :
       associateBeams(usableBeams(*scan), frame.observations, options_.lidar_radius_px))
    out.push_back({m.track_id, m.range_m});
  return out;
}

std::vector<BeamInImage> WindowCore::usableBeams(const FrameScan& scan) const {
  return projectScan(*scan.scan, setup_.camera, cameraFromLidar(setup_.T_B_C, scan.T_B_L),
                     options_.lidar_edge_step, options_.lidar_edge_neighbours);
}

Keyframe* WindowCore::addKeyframe(Timestamp t_ns, const SE3& T_W_B, const Vec3& bias,
                                  const std::vector<TrackObservation>& candidates,
                                  const std::unordered_map<TrackId, TrackObservation>* keep) {
  VisualFrame frame;
  frame.t_ns = t_ns;
  frame.observations = candidates;
  const auto scan = scanFor(t_ns, T_W_B);
  const auto near_beams = lidarCandidates(frame, scan);
  std::unordered_set<TrackId> keep_ids, near_ids;
  if (keep != nullptr)
    for (const auto& [id, o] : *keep) keep_ids.insert(id);
  for (const auto& c : near_beams) near_ids.insert(c.track_id);
  const std::vector<TrackObservation> observations =
      keep == nullptr && near_ids.empty() ? candidates
                                          : selectSpread(candidates, keep_ids, near_ids, options_);
  auto kf = std::make_unique<Keyframe>(scan ? scan->T_B_L : setup_.T_B_L);
  kf->id = next_kf_id_++;
  kf->t_ns = t_ns;
  kf->setPose(T_W_B);
  kf->setBias(bias);
  kf->segment = segment_;
  for (const auto& o : observations) kf->observations[o.track_id] = o;
  for (const auto& c : near_beams)
    if (kf->observations.count(c.track_id)) kf->lidar_candidates.push_back(c);
  if (!map_.empty() && map_.keyframes.back()->segment == segment_) {
    const Keyframe& prev = *map_.keyframes.back();
    if (auto pi = preintegrate(prev.t_ns, t_ns, prev.bias()))
      kf->preint_from_prev = std::make_shared<factors::GyroPreintegration>(std::move(*pi));
  }
  if (scan) kf->scan = *scan->scan;
  kf_times_[kf->id] = t_ns;
  ++stats_.keyframes;
  map_.keyframes.push_back(std::move(kf));
  return map_.keyframes.back().get();
}

void WindowCore::triangulateNewLandmarks(Keyframe& kf) {
  const SE3 T_W_Cn = kf.pose() * setup_.T_B_C;
  const SE3 T_Cn_W = T_W_Cn.inverse();
  const double cos_min = std::cos(options_.landmark_min_parallax_deg * kDegToRad);
  for (const auto& [id, o] : kf.observations) {
    if (map_.landmarks.count(id)) continue;
    const Keyframe* anchor = nullptr;
    for (const auto& other : map_.keyframes) {
      if (other.get() == &kf) break;
      if (other->observations.count(id)) {
        anchor = other.get();
        break;
      }
    }
    if (anchor == nullptr) continue;
    const Vec3& b_a = anchor->observations.at(id).bearing_C;
    const SE3 T_Cn_Ca = T_Cn_W * anchor->pose() * setup_.T_B_C;
    if ((T_Cn_Ca.linear() * b_a).dot(o.bearing_C) > cos_min) continue;
    const auto p =
        frontend::triangulateMidpoint(T_Cn_Ca.linear(), T_Cn_Ca.translation(), b_a, o.bearing_C);
    if (!p || p->depth_prev < options_.landmark_min_depth_m ||
        p->depth_prev > options_.landmark_max_depth_m || p->depth_cur <= 0.0)
      continue;
    Landmark lm;
    lm.id = id;
    lm.anchor_kf = anchor->id;
    lm.bearing_anchor_C = b_a;
    lm.rho[0] = 1.0 / p->depth_prev;
    map_.landmarks[id] = lm;
  }
}

std::vector<WindowCore::LidarRange> WindowCore::lidarRangesAt(const Keyframe& kf) const {
  std::vector<LidarRange> out;
  if (!use_lidar_) return out;
  const SE3 T_L_W = (kf.pose() * kf.T_B_L).inverse();
  if (options_.lidar_interpolate) {
    // Every landmark the keyframe sees whose point lies within a small elevation of the scan
    // plane: the scan's range interpolated at its azimuth (no pixel-radius offset along the scan).
    if (!kf.scan) return out;
    const double max_tan_elevation = std::tan(options_.lidar_max_elevation_deg * kDegToRad);
    // Ground beams (isGroundBeam) are told apart unless lidar_ground_beams is raw.
    const double ground_height = options_.lidar_ground_beams != "raw" && setup_.camera_height_m
                                     ? *setup_.camera_height_m
                                     : 0.0;
    const bool skip_ground = options_.lidar_ground_beams == "skip";
    const SE3 T_C_L = cameraFromLidar(setup_.T_B_C, kf.T_B_L);
    const SE3 T_L_C = T_C_L.inverse();
    const Vec3 up_C = bodyUpIn(setup_.T_B_C);
    const Vec3 up_L = bodyUpIn(kf.T_B_L);
    for (const auto& [id, o] : kf.observations) {
      const auto p_W = map_.pointW(id, setup_.T_B_C);
      if (!p_W) continue;
      const Vec3 p_L = T_L_W * *p_W;
      const double d_xy = p_L.head<2>().norm();
      if (!(d_xy > 1e-3) || std::abs(p_L.z()) > max_tan_elevation * d_xy) continue;
      const double phi = std::atan2(p_L.y(), p_L.x());
      const auto r =
          interpolateRange(*kf.scan, phi, options_.lidar_edge_step, options_.lidar_edge_neighbours);
      if (!r) continue;
      LidarRange range{{id, *r, true}, d_xy, *r, false};
      const Vec3 hit_L(*r * std::cos(phi), *r * std::sin(phi), 0.0);
      if (isGroundBeam(T_C_L * hit_L, up_C, ground_height)) {
        if (skip_ground) continue;
        // plane: the landmark on the ground plane through the beam end; its distance for the
        // gate where the observed ray meets that plane.
        const auto d =
            groundRangeAlongRay(hit_L, up_L, T_L_C.translation(), T_L_C.rotation() * o.bearing_C);
        if (!d) continue;
        range = {
            {id, up_L.dot(hit_L), false, up_L, groundIncidenceSine(hit_L, up_L)}, d_xy, *d, true};
      }
      out.push_back(range);
    }
    return out;
  }
  for (const LidarAssociation& c : kf.lidar_candidates) {
    const auto p_W = map_.pointW(c.track_id, setup_.T_B_C);
    if (!p_W) continue;
    out.push_back({c, (T_L_W * *p_W).norm(), c.range_m, false});
  }
  return out;
}

void WindowCore::associateLidar(Keyframe& kf, bool gate_depth) {
  std::unordered_set<TrackId> have;
  for (const auto& a : kf.lidar) have.insert(a.track_id);
  for (const LidarRange& r : lidarRangesAt(kf)) {
    const TrackId id = r.association.track_id;
    if (have.count(id) || kf.lidar_rejected.count(id)) continue;
    if (gate_depth &&
        std::abs(r.landmark_m - r.measured_m) > options_.lidar_depth_gate * r.measured_m)
      continue;
    kf.lidar.push_back(r.association);
  }
}

std::optional<double> WindowCore::lidarScaleRatio() const {
  // Every range the window's keyframes measure to a landmark they see, gated or rejected or not:
  // the gates are what a wrong scale defeats. Ground beams are left out (their range hangs on
  // the plane's elevation, not on the scale alone).
  std::vector<std::pair<double, TrackId>> ratios;
  for (const auto& kf : map_.keyframes)
    for (const LidarRange& r : lidarRangesAt(*kf))
      if (!r.ground && r.measured_m > 0.0)
        ratios.emplace_back(r.landmark_m / r.measured_m, r.association.track_id);
  if (static_cast<int>(ratios.size()) < options_.lidar_rescale_min_ranges) return std::nullopt;
  std::vector<double> values;
  for (const auto& [ratio, id] : ratios) values.push_back(ratio);
  const double mid = median(values);
  // The ranges that agree with the median: at least half of them and min_ranges, from more than
  // one landmark (one landmark seen from every keyframe is one measurement, not a consensus).
  std::vector<double> agree;
  std::unordered_set<TrackId> tracks;
  for (const auto& [ratio, id] : ratios)
    if (std::abs(ratio / mid - 1.0) <= options_.lidar_rescale_agreement) {
      agree.push_back(ratio);
      tracks.insert(id);
    }
  if (static_cast<int>(agree.size()) < options_.lidar_rescale_min_ranges ||
      2 * agree.size() < ratios.size() || tracks.size() < 3)
    return std::nullopt;
  return median(agree);
}

bool WindowCore::rescaleToLidar() {
  if (!use_lidar_ || options_.lidar_rescale_ratio <= 0.0 || map_.keyframes.size() < 2) return false;
  const auto ratio = lidarScaleRatio();
  if (!ratio || !(*ratio > 0.0) || std::abs(*ratio - 1.0) <= options_.lidar_rescale_ratio)
    return false;
  const double s = 1.0 / *ratio;
  // About the oldest keyframe: the trajectory before the window stays where it is.
  const Vec3 centre = map_.keyframes.front()->pose().translation();
  const factors::TerrainScaling terrain = factors::terrainScaling(centre, s);
  std::vector<factors::MarginalizationInfo::BlockMap> moved;
  for (auto& kf : map_.keyframes) {
    Eigen::Map<Vec3> p(kf->p_W_B);
    p = centre + s * (p - centre);
    moved.push_back(factors::MarginalizationInfo::scaling(kf->p_W_B, centre, s));
    if (kf->terrain_set) factors::scaleTerrain(kf->terrain, centre, s);
    moved.push_back({kf->terrain, terrain.M, terrain.k});
    kf->lidar_rejected.clear();  // rejected at the wrong scale
  }
  for (auto& [id, lm] : map_.landmarks) lm.rho[0] /= s;
  if (gauge_.marginalization) gauge_.marginalization = gauge_.marginalization->mapped(moved);
  if (map_.find(gauge_.kf_id) != nullptr)  // a pose prior on a keyframe of the window moves too
    gauge_.T_W_B.translation() = centre + s * (gauge_.T_W_B.translation() - centre);
  velocity_W_ *= s;
  note("the LiDAR's ranges agreed on another scale than the window's: window rescaled to them");
  return true;
}

void WindowCore::solveWindow() {
  const auto t0 = std::chrono::steady_clock::now();
  auto kfs = windowKeyframes();
  seedTerrain(kfs, model_);
  auto factors = buildFactors(kfs, map_.landmarks, model_, gauge_);
  last_solve_ = {};
  last_solve_.keyframes = static_cast<int>(kfs.size());
  for (const auto& f : factors) last_solve_.lidar_factors += f.kind == FactorKind::kLidar;
  std::unordered_set<TrackId> active;
  for (const auto& f : factors)
    if (f.kind == FactorKind::kBearing) active.insert(f.track);
  last_solve_.landmarks = static_cast<int>(active.size());
  SolveOptions so;
  so.linear_solver = options_.linear_solver;
  so.max_iterations = options_.max_iterations;
  so.max_time_s = options_.max_solver_time_s;
  const SolveSummary s = solveFactors(std::move(factors), kfs, map_.landmarks, model_, so);
  last_solve_.residual_blocks = s.residual_blocks;
  last_solve_.iterations = s.iterations;
  removeOutliers();
  labelGround();
  repropagateGyro(kfs);
  last_solve_.solve_ms = msSince(t0);
}

void WindowCore::removeOutliers() {
  auto kfs = windowKeyframes();
  const double max_angle = options_.outlier_angle_deg * kDegToRad;
  for (const ObservationError& err : observationErrors(kfs, map_.landmarks, model_)) {
    if (err.angle_rad <= max_angle) continue;
    if (Keyframe* kf = map_.find(err.kf_id)) kf->observations.erase(err.track);
  }
  for (auto it = map_.landmarks.begin(); it != map_.landmarks.end();) {
    const Landmark& lm = it->second;
    const Keyframe* anchor = map_.find(lm.anchor_kf);
    const bool bad = anchor == nullptr || !anchor->observations.count(it->first) ||
                     lm.rho[0] <= model_.min_rho * 1.0001 || lm.rho[0] >= model_.max_rho * 0.9999;
    it = bad ? map_.landmarks.erase(it) : std::next(it);
  }
  // LiDAR associations that disagree with the solved landmark by more than the gate.
  for (Keyframe* kf : kfs) {
    std::erase_if(kf->lidar, [&](const LidarAssociation& a) {
      auto lm = map_.landmarks.find(a.track_id);
      if (lm == map_.landmarks.end()) return true;
      const auto p_W = map_.pointW(lm->second, setup_.T_B_C);
      const bool outlier = !p_W || lidarOutlier(a, *p_W, *kf, model_, options_.lidar_outlier_sigmas,
                                                options_.lidar_outlier_fraction);
      if (outlier) kf->lidar_rejected.insert(a.track_id);
      return outlier;
    });
  }
}

void WindowCore::labelGround() {
  labelGroundLandmarks(map_.landmarks, model_, options_, label_ground_options_);
}

void WindowCore::marginalize() {
  while (static_cast<int>(map_.keyframes.size()) > options_.window_size) {
    const auto t0 = std::chrono::steady_clock::now();
    Keyframe* oldest = map_.keyframes.front().get();
    // Landmarks seen twice more live on, re-anchored in the first later keyframe that sees them
    // in front (their point kept).
    std::unordered_map<TrackId, Reanchor> reanchor;
    for (const auto& [id, lm] : map_.landmarks) {
      if (lm.anchor_kf != oldest->id || map_.observationCount(id) - 1 < 2) continue;
      const auto p_W = map_.pointW(lm, setup_.T_B_C);
      if (!p_W) continue;
      for (std::size_t k = 1; k < map_.keyframes.size(); ++k) {
        const Keyframe& kf = *map_.keyframes[k];
        auto o = kf.observations.find(id);
        if (o == kf.observations.end()) continue;
        const Vec3 p_C = (kf.pose() * setup_.T_B_C).inverse() * *p_W;
        const double depth = o->second.bearing_C.dot(p_C);
        if (depth > options_.landmark_min_depth_m)
          reanchor[id] = {kf.id, o->second.bearing_C, 1.0 / depth};
        break;
      }
    }
    // Landmarks that end here, strongest first (LiDAR-linked, then most observed), up to the
    // optional bound (each costs O(k^2) in the prior's Schur step, k = the states it touches).
    std::vector<std::pair<int, TrackId>> ending;
    std::unordered_set<TrackId> lidar_tracks;
    for (const auto& kf : map_.keyframes)
      for (const auto& a : kf->lidar) lidar_tracks.insert(a.track_id);
    for (const auto& [id, lm] : map_.landmarks)
      if (lm.anchor_kf == oldest->id && !reanchor.count(id))
        ending.emplace_back(-(map_.observationCount(id) + (lidar_tracks.count(id) ? 100 : 0)), id);
    std::sort(ending.begin(), ending.end());
    std::unordered_map<TrackId, int> marginalized;  // track -> -1 (all its factors) or link kf
    const std::size_t max_marginalized =
        options_.marginalize_max_landmarks > 0
            ? static_cast<std::size_t>(options_.marginalize_max_landmarks)
            : ending.size();
    for (std::size_t k = 0; k < ending.size() && k < max_marginalized; ++k)
      if (ending[k].first <= -2) marginalized[ending[k].second] = -1;
    if (options_.marginalize_reanchored != "none")
      for (const auto& [id, r] : reanchor)
        marginalized[id] = options_.marginalize_reanchored == "all" ? -1 : r.kf_id;
    auto info = marginalizeOldest(map_, model_, gauge_, marginalized);
    map_.rememberPoints(setup_.T_B_C);
    keepPoses(*oldest);
    countLidar(*oldest, stats_);
    const int oldest_id = oldest->id;
    if (options_.refine == "full") map_.archive.push_back(std::move(map_.keyframes.front()));
    map_.keyframes.pop_front();

    for (auto it = map_.landmarks.begin(); it != map_.landmarks.end();) {
      Landmark& lm = it->second;
      if (lm.anchor_kf != oldest_id) {
        ++it;
        continue;
      }
      const auto r = reanchor.find(it->first);
      if (r == reanchor.end()) {
        it = map_.landmarks.erase(it);
        continue;
      }
      lm.anchor_kf = r->second.kf_id;
      lm.bearing_anchor_C = r->second.bearing_C;
      lm.rho[0] = r->second.rho;
      lm.on_ground = false;  // labelled again against the new anchor's plane
      ++it;
    }
    if (info) {
      gauge_.marginalization = info;
      gauge_.kf_id = -1;
    } else {  // fall back to a pose prior on the new oldest keyframe
      gauge_.marginalization.reset();
      gauge_.kf_id = map_.keyframes.front()->id;
      gauge_.T_W_B = map_.keyframes.front()->pose();
      gauge_.b_g = map_.keyframes.front()->bias();
      note("marginalisation failed once: gauge fixed by a pose prior instead");
    }
    last_solve_.marginalize_ms += msSince(t0);
  }
}

double WindowCore::walkedBiasSigma(double sigma_radps, double dt_s) const {
  return std::sqrt(sigma_radps * sigma_radps +
                   model_.bias_random_walk * model_.bias_random_walk * dt_s);
}

void WindowCore::endStandstill(Timestamp t_ns) {
  still_bias_.endStreak();
  if (!initialized_) {  // the streaks before initialisation add up
    if (auto z = still_bias_.estimate(options_.standstill_min_bias_s)) bias_ = z->bias_radps;
    return;
  }
  const auto z = still_bias_.estimate(options_.standstill_min_bias_s);
  still_bias_.reset();
  if (!z || map_.empty() || !use_gyro_) return;
  Keyframe& kf = *map_.keyframes.back();
  // The bias walks between the keyframe and the end of the standstill.
  const double walk_s = std::max(0.0, toSeconds(t_ns - kf.t_ns));
  const double sigma = walkedBiasSigma(z->sigma_radps, walk_s);
  if (kf.zero_rate) {  // a second standstill before the next keyframe: both, by information
    const double w0 = 1.0 / (kf.zero_rate->sigma_radps * kf.zero_rate->sigma_radps);
    const double w1 = 1.0 / (sigma * sigma);
    kf.zero_rate->bias_radps = (w0 * kf.zero_rate->bias_radps + w1 * z->bias_radps) / (w0 + w1);
    kf.zero_rate->sigma_radps = 1.0 / std::sqrt(w0 + w1);
  } else {
    kf.zero_rate = Keyframe::ZeroRate{z->bias_radps, sigma};
  }
  recent_zero_rate_ = {t_ns, *z};
  note("standstill: gyro bias from its mean rate (zero-rate factor on the last keyframe)");
}

void WindowCore::resetWindow() {
  if (!map_.empty()) carried_bias_ = {map_.keyframes.back()->t_ns, map_.keyframes.back()->bias()};
  map_.rememberPoints(setup_.T_B_C);
  for (auto& kf : map_.keyframes) {
    keepPoses(*kf);
    countLidar(*kf, stats_);
    if (options_.refine == "full") map_.archive.push_back(std::move(kf));
  }
  map_.keyframes.clear();
  map_.landmarks.clear();
  gauge_ = {};
  initialized_ = false;
  lidar_scale_ = false;
  ++segment_;
  reference_.reset();
}

bool WindowCore::tryInitialize(const VisualFrame& frame, const SE3& T_W_B_pred,
                               FrameEstimate* out) {
  Reference& ref = *reference_;
  std::vector<Vec3> b0, b1;
  std::vector<TrackId> ids;
  ref.sharedBearings(frame, &b0, &b1, &ids);
  // Waiting long without enough parallax (slow or far scene): accept half the parallax.
  const bool waited = toSeconds(frame.t_ns - ref.t_ns) > options_.init_max_wait_s;
  const double min_parallax_deg = options_.init_parallax_deg * (waited ? 0.5 : 1.0);
  if (static_cast<int>(ids.size()) < options_.init_min_tracks) {
    if (static_cast<int>(frame.observations.size()) >= options_.init_min_tracks)
      startReference(frame, T_W_B_pred);
    return false;
  }
  const Mat3 R_B_C = setup_.T_B_C.linear();
  Mat3 R_C1_C0 = Mat3::Identity();
  std::optional<TwoViewResult> tv;
  TwoViewOptions tvo;
  tvo.min_parallax_deg = options_.landmark_min_parallax_deg;
  tvo.min_points = std::max(10, options_.init_min_tracks / 2);
  tvo.inlier_rad = std::max(3.0 * model_.bearing_sigma_rad, 1e-3);
  if (use_gyro_) {
    R_C1_C0 = R_B_C.transpose() * T_W_B_pred.linear().transpose() * ref.T_W_B.linear() * R_B_C;
    if (medianParallaxDeg(b0, b1, R_C1_C0) < min_parallax_deg) return false;
    tv = twoViewKnownRotation(b0, b1, R_C1_C0, tvo);
  } else {
    const auto rp = relpose_->estimate(b0, b1);
    if (rp.status != frontend::RelativePoseResult::Status::kOk) return false;
    R_C1_C0 = rp.R_cur_prev;
    if (medianParallaxDeg(b0, b1, R_C1_C0) < min_parallax_deg) return false;
    auto t = triangulateTwoView(b0, b1, R_C1_C0, rp.t_cur_prev, &rp.inliers, tvo.min_parallax_deg);
    if (static_cast<int>(t.p_C0.size()) >= tvo.min_points) tv = std::move(t);
  }
  if (!tv) return false;

  // Metric scale: LiDAR ranges against the unit-baseline points, else the ground plane.
  // Putting off is only safe while the shared tracks are plentiful: once they run out the
  // reference restarts at the current frame and the motion since the old one is lost.
  const bool can_defer = scale_deferrals_ < kMaxScaleDeferrals &&
                         static_cast<int>(ids.size()) >= 4 * options_.init_min_tracks;
  std::optional<double> scale;
  std::optional<double> ground_scale;
  if (setup_.camera_height_m) {
    const Vec3 up_C0 = bodyUpIn(setup_.T_B_C);
    if (auto plane = fitGroundPlane(tv->p_C0, up_C0, ground_options_))
      if (plane->height > 1e-9) ground_scale = *setup_.camera_height_m / plane->height;
  }
  lidar_scale_ = false;
  if (use_lidar_) {
    std::unordered_map<TrackId, int> point_of;
    for (std::size_t k = 0; k < tv->points_index.size(); ++k)
      point_of[ids[tv->points_index[k]]] = static_cast<int>(k);
    std::vector<double> ratios;
    for (int view = 0; view < 2; ++view) {
      const auto scan = view == 0 ? scanFor(ref.t_ns, ref.T_W_B) : scanFor(frame.t_ns, T_W_B_pred);
      if (!scan) continue;
      const auto beams = usableBeams(*scan);
      const auto& observations = view == 0 ? toVector(ref.obs) : frame.observations;
      for (const BeamMatch& m : associateBeams(beams, observations, options_.lidar_radius_px)) {
        auto it = point_of.find(m.track_id);
        if (it == point_of.end()) continue;
        const Vec3& p0 = tv->p_C0[it->second];
        const double unit = view == 0 ? p0.norm() : (tv->R_C1_C0 * p0 + tv->t_C1_C0).norm();
        if (unit > 1e-6) ratios.push_back(m.beam_dist_C / unit);
      }
    }
    using Outcome = LidarScaleVote::Outcome;
    const LidarScaleVote vote =
        voteLidarScale(std::move(ratios), ground_scale, options_.lidar_min_associations, can_defer);
    switch (vote.outcome) {
      case Outcome::kAgreed:
        break;
      case Outcome::kGroundSettled:
        note(
            "LiDAR scale ambiguous at an initialisation: the group that the ground plane agrees "
            "with");
        break;
      case Outcome::kPutOff:
        ++scale_deferrals_;
        note("LiDAR scale ambiguous at an initialisation (two groups of range ratios): put off");
        return false;
      case Outcome::kForced:
        note("LiDAR scale stayed ambiguous at an initialisation: the nearest surfaces");
        break;
      case Outcome::kOverruled:
        note(
            "LiDAR range ratios disagreed with the ground plane at an initialisation: "
            "ground-plane scale there");
        break;
      case Outcome::kTooFew:
        note("LiDAR associated too few points at an initialisation: ground-plane scale there");
        break;
    }
    scale = vote.scale;
    lidar_scale_ = vote.scale.has_value();
  }
  if (!scale) scale = ground_scale;
  // A window started at a wrong scale keeps it: the LiDAR and ground gates then reject every
  // measurement that would correct it. With a scale sensor, wait for a frame that gives a scale.
  const bool can_scale = use_lidar_ || setup_.camera_height_m.has_value();
  if (!scale && can_scale) {
    if (!scale_wait_since_) scale_wait_since_ = frame.t_ns;
    if (can_defer) {
      ++scale_deferrals_;
      note("no LiDAR or ground-plane scale at an initialisation: put off");
      return false;
    }
    if (toSeconds(frame.t_ns - *scale_wait_since_) < kMaxScaleWaitS) {
      // The shared tracks run out (or the reference waited long). A unit baseline now would keep
      // a wrong scale for good (10x on a spin with 60 tracks a keyframe); a new reference here
      // loses the motion since the old one, and the scale comes with a later frame.
      if (!canReference(frame.t_ns)) return false;
      note(
          "no LiDAR or ground-plane scale at an initialisation as the shared tracks ran out: "
          "the two-view reference restarted");
      scale_deferrals_ = 0;
      startReference(frame, T_W_B_pred);
      return false;
    }
  }
  scale_deferrals_ = 0;
  scale_wait_since_.reset();
  if (!scale) {
    scale = 1.0;
    note("initialisation without LiDAR or ground-plane scale: unit baseline");
  }

  SE3 T_C1_C0 = SE3::Identity();
  T_C1_C0.linear() = tv->R_C1_C0;
  T_C1_C0.translation() = *scale * tv->t_C1_C0;
  const SE3 T_W_B1 = ref.T_W_B * setup_.T_B_C * T_C1_C0.inverse() * setup_.T_B_C.inverse();

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
  Keyframe* kf0 = addKeyframe(ref.t_ns, ref.T_W_B, bias_, toVector(ref.obs), nullptr);
  Keyframe* kf1 = addKeyframe(frame.t_ns, T_W_B1, bias_, frame.observations, &keep1);
  for (std::size_t k = 0; k < tv->points_index.size(); ++k) {
    const double depth = *scale * tv->depth0[k];
    if (depth < options_.landmark_min_depth_m || depth > options_.landmark_max_depth_m) continue;
    Landmark lm;
    lm.id = ids[tv->points_index[k]];
    lm.anchor_kf = kf0->id;
    lm.bearing_anchor_C = b0[tv->points_index[k]];
    lm.rho[0] = 1.0 / depth;
    map_.landmarks[lm.id] = lm;
  }
  gauge_ = {};
  gauge_.kf_id = kf0->id;
  gauge_.T_W_B = ref.T_W_B;
  gauge_.b_g = bias_;
  gauge_.b_g_sigma_radps = bias_sigma_radps;
  if (bias_note) note(bias_note);
  if (options_.refine == "full") segment_gauges_.push_back(gauge_);
  carried_bias_.reset();
  recent_zero_rate_.reset();
  still_bias_.reset();
  associateLidar(*kf0, true);
  associateLidar(*kf1, true);
  initialized_ = true;
  if (ground_chain_) ground_chain_->reset();
  solveWindow();

  // Frames between the reference and now: positions interpolated in time, against kf0.
  const SE3 T_W_K0 = kf0->pose();
  const SE3 T_W_K1 = kf1->pose();
  for (std::size_t i = static_cast<std::size_t>(ref.frame_index); i < frames_.size(); ++i) {
    FrameRecord& r = frames_[i];
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
    if (index <= ref.frame_index || index >= static_cast<int>(frames_.size())) continue;
    std::vector<Vec3> points_W, bearings_C;
    for (const TrackObservation& o : seen) {
      if (auto p = map_.pointW(o.track_id, setup_.T_B_C)) {
        points_W.push_back(*p);
        bearings_C.push_back(o.bearing_C);
      }
    }
    if (static_cast<int>(points_W.size()) < options_.min_landmark_observations) continue;
    FrameRecord& r = frames_[index];
    const auto refined = refinePose(
        points_W, bearings_C, r.T_W_B, r.T_W_B.linear(), options_.rotation_prior_sigma_rad, model_,
        options_.motion_only_iterations, options_.outlier_angle_deg * kDegToRad);
    if (!refined || refined->num_inliers < options_.min_landmark_observations) continue;
    r.T_W_B = refined->T_W_B;
    r.T_kf_B = T_W_K0.inverse() * r.T_W_B;
  }
  reference_.reset();
  lost_frames_ = 0;
  velocity_W_ = (T_W_K1.translation() - T_W_K0.translation()) / toSeconds(frame.t_ns - kf0->t_ns);
  out->T_W_B = T_W_K1;
  out->tracked = true;
  out->is_keyframe = true;
  out->status = "initialized";
  return true;
}

void WindowCore::refineAll() {
  std::vector<Keyframe*> kfs;
  for (auto& kf : map_.archive) kfs.push_back(kf.get());
  for (auto& kf : map_.keyframes) kfs.push_back(kf.get());
  std::sort(kfs.begin(), kfs.end(),
            [](const Keyframe* a, const Keyframe* b) { return a->id < b->id; });
  if (kfs.size() < 2) return;
  map_.rememberPoints(setup_.T_B_C);
  // Each segment's first keyframe keeps the bias prior it started with, at its pose now.
  std::vector<WindowGauge> gauges = segment_gauges_;
  for (WindowGauge& g : gauges)
    if (auto T_W_B = keyframePose(g.kf_id)) g.T_W_B = *T_W_B;
  stats_.refine =
      refineKeyframes(kfs, map_.last_point_W, model_, gauges, options_, label_ground_options_);
  if (!stats_.refine->usable) note("full refinement failed: the online keyframe poses are kept");
  for (const Keyframe* kf : kfs) keepPoses(*kf);
}

void WindowCore::finish() {
  if (finished_) return;
  finished_ = true;
  if (options_.refine == "full") refineAll();
  for (const auto& kf : map_.keyframes) keepPoses(*kf);
}

Trajectory WindowCore::trajectory() const {
  Trajectory out;
  out.reserve(frames_.size());
  for (const FrameRecord& r : frames_) {
    SE3 T = r.T_W_B;
    if (r.ref_kf >= 0)
      if (auto T_W_K = keyframePose(r.ref_kf, true)) T = *T_W_K * r.T_kf_B;
    if (!allFinite(T)) T = r.T_W_B;
    out.push_back({r.t_ns, T});
  }
  return out;
}

Trajectory WindowCore::keyframes() const {
  Trajectory out;
  for (const auto& [id, t_ns] : kf_times_)
    if (auto T_W_B = keyframePose(id, true)) out.push_back({t_ns, *T_W_B});
  return out;
}

void WindowCore::countLidar(const Keyframe& kf, EstimatorStats& stats) {
  stats.lidar_keyframes += kf.lidar.empty() ? 0 : 1;
  stats.lidar_ranges += static_cast<int>(kf.lidar.size());
}

EstimatorStats WindowCore::stats() const {
  EstimatorStats s = stats_;  // plus the keyframes still in the window
  for (const auto& kf : map_.keyframes) countLidar(*kf, s);
  return s;
}

}  // namespace ovo::estimator
