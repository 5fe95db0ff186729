// The window core's frame loop (core.hpp says what it does and where its parts live):
// construction, the scans' intake, each frame from prediction to a new keyframe, the frame
// records and the output.
#include "estimator/window/core.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <unordered_set>
#include <utility>

#include "common/so3.hpp"
#include "estimator/common/lidar_deskew.hpp"
#include "estimator/window/keyframe_policy.hpp"
#include "estimator/window/landmarks.hpp"
#include "estimator/window/refine.hpp"
#include "estimator/window/rescale.hpp"
#include "factors/bearing_factor.hpp"

namespace ovo::estimator {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

double pixelSigma(const SensorSetup& setup, const WindowOptions& options) {
  return options.pixel_sigma > 0.0 ? options.pixel_sigma : setup.pixel_sigma;
}

/// The two-view threshold of the initialisation and the ground chain: 3 bearing sigmas, at least
/// 1 mrad.
double twoViewInlierRad(const SensorSetup& setup, const WindowOptions& options) {
  return std::max(3.0 * pixelSigma(setup, options) / camera::focalPx(setup.camera), 1e-3);
}

}  // namespace

WindowCore::WindowCore(const SensorSetup& setup, const WindowOptions& options,
                       const frontend::RelativePoseOptions& relpose_options,
                       const GroundPlaneOptions& ground_options)
    : setup_(setup),
      options_(options),
      model_(makeWindowModel(setup, options)),
      ground_options_(ground_options),
      use_gyro_(options.use_gyro && setup.has_gyro),
      use_lidar_(options.use_lidar && setup.has_lidar),
      gyro_(gyroFrontOptions(options)),
      scans_(options_),
      lidar_(setup_, options_),
      starter_(setup_, options_, ground_options, relpose_options, twoViewInlierRad(setup, options),
               lidar_, use_gyro_, use_lidar_, [this](const std::string& text) { note(text); }),
      still_bias_(setup.gyro_noise_density,
                  options.gyro_bias_random_walk > 0.0 ? options.gyro_bias_random_walk
                                                      : setup.gyro_bias_random_walk,
                  options.standstill_trim_s) {
  // Without a LiDAR the ground is the only scale after the start: a looser gate, so that a start
  // from a poor plane is corrected, not kept to the end as the tight gate keeps it.
  label_ground_options_ = ground_options;
  if (!use_lidar_) {
    options_.ground_scale_gate = options_.ground_scale_gate_no_lidar;
    // ... and a plane tilted against the body's up biases it: the keyframes' camera-height planes
    // and the ground chain's before the start use a tighter normal than vo.ground's 20 deg (the
    // start's two-view plane keeps that: it needs any plane it can get).
    label_ground_options_.max_normal_deviation_deg = std::min(
        label_ground_options_.max_normal_deviation_deg, options_.ground_normal_max_deg_no_lidar);
  }
  if (!use_gyro_) note("no gyro: vision-only rotation (8-point initialisation, no gyro factors)");
  if (!use_lidar_) {
    note(setup.camera_height_m ? "no LiDAR: ground-plane scale at initialisation (camera_height_m)"
                               : "no LiDAR and no camera height: scale is arbitrary");
  }
  if (setup.camera_height_m && *setup.camera_height_m > 0.0) {
    GroundChainOptions chain;
    chain.min_parallax_deg = options.landmark_min_parallax_deg;
    chain.min_point_parallax_deg = options.landmark_min_parallax_deg;
    ground_chain_.emplace(setup.T_B_C, *setup.camera_height_m, twoViewInlierRad(setup, options),
                          label_ground_options_, chain);
  }
}

WindowCore::~WindowCore() = default;

void WindowCore::note(const std::string& text) {
  if (std::find(stats_.notes.begin(), stats_.notes.end(), text) == stats_.notes.end())
    stats_.notes.push_back(text);
}

