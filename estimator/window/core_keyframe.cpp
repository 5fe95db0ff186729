// The window core's keyframe step: the keyframes' LiDAR associations, the rescales (to the LiDAR's
// ranges, or to the ground planes for a window started without a scale), the solve with its
// outlier pass and ground labels, the marginalisation of the oldest keyframe, the settling of the
// frames it held, the reset after a loss, and the offline refinement at the end.
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <unordered_set>
#include <utility>

#include "common/so3.hpp"
#include "estimator/common/lidar_deskew.hpp"
#include "estimator/window/core.hpp"
#include "estimator/window/covariance.hpp"
#include "estimator/window/keyframe_policy.hpp"
#include "estimator/window/landmarks.hpp"
#include "estimator/window/refine.hpp"
#include "estimator/window/rescale.hpp"
#include "factors/bearing_factor.hpp"

namespace ovo::estimator {

void WindowCore::associateLidar() {
  if (!use_lidar_) return;
  attachLateScans();
  for (auto& k : map_.keyframes) lidar_.associate(*k, map_, true);
}

void WindowCore::attachLateScans() {
  // A keyframe's scan may come after it: a camera whose stamps run early, before the window has
  // found the offset (its scans are then placed anew, ScanTimeline::setShift), or a LiDAR that
  // lags the camera. The scan at the keyframe's time is the keyframe's (the rig's T_B_L, which a
  // keyframe without a scan has already), with its beams paired to the keyframe's tracks.
  for (auto& k : map_.keyframes) {
    if (k->scan) continue;
    const LidarScan* s = scans_.at(k->t_ns);
    if (s == nullptr) continue;
    k->scan = *s;
    std::vector<TrackObservation> observations;
    observations.reserve(k->observations.size());
    for (const auto& [id, o] : k->observations) observations.push_back(o);
    std::sort(observations.begin(), observations.end(),
              [](const TrackObservation& a, const TrackObservation& b) {
                return a.track_id < b.track_id;
              });
    k->lidar_candidates = lidar_.candidates(observations, FrameScan{&*k->scan, k->T_B_L});
  }
}

bool WindowCore::rescaleToLidar() {
  if (!use_lidar_ || options_.lidar_rescale_ratio <= 0.0 || map_.keyframes.size() < 2) return false;
  bool searched = false;
  const auto ratio = lidar_.scaleRatio(map_, &searched);
  const auto previous = std::exchange(searched_ratio_, std::nullopt);
  if (!ratio || !(*ratio > 0.0)) return false;
  if (searched &&
      !(previous && std::abs(*ratio / *previous - 1.0) <= options_.lidar_rescale_agreement)) {
    searched_ratio_ = ratio;  // found once: again at the next keyframe before it counts
    return false;
  }
  if (std::abs(*ratio - 1.0) <= options_.lidar_rescale_ratio) {
    scale_known_ = true;  // the LiDAR agrees with the window's scale
    return false;
  }
  rescaleBy(1.0 / *ratio);
  note("the LiDAR's ranges agreed on another scale than the window's: window rescaled to them");
  return true;
}

bool WindowCore::rescaleToGround() {
  // At least this many keyframes' planes, more than half within this fraction of their median;
  // and a rescale within these bounds (a plane at a near-zero height is no scale).
  constexpr int kMinKeyframes = 2;
  constexpr double kAgreement = 0.1;
  constexpr double kMinFactor = 0.01, kMaxFactor = 100.0;
  const double h = heightCorrectedModel().camera_height_m;
  if (scale_known_ || lidar_scale_ || last_solve_.lidar_factors > 0 || !(h > 0.0)) return false;
  const auto height = agreedGroundHeight(ground_heights_, kMinKeyframes, kAgreement);
  if (!height) return false;
  const double factor = h / *height;
  if (!(factor >= kMinFactor && factor <= kMaxFactor)) return false;
  rescaleBy(factor);
  note("the window started without a scale: rescaled to the ground plane's camera height");
  return true;
}

void WindowCore::rescaleBy(double s) {
  rescaleWindow(s, map_, gauge_, frames_, {last_T_W_B_, velocity_W_}, setup_.T_B_L);
  scale_known_ = true;
  // A restart from the last still frame would start at its pose of the old scale.
  still_reference_.reset();
}

void WindowCore::solveWindow() {
  const auto t0 = std::chrono::steady_clock::now();
  refreshGyroFactors();
  auto kfs = windowKeyframes();
  seedTerrain(kfs, model_);
  setGravity();
  auto factors = buildFactors(kfs, map_.landmarks, model_, gauge_, &ledger_, map_.time_offset_s,
                              map_.camera_height_offset_m, map_.gravity);
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
  so.stop_decrease = options_.solver_stop_decrease;
  so.max_time_s = options_.max_solver_time_s;
  so.time_offset = {map_.time_offset_s, options_.time_offset_max_s};
  so.camera_height_offset = {map_.camera_height_offset_m,
                             5.0 * model_.camera_height_offset_sigma_m};
  so.height_offset_max_abs = 5.0 * model_.camera_height_path_sigma_m;
  so.gravity = map_.gravity;
  const SolveSummary s = solveFactors(std::move(factors), kfs, map_.landmarks, model_, so);
  if (s.failed) {
    if (++stats_.solve_failures == 1)
      note(fmt::format(
          "window: a keyframe solve failed and was undone (its states restored; solve_failures "
          "counts them); the first said: {}",
          s.message.empty() ? "a state came out non-finite" : s.message));
  }
  frames_.setTimeShift(toSeconds(gyroShift()));
  scans_.setShift(gyroShift());
  last_solve_.residual_blocks = s.residual_blocks;
  last_solve_.iterations = s.iterations;
  removeOutliers(map_, model_, options_);
  labelGround();
  repropagateGyro(kfs);
  last_solve_.solve_ms = msSince(t0);
}

std::optional<Eigen::Matrix<double, 6, 6>> WindowCore::newestPoseCovariance() {
  if (!initialized_ || map_.empty()) return std::nullopt;
  auto kfs = windowKeyframes();
  auto factors = buildFactors(kfs, map_.landmarks, model_, gauge_, &ledger_, map_.time_offset_s,
                              map_.camera_height_offset_m, map_.gravity);
  return poseCovariance(std::move(factors), kfs, model_, *kfs.back());
}

void WindowCore::labelGround() {
  ground_heights_ =
      labelGroundLandmarks(map_.landmarks, heightCorrectedModel(), options_, label_ground_options_);
  if (followsCameraHeight(model_) && !(options_.camera_height_path_sigma_m > 0.0)) {
    // The correction's strength is the terrain's roughness, which the LiDAR's ground beams measure
    // in metres whatever the window's scale (the ground's own offsets, at the window's scale,
    // read a scale error as terrain).
    constexpr int kMinScans = 10;
    if (const auto terrain = terrainRoughness(ground_roughness_, kMinScans))
      model_.camera_height_path_sigma_m =
          std::clamp(*terrain, kPathHeightSigmaMinM, kPathHeightSigmaMaxM);
  }
}

WindowModel WindowCore::heightCorrectedModel() const {
  WindowModel model = model_;
  if (estimatesCameraHeight(model_)) {
    model.camera_height_m += map_.camera_height_offset_m[0];
    model.camera_height_offset_sigma_m = 0.0;
  }
  return model;
}

void WindowCore::marginalize() {
  while (static_cast<int>(map_.keyframes.size()) > options_.window_size) {
    const auto t0 = std::chrono::steady_clock::now();
    Keyframe* oldest = map_.keyframes.front().get();
    const MarginalizationPlan plan = planMarginalization(map_, setup_.T_B_C, options_);
    auto info = marginalizeOldest(map_, model_, gauge_, plan, &ledger_);
    // The landmarks' last points seed the full refinement (kept only for it: they grow).
    if (options_.refine == RefineMode::kFull) map_.rememberPoints(setup_.T_B_C);
    frames_.keepPoses(*oldest);
    countKeyframe(*oldest, stats_);
    const int oldest_id = oldest->id;
    if (options_.refine == RefineMode::kFull)
      map_.archive.push_back(std::move(map_.keyframes.front()));
    map_.keyframes.pop_front();
    ledger_.forgetBefore(map_.keyframes.front()->id);
    reanchorLandmarks(map_, oldest_id, plan);
    if (info) {
      gauge_.marginalization = info;
      gauge_.kf_id = -1;
    } else {  // fall back to a pose prior on the new oldest keyframe
      gauge_.marginalization.reset();
      gauge_.kf_id = map_.keyframes.front()->id;
      gauge_.T_W_B = map_.keyframes.front()->pose();
      gauge_.b_g = map_.keyframes.front()->bias();
      ++stats_.marginalization_failures;
      note(
          "window: a marginalisation failed: the gauge was held by a pose prior on the oldest "
          "keyframe instead, and the factors meant for the prior were dropped "
          "(marginalization_failures counts them)");
    }
    last_solve_.marginalize_ms += msSince(t0);
  }
  settleFrames();
}

void WindowCore::settleFrames() {
  if (options_.refine == RefineMode::kFull) return;
  const Timestamp recent = last_t_ - fromSeconds(kSettleAfterS);  // scans look back this far
  if (!frames_.keepsHistory()) {
    // Nothing is kept: a frame goes once it is that old, whatever its keyframe or reference (a
    // later start would place it again only for the output), so that a parked robot (no new
    // keyframe) or one that never starts holds no more frames than a moving one. The
    // reference's sightings of frames gone go with them.
    frames_.settle(recent, [this](int id) { return keyframeState(id); });
    const std::size_t first_open = frames_.size() - frames_.open().size();
    for (auto* ref : {&reference_, &still_reference_})
      if (*ref) (*ref)->forgetSightingsBefore(static_cast<int>(first_open));
    return;
  }
  // A keyframe that left the window keeps its pose, unless the full refinement moves it at the
  // end; frames are settled up to the window's oldest keyframe and the frames a restart may
  // still place (from its reference on).
  if (map_.empty()) return;
  Timestamp before = std::min(map_.keyframes.front()->t_ns, recent);
  if (reference_) before = std::min(before, reference_->t_ns);
  if (still_reference_) before = std::min(before, still_reference_->t_ns);
  frames_.settle(before, [this](int id) { return keyframeState(id); });
}

void WindowCore::resetWindow() {
  if (!map_.empty()) carried_bias_ = {map_.keyframes.back()->t_ns, map_.keyframes.back()->bias()};
  if (options_.refine == RefineMode::kFull) map_.rememberPoints(setup_.T_B_C);
  // Counted before any keyframe moves out: the residuals look up the landmarks' anchors.
  for (const auto& kf : map_.keyframes) countKeyframe(*kf, stats_);
  for (auto& kf : map_.keyframes) {
    frames_.keepPoses(*kf);
    if (options_.refine == RefineMode::kFull) map_.archive.push_back(std::move(kf));
  }
  map_.keyframes.clear();
  map_.landmarks.clear();
  gauge_ = {};
  ledger_ = {};
  initialized_ = false;
  lidar_scale_ = false;
  ++segment_;
  reference_.reset();
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
  // The camera height as corrected online: the run's correction held; the corrections along the
  // path estimated again, bounded as online.
  stats_.refine = refineKeyframes(kfs, map_.last_point_W, heightCorrectedModel(), gauges, options_,
                                  label_ground_options_, map_.time_offset_s,
                                  map_.gravity_set ? map_.gravity : nullptr);
  if (!stats_.refine->usable) note("full refinement failed: the online keyframe poses are kept");
  for (const Keyframe* kf : kfs) frames_.keepPoses(*kf);
}

void WindowCore::finish() {
  if (finished_) return;
  finished_ = true;
  if (options_.refine == RefineMode::kFull) refineAll();
  for (const auto& kf : map_.keyframes) frames_.keepPoses(*kf);
}

}  // namespace ovo::estimator
