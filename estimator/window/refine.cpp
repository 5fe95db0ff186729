// The offline full refinement of every keyframe of the run.
#include "estimator/window/refine.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>

#include "common/stats.hpp"
#include "estimator/estimator.hpp"
#include "estimator/window/lidar_gate.hpp"
#include "estimator/window/sighting.hpp"
#include "estimator/window/terrain.hpp"
#include "factors/bias_prior_factor.hpp"
#include "factors/pose_prior_factor.hpp"
#include "frontend/triangulation.hpp"

namespace ovo::estimator {
namespace {

constexpr double kDegToRad = M_PI / 180.0;
// Pose prior of a later segment's first keyframe at its online pose (m, rad).
constexpr double kSegmentSigmaM = 1e-3;
constexpr double kSegmentSigmaRad = 1e-3;

/// A batch copy of a keyframe: the same states and factors, observations keyed by landmark piece.
std::unique_ptr<Keyframe> batchCopy(const Keyframe& kf) {
  auto b = std::make_unique<Keyframe>(kf.T_B_L);  // the LiDAR factors' pose of the scan
  b->id = kf.id;
  b->t_ns = kf.t_ns;
  b->copyStates(kf);
  b->preint_from_prev = kf.preint_from_prev;
  b->accel_from_prev = kf.accel_from_prev;
  b->segment = kf.segment;
  b->zero_rate = kf.zero_rate;
  b->readout = kf.readout;  // a rolling shutter's rows
  return b;
}

/// Inverse depth of a piece along its anchor bearing: from the last window estimate of the track,
/// else the midpoint triangulation against the sighting of widest parallax at the current poses.
std::optional<double> initialRho(const std::vector<const Keyframe*>& seen,
                                 const std::vector<TrackObservation>& sightings,
                                 const Vec3* point_W, const WindowModel& model,
                                 const WindowOptions& options) {
  // Each camera at its sighting's row (a rolling shutter).
  const auto T_W_C = [&](std::size_t k) {
    return seen[k]->pose() * seen[k]->cameraAt(sightings[k], model.T_B_C);
  };
  std::vector<Vec3> bearings_C;
  for (const auto& o : sightings) bearings_C.push_back(o.bearing_C);
  const SE3 T_W_Ca = T_W_C(0);
  const Vec3& b_a = bearings_C.front();
  if (point_W != nullptr) {
    const double depth = b_a.dot(T_W_Ca.inverse() * *point_W);
    if (depth > options.landmark_min_depth_m && depth < options.landmark_max_depth_m)
      return 1.0 / depth;
  }
  double best_cos = std::cos(options.landmark_min_parallax_deg * kDegToRad);
  std::size_t best = 0;
  for (std::size_t k = 1; k < seen.size(); ++k) {
    const Mat3 R_Ck_Ca = T_W_C(k).linear().transpose() * T_W_Ca.linear();
    const double c = (R_Ck_Ca * b_a).dot(bearings_C[k]);
    if (c < best_cos) best_cos = c, best = k;
  }
  if (best == 0) return std::nullopt;
  const SE3 T_Ck_Ca = T_W_C(best).inverse() * T_W_Ca;
  const auto p =
      frontend::triangulateMidpoint(T_Ck_Ca.linear(), T_Ck_Ca.translation(), b_a, bearings_C[best]);
  if (!p || p->depth_prev < options.landmark_min_depth_m ||
      p->depth_prev > options.landmark_max_depth_m || p->depth_cur <= 0.0)
    return std::nullopt;
  return 1.0 / p->depth_prev;
}

}  // namespace

RefineInfo refineKeyframes(const std::vector<Keyframe*>& keyframes,
                           const std::unordered_map<TrackId, Vec3>& points_W,
                           const WindowModel& window_model,
                           const std::vector<WindowGauge>& segment_gauges,
                           const WindowOptions& options, const GroundPlaneOptions& ground_options,
                           const double* time_offset_s, const double* gravity) {
  WindowModel model = window_model;
  double td[1] = {time_offset_s ? time_offset_s[0] : 0.0};               // the batch's copy, held
  // The batch's copy of the run's gravity and accelerometer bias, estimated again.
  double g[factors::kGravityStateSize] = {};
  if (gravity) std::copy_n(gravity, factors::kGravityStateSize, g);
  model.terrain_planes = model.terrain_planes && options.refine_ground;  // no ground: no terrain
  model.bearing_steps = useBearingSteps(options.refine_bearing_steps, options);
  RefineInfo info;
  info.keyframes = static_cast<int>(keyframes.size());
  if (keyframes.size() < 2) return info;
  WindowGauge gauge;
  gauge.kf_id = keyframes.front()->id;
  gauge.T_W_B = keyframes.front()->pose();
  gauge.b_g = keyframes.front()->bias();
  std::unordered_map<int, const WindowGauge*> later_gauges;
  for (const WindowGauge& g : segment_gauges) {
    if (g.kf_id == gauge.kf_id) {
      gauge = g;
      gauge.marginalization.reset();
    } else {
      later_gauges[g.kf_id] = &g;
    }
  }
  std::vector<std::unique_ptr<Keyframe>> batch;
  std::vector<Keyframe*> kfs;
  for (const Keyframe* kf : keyframes) {
    batch.push_back(batchCopy(*kf));
    kfs.push_back(batch.back().get());
  }

  // Landmark pieces: a track's sightings in one segment, cut after refine_max_span_frames frames
  // unless bearing steps model the creep (with steps the batch does better with the tracks uncut).
  // Pieces get fresh ids (the batch copies observe pieces, not tracks).
  std::map<TrackId, std::vector<int>> sightings;  // track -> keyframe indices, time order
  for (std::size_t k = 0; k < keyframes.size(); ++k)
    for (const auto& [id, o] : keyframes[k]->observations)
      sightings[id].push_back(static_cast<int>(k));
  std::unordered_map<TrackId, Landmark> landmarks;
  std::vector<std::unordered_map<TrackId, TrackId>> piece_of(keyframes.size());  // track -> piece
  const int max_span = model.bearing_steps ? 0 : options.refine_max_span_frames;
  TrackId next_piece = 0;
  for (const auto& [track, ks] : sightings) {
    for (std::size_t start = 0; start < ks.size();) {
      const int age0 = keyframes[ks[start]]->observations.at(track).age;
      std::size_t end = start + 1;
      while (end < ks.size() && kfs[ks[end]]->segment == kfs[ks[start]]->segment &&
             (max_span <= 0 || keyframes[ks[end]]->observations.at(track).age - age0 <= max_span))
        ++end;
      if (end - start >= 2) {
        std::vector<const Keyframe*> seen;
        std::vector<TrackObservation> sightings;
        for (std::size_t i = start; i < end; ++i) {
          seen.push_back(kfs[ks[i]]);
          sightings.push_back(keyframes[ks[i]]->observations.at(track));
        }
        const auto p = points_W.find(track);
        const auto rho = initialRho(seen, sightings, p == points_W.end() ? nullptr : &p->second,
                                    model, options);
        if (rho) {
          const TrackId piece = next_piece++;
          Landmark lm;
          lm.id = piece;
          lm.anchor_kf = kfs[ks[start]]->id;
          lm.bearing_anchor_C = sightings.front().bearing_C;
          lm.anchor_row_s = sightings.front().row_s;
          lm.rho[0] = *rho;
          landmarks[piece] = lm;
          for (std::size_t i = start; i < end; ++i) {
            kfs[ks[i]]->observations[piece] = keyframes[ks[i]]->observations.at(track);
            piece_of[ks[i]][track] = piece;
          }
        }
      }
      start = end;
    }
  }
  for (std::size_t k = 0; k < keyframes.size(); ++k) {
    for (LidarAssociation a : keyframes[k]->lidar) {
      auto it = piece_of[k].find(a.track_id);
      if (it == piece_of[k].end()) continue;
      a.track_id = it->second;
      kfs[k]->lidar.push_back(a);
    }
  }
  info.landmarks = static_cast<int>(landmarks.size());
  if (options.refine_ground) labelGroundLandmarks(landmarks, model, options, ground_options);
  seedTerrain(kfs, model);

  const int passes = std::max(1, options.refine_passes);
  for (int pass = 0; pass < passes; ++pass) {
    auto factors =
        buildFactors(kfs, landmarks, model, gauge, nullptr, time_offset_s ? td : nullptr, nullptr,
                     gravity ? g : nullptr);
    // Each later segment keeps its placement (nothing links segments but the gyro) and the bias
    // prior it started with.
    for (std::size_t k = 1; k < kfs.size(); ++k) {
      if (kfs[k]->segment == kfs[k - 1]->segment) continue;
      FactorSpec p;
      p.kind = FactorKind::kPosePrior;
      p.cost = std::make_unique<factors::PosePriorFactor>(
          keyframes[k]->pose(), factors::PosePriorFactor::gaugeInformation(
                                    kSegmentSigmaM, kSegmentSigmaRad, kSegmentSigmaRad));
      p.blocks = {kfs[k]->q_W_B, kfs[k]->p_W_B};
      p.kf_id = kfs[k]->id;
      factors.push_back(std::move(p));
      const auto g = later_gauges.find(kfs[k]->id);
      if (!model.use_gyro || g == later_gauges.end()) continue;
      FactorSpec b;
      b.kind = FactorKind::kBiasPrior;
      b.cost = std::make_unique<factors::BiasPriorFactor>(
          g->second->b_g, g->second->b_g_sigma_radps > 0.0 ? g->second->b_g_sigma_radps
                                                           : model.bias_prior_sigma_radps);
      b.blocks = {kfs[k]->b_g};
      b.kf_id = kfs[k]->id;
      factors.push_back(std::move(b));
    }
    info.bearing_factors = info.lidar_factors = info.ground_factors = 0;
    for (const FactorSpec& f : factors) {
      info.bearing_factors += f.kind == FactorKind::kBearing;
      info.lidar_factors += f.kind == FactorKind::kLidar;
      info.ground_factors += f.kind == FactorKind::kGround;
    }
    SolveOptions so;
    so.linear_solver = LinearSolver::kSparseSchur;
    so.max_iterations = options.refine_iterations;
    // Held at the online estimate: the gyro intervals of the keyframes that left the window were
    // made at the offset of their time (the samples are gone), and the first-order shift of the
    // earliest, made before the estimate settled, is too coarse to estimate the offset from.
    so.time_offset = {time_offset_s ? td : nullptr, options.time_offset_max_s, /*hold=*/true};
    so.gravity = gravity ? g : nullptr;
    so.height_offset_max_abs = 5.0 * model.camera_height_path_sigma_m;
    const SolveSummary s = solveFactors(std::move(factors), kfs, landmarks, model, so);
    ++info.passes;
    info.iterations += s.iterations;
    if (pass == 0) info.initial_cost = s.initial_cost;
    info.final_cost = s.final_cost;
    info.message = s.message;
    if (!s.usable) return info;
    if (pass + 1 == passes) break;

    // Outliers at the solved states: bearings beyond the window's gate, LiDAR ranges beyond its
    // gate, landmarks at a depth bound; the gyro factors re-linearised at the new biases.
    for (const ObservationError& err : observationErrors(kfs, landmarks, model)) {
      if (err.sigmas <= options.outlier_sigmas) continue;
      for (Keyframe* kf : kfs)
        if (kf->id == err.kf_id) info.removed_outliers += kf->observations.erase(err.track);
    }
    std::unordered_map<int, Keyframe*> kf_of;
    for (Keyframe* kf : kfs) kf_of[kf->id] = kf;
    for (Keyframe* kf : kfs) {
      info.removed_outliers += std::erase_if(kf->lidar, [&](const LidarAssociation& a) {
        const auto lm = landmarks.find(a.track_id);
        if (lm == landmarks.end()) return true;
        const auto p_W = landmarkPointW(*kf_of.at(lm->second.anchor_kf), lm->second, model.T_B_C);
        if (!p_W) return true;
        return lidarOutlier(a, *p_W, *kf, model, options.lidar_outlier_sigmas,
                            options.lidar_outlier_fraction);
      });
    }
    if (options.refine_ground) labelGroundLandmarks(landmarks, model, options, ground_options);
    repropagateGyro(kfs);
  }
  info.usable = true;
  for (std::size_t k = 0; k < keyframes.size(); ++k) keyframes[k]->copyStates(*kfs[k]);
  return info;
}

}  // namespace ovo::estimator