void WindowCore::addScan(const LidarScan& scan) {
  if (!use_lidar_) return;
  // Keep what the window can still use: scans newer than the oldest frame of interest.
  Timestamp keep_from = last_t_ - fromSeconds(5.0);
  if (reference_) keep_from = std::min(keep_from, reference_->t_ns);
  // The scans go onto the images' timeline (their stamps are on the gyro clock, the images' run
  // ahead by the time offset) by the newest estimate of the offset (solveWindow moves them on).
  scans_.setShift(gyroShift());
  LidarScan made = deskewed(scan);
  if (followsCameraHeight(model_) && !(options_.camera_height_path_sigma_m > 0.0)) {
    // The terrain's roughness in the last 100 scans with a ground line (labelGround's sigma).
    constexpr std::size_t kRecentScans = 100;
    if (const auto r = groundRoughnessFromScan(made, setup_.T_B_L, model_.lidar_range_sigma_m))
      ground_roughness_.push_back(*r);
    while (ground_roughness_.size() > kRecentScans) ground_roughness_.pop_front();
  }
  scans_.add(std::move(made), keep_from);
}

LidarScan WindowCore::deskewed(const LidarScan& scan) const {
  if (!options_.lidar_deskew || scan.time_increment_s == 0.0 || scan.ranges_m.size() < 2)
    return scan;
  // The body's mean rate over the sweep from the gyro (held past its newest sample: the scan may
  // arrive before the gyro of its last beams), and its velocity from the frames.
  const auto [t0, t1] = sweepInterval(scan);
  Vec3 w_B = Vec3::Zero();
  if (const auto pi = preintegrateOnGyroClock(t0, t1, bias_);
      pi && pi->status() != factors::GyroPreintegration::Status::kNoData)
    w_B = so3::log(pi->deltaR()) / toSeconds(t1 - t0);
  const Vec3 v_B = last_T_W_B_.linear().transpose() * velocity_W_;
  return deskewScan(scan, lidarMotionFromBody([w_B](double tau_s) { return so3::exp(w_B * tau_s); },
                                              v_B, setup_.T_B_L));
}

std::optional<FrameScan> WindowCore::scanFor(Timestamp t_ns, const SE3& T_W_B) const {
  if (!use_lidar_) return std::nullopt;
  return scans_.scanFor(t_ns, T_W_B, velocity_W_, frames_, setup_.T_B_L,
                        [this](Timestamp t0, Timestamp t1) { return gyroRotation(t0, t1); });
}

bool WindowCore::canReference(Timestamp t_ns) const {
  return !use_lidar_ ||
         scans_.choose(t_ns, [this](Timestamp t0, Timestamp t1) { return gyroRotation(t0, t1); })
             .has_value();
}

std::vector<Keyframe*> WindowCore::windowKeyframes() {
  std::vector<Keyframe*> out;
  for (auto& kf : map_.keyframes) out.push_back(kf.get());
  return out;
}

void WindowCore::recordFrame(const FrameEstimate& e, int ref_kf) {
  FrameRecord r;
  r.gyro = std::exchange(frame_gyro_, std::nullopt);
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
  frames_.add(r);
}

std::optional<KeyframeState> WindowCore::keyframeState(int kf_id) const {
  const Keyframe* kf = map_.find(kf_id);
  for (std::size_t k = 0; kf == nullptr && k < map_.archive.size(); ++k)
    if (map_.archive[k]->id == kf_id) kf = map_.archive[k].get();
  if (kf != nullptr) return KeyframeState{kf->pose(), kf->bodyPose(), kf->bias()};
  return frames_.keptState(kf_id);
}

std::optional<SE3> WindowCore::keyframePose(int kf_id, bool body) const {
  const auto state = keyframeState(kf_id);
  if (!state) return std::nullopt;
  return body ? state->body : state->vision;
}

