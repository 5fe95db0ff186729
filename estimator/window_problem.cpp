#include "estimator/window_problem.hpp"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <unordered_map>
#include <unordered_set>

#include "factors/bearing_factor.hpp"
#include "factors/bearing_step_factor.hpp"
#include "factors/ground_height_factor.hpp"
#include "factors/lidar_range_factor.hpp"
#include "factors/parameterization.hpp"
#include "factors/pose_prior_factor.hpp"
#include "factors/rotation_tie_factor.hpp"
#include "factors/terrain_plane_factor.hpp"

namespace ovo::estimator {
namespace {

std::unordered_map<int, Keyframe*> byId(const std::vector<Keyframe*>& keyframes) {
  std::unordered_map<int, Keyframe*> out;
  for (Keyframe* kf : keyframes) out[kf->id] = kf;
  return out;
}

/// True when the keyframes' gyro factors see an orientation of their own (q_W_G), tied to q_W_B.
bool tiedRotations(const WindowModel& model) {
  return model.use_gyro && model.vision_rotation_sigma_rad > 0.0;
}

/// The orientation block a keyframe's gyro factors use.
double* gyroRotation(Keyframe& kf, const WindowModel& model) {
  return tiedRotations(model) ? kf.q_W_G : kf.q_W_B;
}

/// The bearing sigma of a sighting against one `frames` earlier on the same track (rad): the
/// sightings' own noise (white_sq, rad^2) and the track's creep in between, which random-walks.
double creepSigma(double white_sq, double frames, const WindowModel& model) {
  return std::sqrt(white_sq + model.bearing_creep_rad * model.bearing_creep_rad * frames);
}

}  // namespace

bool usesTerrain(const WindowModel& model) {
  return model.terrain_planes && model.camera_height_m > 0.0;
}

void seedTerrain(const std::vector<Keyframe*>& keyframes, const WindowModel& model) {
  if (!usesTerrain(model)) return;
  const Keyframe* prev = nullptr;
  for (Keyframe* kf : keyframes) {
    if (!kf->terrain_set) {
      if (prev != nullptr)
        std::copy_n(prev->terrain, 3, kf->terrain);
      else
        factors::terrainBelow(kf->pose(), model.T_B_C, model.camera_height_m, kf->terrain);
      kf->terrain_set = true;
    }
    prev = kf;
  }
}

std::vector<FactorSpec> buildFactors(const std::vector<Keyframe*>& keyframes,
                                     std::unordered_map<TrackId, Landmark>& landmarks,
                                     const WindowModel& model, const WindowGauge& gauge) {
  std::vector<FactorSpec> out;
  const auto kf_of = byId(keyframes);

  // Bearing and LiDAR factors of the landmarks.
  for (auto& [id, lm] : landmarks) {
    auto anchor_it = kf_of.find(lm.anchor_kf);
    if (anchor_it == kf_of.end() || !(lm.rho[0] > 0.0)) continue;
    Keyframe* anchor = anchor_it->second;
    // With bearing steps each sighting after the first is tied to the previous kept one.
    Keyframe* prev = nullptr;
    for (Keyframe* kf : keyframes) {
      if (kf == anchor) continue;
      auto obs = kf->observations.find(id);
      if (obs == kf->observations.end()) continue;
      const auto u = factors::predictBearing(lm.bearing_anchor_C, model.T_B_C.linear(),
                                             model.T_B_C.translation(), anchor->q_W_B,
                                             anchor->p_W_B, kf->q_W_B, kf->p_W_B, lm.rho[0], false);
      if (!u || u->u.dot(obs->second.bearing_C) < std::cos(0.2)) continue;  // gross: > 11 deg
      FactorSpec f;
      f.kind = FactorKind::kBearing;
      if (model.bearing_steps && prev != nullptr) {
        const TrackObservation& oi = prev->observations.at(id);
        const double frames = std::max(0, obs->second.age - oi.age);
        // The step's two sightings each carry their own noise.
        const double sigma_rad =
            creepSigma(2.0 * model.step_white_rad * model.step_white_rad, frames, model);
        f.cost = std::make_unique<factors::BearingStepFactor>(
            lm.bearing_anchor_C, oi.bearing_C, obs->second.bearing_C, model.T_B_C, sigma_rad);
        f.blocks = {anchor->q_W_B, anchor->p_W_B, prev->q_W_B, prev->p_W_B,
                    kf->q_W_B,     kf->p_W_B,     lm.rho};
      } else {
        // Tracks creep (a random walk of the sub-pixel position per frame): the error between the
        // anchor's and this observation grows with the frames between them.
        double sigma_rad = model.bearing_sigma_rad;
        if (model.bearing_creep_rad > 0.0) {
          auto a = anchor->observations.find(id);
          const int frames =
              a == anchor->observations.end() ? 0 : std::max(0, obs->second.age - a->second.age);
          sigma_rad = creepSigma(sigma_rad * sigma_rad, frames, model);
        }
        f.cost = std::make_unique<factors::BearingFactor>(
            lm.bearing_anchor_C, obs->second.bearing_C, model.T_B_C, sigma_rad);
        f.blocks = {anchor->q_W_B, anchor->p_W_B, kf->q_W_B, kf->p_W_B, lm.rho};
      }
      f.loss = std::make_unique<ceres::HuberLoss>(model.bearing_huber);
      f.track = id;
      f.kf_id = kf->id;
      out.push_back(std::move(f));
      prev = kf;
    }
  }
  if (usesTerrain(model)) {
    for (auto& [id, lm] : landmarks) {
      auto a = kf_of.find(lm.anchor_kf);
      if (!lm.on_ground || a == kf_of.end() || !a->second->terrain_set || !(lm.rho[0] > 0.0))
        continue;
      FactorSpec f;
      f.kind = FactorKind::kTerrain;
      f.cost = std::make_unique<factors::TerrainPointFactor>(lm.bearing_anchor_C, model.T_B_C,
                                                             model.ground_sigma_m);
      f.loss = std::make_unique<ceres::HuberLoss>(model.ground_huber);
      f.blocks = {a->second->q_W_B, a->second->p_W_B, lm.rho, a->second->terrain};
      f.track = id;
      f.kf_id = lm.anchor_kf;
      out.push_back(std::move(f));
    }
    for (std::size_t k = 1; k < keyframes.size(); ++k) {
      Keyframe* i = keyframes[k - 1];
      Keyframe* j = keyframes[k];
      if (!i->terrain_set || !j->terrain_set) continue;
      const Vec3 ci = i->pose() * model.T_B_C.translation();
      const Vec3 cj = j->pose() * model.T_B_C.translation();
      FactorSpec w;
      w.kind = FactorKind::kTerrain;
      w.cost = std::make_unique<factors::TerrainWalkFactor>(
          0.5 * (ci + cj), (cj - ci).norm(), model.terrain_slope_walk, model.terrain_height_walk);
      w.blocks = {i->terrain, j->terrain};
      w.kf_id = j->id;
      out.push_back(std::move(w));
    }
  }
  if (model.camera_height_m > 0.0) {
    for (auto& [id, lm] : landmarks) {
      if (!lm.on_ground || !kf_of.count(lm.anchor_kf) || !(lm.rho[0] > 0.0)) continue;
      FactorSpec f;
      f.kind = FactorKind::kGround;
      f.cost = std::make_unique<factors::GroundHeightFactor>(
          lm.bearing_anchor_C, lm.ground_up_C, model.camera_height_m, model.ground_sigma_m);
      f.loss = std::make_unique<ceres::HuberLoss>(model.ground_huber);
      f.blocks = {lm.rho};
      f.track = id;
      f.kf_id = lm.anchor_kf;
      out.push_back(std::move(f));
    }
  }
  for (Keyframe* kf : keyframes) {
    for (const LidarAssociation& a : kf->lidar) {
      auto lm_it = landmarks.find(a.track_id);
      if (lm_it == landmarks.end()) continue;
      Landmark& lm = lm_it->second;
      auto anchor_it = kf_of.find(lm.anchor_kf);
      if (anchor_it == kf_of.end() || !(lm.rho[0] > 0.0)) continue;
      FactorSpec f;
      f.kind = FactorKind::kLidar;
      if (model.lidar_cauchy)
        f.loss = std::make_unique<ceres::CauchyLoss>(model.lidar_huber);
      else
        f.loss = std::make_unique<ceres::HuberLoss>(model.lidar_huber);
      const double sigma = lidarSigma(a, model);
      if (anchor_it->second == kf) {
        f.cost = std::make_unique<factors::LidarRangeAnchorFactor>(
            lm.bearing_anchor_C, a.range_m, model.T_B_C, kf->T_B_L, sigma, a.planar, a.ground_up_L);
        f.blocks = {lm.rho};
      } else {
        Keyframe* anchor = anchor_it->second;
        f.cost = std::make_unique<factors::LidarRangeFactor>(
            lm.bearing_anchor_C, a.range_m, model.T_B_C, kf->T_B_L, sigma, a.planar, a.ground_up_L);
        f.blocks = {anchor->q_W_B, anchor->p_W_B, kf->q_W_B, kf->p_W_B, lm.rho};
      }
      f.track = a.track_id;
      f.kf_id = kf->id;
      out.push_back(std::move(f));
    }
  }

  // Gyro and bias factors between consecutive keyframes of one segment.
  if (model.use_gyro) {
    for (std::size_t k = 1; k < keyframes.size(); ++k) {
      Keyframe* i = keyframes[k - 1];
      Keyframe* j = keyframes[k];
      if (i->segment != j->segment || !j->preint_from_prev) continue;
      FactorSpec g;
      g.kind = FactorKind::kGyro;
      g.cost = std::make_unique<factors::GyroFactor>(j->preint_from_prev);
      g.blocks = {gyroRotation(*i, model), gyroRotation(*j, model), i->b_g};
      g.kf_id = j->id;
      out.push_back(std::move(g));
      FactorSpec w;
      w.kind = FactorKind::kBiasWalk;
      w.cost = std::make_unique<factors::BiasRandomWalkFactor>(
          model.bias_random_walk, std::max(1e-3, toSeconds(j->t_ns - i->t_ns)));
      w.blocks = {i->b_g, j->b_g};
      w.kf_id = j->id;
      out.push_back(std::move(w));
    }
  }
  if (tiedRotations(model)) {
    for (Keyframe* kf : keyframes) {
      FactorSpec t;
      t.kind = FactorKind::kRotationTie;
      t.cost = std::make_unique<factors::RotationTieFactor>(model.vision_rotation_sigma_rad);
      t.blocks = {kf->q_W_B, kf->q_W_G};
      t.kf_id = kf->id;
      out.push_back(std::move(t));
    }
  }
  if (model.use_gyro) {
    for (Keyframe* kf : keyframes) {
      if (!kf->zero_rate) continue;
      FactorSpec z;
      z.kind = FactorKind::kBiasPrior;
      z.cost =
          std::make_unique<BiasPriorFactor>(kf->zero_rate->bias_radps, kf->zero_rate->sigma_radps);
      z.blocks = {kf->b_g};
      z.kf_id = kf->id;
      out.push_back(std::move(z));
    }
  }

  // Gauge.
  if (auto it = kf_of.find(gauge.kf_id); it != kf_of.end()) {
    Keyframe* kf = it->second;
    FactorSpec p;
    p.kind = FactorKind::kPosePrior;
    p.cost = std::make_unique<factors::PosePriorFactor>(
        gauge.T_W_B, factors::PosePriorFactor::gaugeInformation(model.gauge_sigma_position_m,
                                                                model.gauge_sigma_rotation_rad,
                                                                model.gauge_sigma_rotation_rad));
    p.blocks = {kf->q_W_B, kf->p_W_B};
    p.kf_id = kf->id;
    out.push_back(std::move(p));
    if (model.use_gyro) {
      FactorSpec b;
      b.kind = FactorKind::kBiasPrior;
      b.cost = std::make_unique<BiasPriorFactor>(gauge.b_g, gauge.b_g_sigma_radps > 0.0
                                                                ? gauge.b_g_sigma_radps
                                                                : model.bias_prior_sigma_radps);
      b.blocks = {kf->b_g};
      b.kf_id = kf->id;
      out.push_back(std::move(b));
    }
  }
  if (gauge.marginalization) {
    FactorSpec m;
    m.kind = FactorKind::kMarginal;
    m.cost = std::make_unique<factors::MarginalizationFactor>(gauge.marginalization);
    m.blocks = gauge.marginalization->keptBlocks();
    out.push_back(std::move(m));
  }
  return out;
}

SolveSummary solveFactors(std::vector<FactorSpec> factors, const std::vector<Keyframe*>& keyframes,
                          std::unordered_map<TrackId, Landmark>& landmarks,
                          const WindowModel& model, const SolveOptions& options) {
  SolveSummary summary;
  if (factors.empty()) return summary;

  // Backup for a diverged solve.
  struct KfBackup {
    double q[4], g[4], p[3], b[3], terrain[3];
  };
  std::vector<KfBackup> kf_backup(keyframes.size());
  for (std::size_t k = 0; k < keyframes.size(); ++k) {
    std::copy_n(keyframes[k]->q_W_B, 4, kf_backup[k].q);
    std::copy_n(keyframes[k]->q_W_G, 4, kf_backup[k].g);
    std::copy_n(keyframes[k]->p_W_B, 3, kf_backup[k].p);
    std::copy_n(keyframes[k]->b_g, 3, kf_backup[k].b);
    std::copy_n(keyframes[k]->terrain, 3, kf_backup[k].terrain);
  }
  std::unordered_map<TrackId, double> rho_backup;
  for (const auto& [id, lm] : landmarks) rho_backup[id] = lm.rho[0];

  ceres::Problem problem;
  for (Keyframe* kf : keyframes) {
    problem.AddParameterBlock(kf->q_W_B, 4, factors::newQuaternionManifold());
    if (tiedRotations(model))
      problem.AddParameterBlock(kf->q_W_G, 4, factors::newQuaternionManifold());
  }
  for (FactorSpec& f : factors) {
    problem.AddResidualBlock(f.cost.release(), f.loss.release(), f.blocks);
    ++summary.residual_blocks;
  }
  // Keyframes without any factor (e.g. no landmark yet) must not be left floating.
  for (Keyframe* kf : keyframes) {
    std::vector<ceres::ResidualBlockId> ids;
    problem.GetResidualBlocksForParameterBlock(kf->q_W_B, &ids);
    if (ids.empty()) problem.RemoveParameterBlock(kf->q_W_B);
    if (!problem.HasParameterBlock(kf->q_W_G)) continue;
    problem.GetResidualBlocksForParameterBlock(kf->q_W_G, &ids);
    if (ids.empty()) problem.RemoveParameterBlock(kf->q_W_G);
  }
  for (auto& [id, lm] : landmarks) {
    if (!problem.HasParameterBlock(lm.rho)) continue;
    problem.SetParameterLowerBound(lm.rho, 0, model.min_rho);
    problem.SetParameterUpperBound(lm.rho, 0, model.max_rho);
    lm.rho[0] = std::clamp(lm.rho[0], model.min_rho, model.max_rho);
  }

  ceres::Solver::Options so;
  so.linear_solver_type =
      options.linear_solver == "sparse_schur" ? ceres::SPARSE_SCHUR : ceres::DENSE_SCHUR;
  so.max_num_iterations = options.max_iterations;
  if (options.max_time_s > 0.0) so.max_solver_time_in_seconds = options.max_time_s;
  so.num_threads = options.num_threads;
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary s;
  ceres::Solve(so, &problem, &s);

  summary.iterations = static_cast<int>(s.iterations.size());
  summary.initial_cost = s.initial_cost;
  summary.final_cost = s.final_cost;
  summary.message = s.message;
  bool finite = s.termination_type != ceres::FAILURE;
  for (const Keyframe* kf : keyframes)
    finite = finite &&
             std::isfinite(kf->q_W_B[0] + kf->q_W_B[1] + kf->q_W_B[2] + kf->q_W_B[3] +
                           kf->p_W_B[0] + kf->p_W_B[1] + kf->p_W_B[2] + kf->b_g[0] + kf->b_g[1] +
                           kf->b_g[2] + kf->terrain[0] + kf->terrain[1] + kf->terrain[2] +
                           kf->q_W_G[0] + kf->q_W_G[1] + kf->q_W_G[2] + kf->q_W_G[3]);
  for (const auto& [id, lm] : landmarks) finite = finite && std::isfinite(lm.rho[0]);
  if (!finite) {
    for (std::size_t k = 0; k < keyframes.size(); ++k) {
      std::copy_n(kf_backup[k].q, 4, keyframes[k]->q_W_B);
      std::copy_n(kf_backup[k].g, 4, keyframes[k]->q_W_G);
      std::copy_n(kf_backup[k].p, 3, keyframes[k]->p_W_B);
      std::copy_n(kf_backup[k].b, 3, keyframes[k]->b_g);
      std::copy_n(kf_backup[k].terrain, 3, keyframes[k]->terrain);
    }
    for (auto& [id, lm] : landmarks) lm.rho[0] = rho_backup[id];
    return summary;
  }
  for (Keyframe* kf : keyframes) {  // keep the quaternions exactly unit
    factors::quatToBlock(factors::quatFromBlock(kf->q_W_B), kf->q_W_B);
    if (tiedRotations(model))
      factors::quatToBlock(factors::quatFromBlock(kf->q_W_G), kf->q_W_G);
    else  // one orientation for both
      std::copy_n(kf->q_W_B, 4, kf->q_W_G);
  }
  summary.usable = true;
  return summary;
}

double lidarSigma(const LidarAssociation& a, const WindowModel& model) {
  if (a.ground_up_L.isZero()) return model.lidar_sigma_m;
  return std::hypot(model.lidar_range_sigma_m * a.ground_sin, model.lidar_ground_sigma_m);
}

bool lidarOutlier(const LidarAssociation& a, const Vec3& p_W, const Keyframe& kf,
                  const WindowModel& model, double gate_sigmas, double gate_fraction) {
  const SE3 T_L_W = (kf.pose() * kf.T_B_L).inverse();
  const auto value = factors::lidarMeasuredValue(T_L_W * p_W, a.planar, a.ground_up_L);
  if (!value) return true;  // the landmark sits on the LiDAR
  const double gate_sigma = gate_sigmas * lidarSigma(a, model);
  const double gate =
      a.ground_up_L.isZero() ? std::max(gate_sigma, gate_fraction * a.range_m) : gate_sigma;
  return std::abs(*value - a.range_m) > gate;
}

void repropagateGyro(const std::vector<Keyframe*>& keyframes) {
  for (std::size_t k = 1; k < keyframes.size(); ++k) {
    auto& pi = keyframes[k]->preint_from_prev;
    if (pi && pi->needsRepropagation(keyframes[k - 1]->bias(), 0.002))
      pi->repropagate(keyframes[k - 1]->bias());
  }
}

std::vector<ObservationError> observationErrors(const std::vector<Keyframe*>& keyframes,
                                                const std::unordered_map<TrackId, Landmark>& lms,
                                                const WindowModel& model) {
  std::vector<ObservationError> out;
  const auto kf_of = byId(keyframes);
  const SE3 T_C_B = model.T_B_C.inverse();
  for (const auto& [id, lm] : lms) {
    auto a = kf_of.find(lm.anchor_kf);
    if (a == kf_of.end() || !(lm.rho[0] > 0.0)) continue;
    const Vec3 p_W = a->second->pose() * (model.T_B_C * (lm.bearing_anchor_C / lm.rho[0]));
    for (const Keyframe* kf : keyframes) {
      if (kf == a->second) continue;
      auto obs = kf->observations.find(id);
      if (obs == kf->observations.end()) continue;
      const Vec3 p_C = T_C_B * (kf->pose().inverse() * p_W);
      const double n = p_C.norm();
      const double c = n > 0.0 ? std::clamp(p_C.dot(obs->second.bearing_C) / n, -1.0, 1.0) : -1.0;
      out.push_back({kf->id, id, std::acos(c)});
    }
  }
  return out;
}

std::shared_ptr<const factors::MarginalizationInfo> marginalizeOldest(
    WindowMap& map, const WindowModel& model, const WindowGauge& gauge,
    const std::unordered_map<TrackId, int>& marginalize_tracks) {
  if (map.keyframes.size() < 2) return nullptr;
  Keyframe* oldest = map.keyframes.front().get();
  std::vector<Keyframe*> kfs;
  for (auto& kf : map.keyframes) kfs.push_back(kf.get());

  std::vector<FactorSpec> all = buildFactors(kfs, map.landmarks, model, gauge);
  auto info = std::make_shared<factors::MarginalizationInfo>();
  for (Keyframe* kf : kfs) {
    info->setQuaternionBlock(kf->q_W_B);
    if (tiedRotations(model)) info->setQuaternionBlock(kf->q_W_G);
  }

  std::unordered_set<const double*> drop = {oldest->q_W_B, oldest->q_W_G, oldest->p_W_B,
                                            oldest->b_g, oldest->terrain};
  for (auto& [id, lm] : map.landmarks)
    if (lm.anchor_kf == oldest->id && marginalize_tracks.count(id)) drop.insert(lm.rho);

  int added = 0;
  for (const FactorSpec& f : all) {
    bool touches = false;
    for (const double* b : f.blocks) touches = touches || drop.count(b) > 0;
    if (!touches) continue;
    if (f.track >= 0) {
      const auto it = map.landmarks.find(f.track);
      const bool anchored_here = it != map.landmarks.end() && it->second.anchor_kf == oldest->id;
      // Only the selected landmarks anchored here; a factor of a landmark anchored elsewhere
      // would put its rho into the prior, so it is dropped as well.
      const auto sel = marginalize_tracks.find(f.track);
      if (!anchored_here || sel == marginalize_tracks.end()) continue;
      if (sel->second >= 0 && f.kf_id != oldest->id && f.kf_id != sel->second) continue;
    }
    std::vector<int> drop_idx;
    for (std::size_t k = 0; k < f.blocks.size(); ++k)
      if (drop.count(f.blocks[k])) drop_idx.push_back(static_cast<int>(k));
    if (info->addResidualBlock(f.cost.get(), f.loss.get(), f.blocks, drop_idx)) ++added;
  }
  if (added == 0 || !info->marginalize()) return nullptr;
  return info;
}

std::optional<PoseRefinement> refinePose(const std::vector<Vec3>& points_W,
                                         const std::vector<Vec3>& bearings_C, const SE3& T_W_B_init,
                                         const std::optional<Mat3>& R_W_B_prior,
                                         double prior_sigma_rad, const WindowModel& model,
                                         int max_iterations, double outlier_rad) {
  const std::size_t n = points_W.size();
  if (n < 3 || bearings_C.size() != n) return std::nullopt;
  // Each point as an anchor at the world origin with identity rotation: b_a = p_W - t_B_C
  // direction is awkward; instead anchor it in a virtual body frame at p_W - R t_B_C.
  struct Anchor {
    double q[4] = {0, 0, 0, 1};
    double p[3] = {0, 0, 0};
    double rho[1] = {1.0};
    Vec3 bearing = Vec3::UnitZ();
  };
  std::vector<Anchor> anchors(n);
  const Mat3 R_B_C = model.T_B_C.linear();
  const Vec3 t_B_C = model.T_B_C.translation();
  for (std::size_t i = 0; i < n; ++i) {
    // Virtual anchor body with R_W_Ba = R_C_B (so that R_W_Ba R_B_C = I): its camera sits at
    // p_W_Ba + R_W_Ba t_B_C; put that camera at the origin and the point at distance 1/rho.
    const Mat3 R_W_Ba = R_B_C.transpose();
    Vec3 d = points_W[i];
    const double dist = d.norm();
    if (!(dist > 1e-6)) return std::nullopt;
    factors::quatToBlock(Quat(R_W_Ba), anchors[i].q);
    const Vec3 p_W_Ba = -R_W_Ba * t_B_C;
    for (int k = 0; k < 3; ++k) anchors[i].p[k] = p_W_Ba[k];
    anchors[i].bearing = d / dist;
    anchors[i].rho[0] = 1.0 / dist;
  }
  double q[4], p[3];
  factors::quatToBlock(Quat(T_W_B_init.linear()).normalized(), q);
  for (int k = 0; k < 3; ++k) p[k] = T_W_B_init.translation()[k];

  ceres::Problem problem;
  problem.AddParameterBlock(q, 4, factors::newQuaternionManifold());
  problem.AddParameterBlock(p, 3);
  for (std::size_t i = 0; i < n; ++i) {
    auto* cost = new factors::BearingFactor(anchors[i].bearing, bearings_C[i], model.T_B_C,
                                            model.bearing_sigma_rad);
    problem.AddResidualBlock(cost, new ceres::HuberLoss(model.bearing_huber),
                             {anchors[i].q, anchors[i].p, q, p, anchors[i].rho});
    problem.SetParameterBlockConstant(anchors[i].q);
    problem.SetParameterBlockConstant(anchors[i].p);
    problem.SetParameterBlockConstant(anchors[i].rho);
  }
  if (R_W_B_prior) {
    factors::Mat6 info = factors::Mat6::Zero();
    info.topLeftCorner<3, 3>() = Mat3::Identity() / (prior_sigma_rad * prior_sigma_rad);
    SE3 T0 = SE3::Identity();
    T0.linear() = *R_W_B_prior;
    problem.AddResidualBlock(new factors::PosePriorFactor(T0, info), nullptr, q, p);
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = max_iterations;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary s;
  ceres::Solve(so, &problem, &s);
  if (s.termination_type == ceres::FAILURE) return std::nullopt;

  PoseRefinement out;
  out.T_W_B = SE3::Identity();
  out.T_W_B.linear() = factors::quatFromBlock(q).toRotationMatrix();
  out.T_W_B.translation() = Vec3(p[0], p[1], p[2]);
  if (!allFinite(out.T_W_B)) return std::nullopt;
  const SE3 T_C_W = (out.T_W_B * model.T_B_C).inverse();
  out.inlier.resize(n, 0);
  const double cos_max = std::cos(outlier_rad);
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 p_C = T_C_W * points_W[i];
    const double norm = p_C.norm();
    if (norm > 0.0 && p_C.dot(bearings_C[i]) / norm > cos_max) {
      out.inlier[i] = 1;
      ++out.num_inliers;
    }
  }
  return out;
}

}  // namespace ovo::estimator