FrameEstimate WindowCore::processFrame(VisualFrame frame_in) {
  // Each sighting's row time, once, for every consumer (a rolling shutter; 0 with a global one).
  for (auto& o : frame_in.observations) o.row_s = model_.rowTime(o.px);
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
    frames_.addBias(e.t_ns, bias_);
    e.estimator_ms = msSince(t_start);
    return e;
  }
  if (frame.t_ns <= last_t_) {  // out of order: hold
    e.T_W_B = last_T_W_B_;
    e.status = "out_of_order";
    recordFrame(e, -1);
    return e;
  }

  const Prediction pred = predict(frame.t_ns);
  const bool standstill = still(frame, obs, pred);

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
  frames_.addBias(e.t_ns, bias_);
  // (With the history, frames settle when a keyframe leaves the window: a parked robot's then
  // wait for the next keyframe.)
  if (!frames_.keepsHistory()) settleFrames();
  trimGyro();
  e.estimator_ms = msSince(t_start);
  return e;
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
    KeyframeContext context;
    context.has_scan = use_lidar_ && scans_.at(frame.t_ns) != nullptr;
    context.scan_expected_after = use_lidar_ && scans_.expectedAfter(frame.t_ns, last_t_);
    if (isKeyframe(frame, e.T_W_B, *map_.keyframes.back(), setup_.T_B_C, context, options_)) {
      std::vector<TrackObservation> inlier_obs;
      inlier_obs.reserve(frame.observations.size());
      for (const auto& o : frame.observations)
        if (!outliers.count(o.track_id)) inlier_obs.push_back(o);
      Keyframe* kf = addKeyframe(frame.t_ns, e.T_W_B, bias_, inlier_obs, &obs);
      triangulateNewLandmarks(map_, *kf, setup_.T_B_C, options_);
      associateLidar();
      solveWindow();
      if (rescaleToLidar() || rescaleToGround()) {
        associateLidar();
        solveWindow();
      }
      marginalize();
      e.T_W_B = map_.keyframes.back()->pose();
      e.is_keyframe = true;
    }
    ref_kf = map_.keyframes.back()->id;
    if (!e.is_keyframe) carryGyroRotation(*map_.keyframes.back(), e);
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
  std::vector<SE3> cameras_B;
  const Readout readout = readoutAt(pred.t_ns, pred.T_W_B, bias_);
  ids->clear();
  for (const auto& [id, o] : obs) {
    if (auto p = map_.pointW(id, setup_.T_B_C)) {
      points_W.push_back(*p);
      bearings_C.push_back(o.bearing_C);
      cameras_B.push_back(readout.cameraAt(o.row_s, setup_.T_B_C));
      ids->push_back(id);
    }
  }
  *landmarks_seen = points_W.size();
  if (static_cast<int>(points_W.size()) < options_.min_landmark_observations) return std::nullopt;
  auto ref = refinePose(
      points_W, bearings_C, cameras_B, pred.T_W_B,
      pred.rotation_prior ? std::optional<Mat3>(pred.T_W_B.linear()) : std::nullopt, pred.rot_sigma,
      model_, options_.motion_only_iterations, options_.outlier_angle_deg * kDegToRad);
  // Enough landmarks fit, and enough of those seen (tracks that crept far during a standstill
  // leave a few that fit by chance; a good frame fits most of them, the first frames after a stop
  // fewer).
  if (!ref || ref->num_inliers < options_.min_landmark_observations ||
      ref->num_inliers < options_.min_inlier_fraction * static_cast<double>(points_W.size()))
    return std::nullopt;
  return ref;
}

Keyframe* WindowCore::addKeyframe(Timestamp t_ns, const SE3& T_W_B, const Vec3& bias,
                                  const std::vector<TrackObservation>& candidates,
                                  const std::unordered_map<TrackId, TrackObservation>* keep) {
  const auto scan = scanFor(t_ns, T_W_B);
  const auto near_beams = lidar_.candidates(candidates, scan);
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
  kf->readout = readoutAt(t_ns, T_W_B, bias);
  kf->segment = segment_;
  for (const auto& o : observations) {
    TrackObservation& kept = kf->observations[o.track_id] = o;
    if (model_.bearing_sigma_from_camera) kept.px_per_rad = pixelsPerRadian(o.bearing_C);
  }
  for (const auto& c : near_beams)
    if (kf->observations.count(c.track_id)) kf->lidar_candidates.push_back(c);
  if (!map_.empty() && map_.keyframes.back()->segment == segment_) {
    const Keyframe& prev = *map_.keyframes.back();
    if (auto pi = preintegrate(prev.t_ns, t_ns, prev.bias()))
      kf->preint_from_prev = std::make_shared<factors::GyroPreintegration>(std::move(*pi));
    kf->accel_from_prev = accelInterval(prev.t_ns, t_ns, prev.bias());
    kf->height_offset_m[0] = prev.height_offset_m[0];  // the ground goes on as it was
  }
  if (scan) kf->scan = *scan->scan;
  frames_.addKeyframeTime(kf->id, t_ns);
  ++stats_.keyframes;
  map_.keyframes.push_back(std::move(kf));
  return map_.keyframes.back().get();
}

Mat2 WindowCore::pixelsPerRadian(const Vec3& bearing_C) const {
  Eigen::Matrix<double, 2, 3> J;
  if (!camera::project(setup_.camera, bearing_C, &J) || !J.allFinite()) return Mat2::Zero();
  const Mat2 J_t = J * factors::BearingFactor::tangentBasis(bearing_C).transpose();
  // A Jacobian that has lost its rank (the model's edge) says nothing usable.
  return std::abs(J_t.determinant()) > 1e-6 * model_.focal_px * model_.focal_px ? J_t
                                                                                : Mat2::Zero();
}

Trajectory WindowCore::trajectory() const {
  return ontoGyroClock(frames_.trajectory([this](int id) { return keyframeState(id); }));
}

Trajectory WindowCore::keyframes() const {
  return ontoGyroClock(frames_.keyframes([this](int id) { return keyframeState(id); }));
}

std::vector<std::pair<Timestamp, Vec3>> WindowCore::biasHistory() const {
  auto bias = frames_.biasHistory();
  const Timestamp shift = gyroShift();  // (as ontoGyroClock)
  for (auto& [t_ns, b] : bias) t_ns -= shift;
  return bias;
}

void WindowCore::countKeyframe(const Keyframe& kf, EstimatorStats& stats) const {
  if (followsCameraHeight(model_)) stats.camera_height_path_m.push_back(kf.height_offset_m[0]);
  stats.lidar_keyframes += kf.lidar.empty() ? 0 : 1;
  stats.lidar_ranges += static_cast<int>(kf.lidar.size());
  if (kf.lidar.empty() && kf.lidar_rejected.empty()) return;
  if (!stats.lidar_residuals) {
    stats.lidar_residuals.emplace();
    stats.lidar_residuals->range_sigma_m = model_.lidar_range_sigma_m;
  }
  LidarResidualStats& r = *stats.lidar_residuals;
  // The keyframe's mean turn rate since the previous keyframe (the gyro's, bias removed).
  bool turning = false;
  if (const auto& pre = kf.preint_from_prev; pre && pre->dtSeconds() > 0.0) {
    turning = so3::angle(pre->deltaR(kf.bias())) / pre->dtSeconds() >
              LidarResidualStats::kTurningDegS * M_PI / 180.0;
  }
  const int rejected = static_cast<int>(kf.lidar_rejected.size());
  r.rejected += rejected;
  if (turning) r.turning_rejected += rejected;
  for (const LidarAssociation& a : kf.lidar) {
    if (!a.ground_up_L.isZero()) continue;  // a ground-plane height, not a range
    const auto p_W = map_.pointW(a.track_id, setup_.T_B_C);
    if (!p_W) continue;
    const auto residual = lidarResidualM(a, *p_W, kf);
    if (!residual || !std::isfinite(*residual)) continue;
    const double sq = *residual * *residual;
    ++r.count;
    r.sum_sq_m2 += sq;
    if (turning) {
      ++r.turning_count;
      r.turning_sum_sq_m2 += sq;
    }
  }
}

EstimatorStats WindowCore::stats() const {
  EstimatorStats s = stats_;  // plus the keyframes still in the window
  for (const auto& kf : map_.keyframes) countKeyframe(*kf, s);
  if (estimatesTimeOffset(model_)) s.time_offset_s = map_.time_offset_s[0];
  if (estimatesCameraHeight(model_)) s.camera_height_offset_m = map_.camera_height_offset_m[0];
  if (followsCameraHeight(model_)) s.camera_height_path_sigma_m = model_.camera_height_path_sigma_m;
  return s;
}

}  // namespace ovo::estimator
