// Building the window's residual blocks, kind by kind, from its keyframes and landmarks.
#include "estimator/window/factors.hpp"

#include <ceres/loss_function.h>

#include <algorithm>
#include <cmath>

#include "common/so3.hpp"
#include "estimator/window/lidar_gate.hpp"
#include "estimator/window/sighting.hpp"
#include "estimator/window/terrain.hpp"
#include "factors/accel_factor.hpp"
#include "factors/bearing_factor.hpp"
#include "factors/bearing_step_factor.hpp"
#include "factors/bias_prior_factor.hpp"
#include "factors/ground_height_factor.hpp"
#include "factors/lidar_range_factor.hpp"
#include "factors/pose_prior_factor.hpp"
#include "factors/rotation_tie_factor.hpp"
#include "factors/scalar_prior_factor.hpp"
#include "factors/terrain_plane_factor.hpp"
#include "factors/time_offset_factor.hpp"

namespace ovo::estimator {
namespace {

// The inverse depth a landmark needs for the factors that measure its distance (ground height,
// terrain plane, LiDAR range), 1/m: a point further than 1000 km is at infinity for them, and
// its distance (1 / rho) would make them fail at the solve's start.
constexpr double kMinRangedRho = 1e-6;

/// The orientation block a keyframe's gyro factors use.
double* gyroRotation(Keyframe& kf, const WindowModel& model) {
  return tiedRotations(model) ? kf.q_W_G : kf.q_W_B;
}

using Keyframes = std::vector<Keyframe*>;
using Landmarks = std::unordered_map<TrackId, Landmark>;
using KeyframesById = std::unordered_map<int, Keyframe*>;

// Whether the marginalisation prior holds a block (a state of a keyframe that left the window
// acts on it through the prior).
bool inPrior(const WindowGauge& gauge, const double* block) {
  if (!gauge.marginalization) return false;
  const auto& kept = gauge.marginalization->keptBlocks();
  return std::find(kept.begin(), kept.end(), block) != kept.end();
}

// Whether a landmark's factors are left out: when `seen_by` is given, only those of the landmarks
// it sees or anchors are built.
bool leftOut(const Keyframe* seen_by, TrackId id, const Landmark& lm) {
  return seen_by != nullptr && lm.anchor_kf != seen_by->id && !seen_by->observations.count(id);
}

// Each landmark's sightings against its anchor (or, with bearing steps, against the previous one).
void addBearingFactors(const Keyframes& keyframes, const KeyframesById& kf_of, Landmarks& landmarks,
                       const WindowModel& model, const Keyframe* seen_by,
                       std::vector<FactorSpec>& out) {
  for (auto& [id, lm] : landmarks) {
    if (leftOut(seen_by, id, lm)) continue;
    auto anchor_it = kf_of.find(lm.anchor_kf);
    // (a point at infinity, rho 0, still gives its bearings: they hold the rotations)
    if (anchor_it == kf_of.end() || !(lm.rho[0] >= 0.0)) continue;
    Keyframe* anchor = anchor_it->second;
    // The anchor's camera pose in its body when it took the landmark's first sighting (a rolling
    // shutter's row).
    const SE3 T_B_Ca = anchorExtrinsics(*anchor, lm, model);
    // With bearing steps each sighting after the first is tied to the previous kept one.
    Keyframe* prev = nullptr;
    for (Keyframe* kf : keyframes) {
      if (kf == anchor) continue;
      auto obs = kf->observations.find(id);
      if (obs == kf->observations.end()) continue;
      const SE3 T_B_Cj = sightingExtrinsics(*kf, obs->second, model);
      const auto u = factors::predictBearing(lm.bearing_anchor_C, T_B_Ca, T_B_Cj, anchor->q_W_B,
                                             anchor->p_W_B, kf->q_W_B, kf->p_W_B, lm.rho[0], false);
      if (!u || u->u.dot(obs->second.bearing_C) < std::cos(0.2)) continue;  // gross: > 11 deg
      FactorSpec f;
      f.kind = FactorKind::kBearing;
      if (model.bearing_steps && prev != nullptr) {
        const TrackObservation& oi = prev->observations.at(id);
        const double frames = std::max(0, obs->second.age - oi.age);
        // The step's two sightings each carry their own noise.
        const double sigma_px =
            sightingSigmaPx(2.0 * model.track_white_px * model.track_white_px, frames, model);
        f.cost = std::make_unique<factors::BearingStepFactor>(
            lm.bearing_anchor_C, oi.bearing_C, obs->second.bearing_C, T_B_Ca,
            sightingExtrinsics(*prev, oi, model), T_B_Cj,
            sightingSqrtInformation(obs->second, sigma_px, model));
        f.blocks = {anchor->q_W_B, anchor->p_W_B, prev->q_W_B, prev->p_W_B,
                    kf->q_W_B,     kf->p_W_B,     lm.rho};
      } else {
        // Tracks creep (a random walk of the sub-pixel position per frame): the error between the
        // anchor's and this observation grows with the frames between them.
        const double sigma_px = anchorSigmaPx(*anchor, obs->second, model);
        f.cost = std::make_unique<factors::BearingFactor>(
            lm.bearing_anchor_C, obs->second.bearing_C, T_B_Ca, T_B_Cj,
            sightingSqrtInformation(obs->second, sigma_px, model));
        f.blocks = {anchor->q_W_B, anchor->p_W_B, kf->q_W_B, kf->p_W_B, lm.rho};
      }
      f.loss = std::make_unique<ceres::HuberLoss>(model.bearing_huber);
      f.track = id;
      f.kf_id = kf->id;
      out.push_back(std::move(f));
      prev = kf;
    }
  }
}

// Ground landmarks on their anchor's terrain plane, and the planes' walk between keyframes.
void addTerrainFactors(const Keyframes& keyframes, const KeyframesById& kf_of, Landmarks& landmarks,
                       const WindowModel& model, const Keyframe* seen_by,
                       std::vector<FactorSpec>& out) {
  if (!usesTerrain(model)) return;
  for (auto& [id, lm] : landmarks) {
    if (leftOut(seen_by, id, lm)) continue;
    auto a = kf_of.find(lm.anchor_kf);
    if (!lm.on_ground || a == kf_of.end() || !a->second->terrain_set ||
        !(lm.rho[0] > kMinRangedRho))
      continue;
    FactorSpec f;
    f.kind = FactorKind::kTerrain;
    f.cost = std::make_unique<factors::TerrainPointFactor>(
        lm.bearing_anchor_C, anchorExtrinsics(*a->second, lm, model), model.ground_sigma_m);
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

// Ground landmarks' depth below their anchor camera (the camera height, corrected by the
// camera_height_offset_m state when given, or by the anchor keyframe's correction along the
// path); true when a factor uses the camera_height_offset_m state.
bool addGroundFactors(const KeyframesById& kf_of, Landmarks& landmarks, const WindowModel& model,
                      double* camera_height_offset_m, const Keyframe* seen_by,
                      std::vector<FactorSpec>& out) {
  const bool path = followsCameraHeight(model);
  bool height_used = false;
  if (model.camera_height_m > 0.0) {
    for (auto& [id, lm] : landmarks) {
      const auto anchor = kf_of.find(lm.anchor_kf);
      if (!lm.on_ground || anchor == kf_of.end() || !(lm.rho[0] > kMinRangedRho) ||
          leftOut(seen_by, id, lm))
        continue;
      double* offset = path ? anchor->second->height_offset_m : camera_height_offset_m;
      FactorSpec f;
      f.kind = FactorKind::kGround;
      if (offset != nullptr) {
        f.cost = std::make_unique<factors::GroundHeightCorrectedFactor>(
            lm.bearing_anchor_C, lm.ground_up_C, model.camera_height_m, model.ground_sigma_m);
        f.blocks = {lm.rho, offset};
        height_used = !path;
      } else {
        f.cost = std::make_unique<factors::GroundHeightFactor>(
            lm.bearing_anchor_C, lm.ground_up_C, model.camera_height_m, model.ground_sigma_m);
        f.blocks = {lm.rho};
      }
      f.loss = std::make_unique<ceres::HuberLoss>(model.ground_huber);
      f.track = id;
      f.kf_id = lm.anchor_kf;
      out.push_back(std::move(f));
    }
  }
  return height_used;
}

// The camera height's correction along the path: its walk between the keyframes of a segment,
// and its prior about the rig's height on a segment's first keyframe unless the marginalisation
// prior already holds that keyframe's correction.
void addCameraHeightPathFactors(const Keyframes& keyframes, const WindowModel& model,
                                const WindowGauge& gauge, std::vector<FactorSpec>& out) {
  if (!followsCameraHeight(model)) return;
  for (std::size_t k = 0; k < keyframes.size(); ++k) {
    Keyframe* j = keyframes[k];
    Keyframe* i = k > 0 && keyframes[k - 1]->segment == j->segment ? keyframes[k - 1] : nullptr;
    FactorSpec f;
    f.kf_id = j->id;
    if (i != nullptr) {
      f.kind = FactorKind::kCameraHeightWalk;
      f.cost = std::make_unique<factors::CameraHeightWalkFactor>(
          (j->pose().translation() - i->pose().translation()).norm(),
          model.camera_height_path_sigma_m, model.camera_height_path_length_m);
      f.blocks = {i->height_offset_m, j->height_offset_m};
    } else if (!inPrior(gauge, j->height_offset_m)) {
      f.kind = FactorKind::kCameraHeightPrior;
      f.cost = std::make_unique<factors::ScalarPriorFactor>(0.0, model.camera_height_path_sigma_m);
      f.blocks = {j->height_offset_m};
    } else {
      continue;
    }
    out.push_back(std::move(f));
  }
}

// Every keyframe's LiDAR ranges to the landmarks it measured.
void addLidarFactors(const Keyframes& keyframes, const KeyframesById& kf_of, Landmarks& landmarks,
                     const WindowModel& model, const Keyframe* seen_by,
                     std::vector<FactorSpec>& out) {
  for (Keyframe* kf : keyframes) {
    for (const LidarAssociation& a : kf->lidar) {
      auto lm_it = landmarks.find(a.track_id);
      if (lm_it == landmarks.end()) continue;
      Landmark& lm = lm_it->second;
      auto anchor_it = kf_of.find(lm.anchor_kf);
      if (anchor_it == kf_of.end() || !(lm.rho[0] > kMinRangedRho) ||
          leftOut(seen_by, a.track_id, lm))
        continue;
      FactorSpec f;
      f.kind = FactorKind::kLidar;
      if (model.lidar_cauchy)
        f.loss = std::make_unique<ceres::CauchyLoss>(model.lidar_huber);
      else
        f.loss = std::make_unique<ceres::HuberLoss>(model.lidar_huber);
      const double sigma = lidarSigma(a, model);
      Keyframe* anchor = anchor_it->second;
      const SE3 T_B_Ca = anchorExtrinsics(*anchor, lm, model);
      if (anchor == kf) {
        f.cost = std::make_unique<factors::LidarRangeAnchorFactor>(
            lm.bearing_anchor_C, a.range_m, T_B_Ca, kf->T_B_L, sigma, a.planar, a.ground_up_L);
        f.blocks = {lm.rho};
      } else {
        f.cost = std::make_unique<factors::LidarRangeFactor>(
            lm.bearing_anchor_C, a.range_m, T_B_Ca, kf->T_B_L, sigma, a.planar, a.ground_up_L);
        f.blocks = {anchor->q_W_B, anchor->p_W_B, kf->q_W_B, kf->p_W_B, lm.rho};
      }
      f.track = a.track_id;
      f.kf_id = kf->id;
      out.push_back(std::move(f));
    }
  }
}

// Gyro and bias factors between consecutive keyframes of one segment (with the time offset as a
// state when time_offset_s is given); true when a factor uses that state.
bool addGyroFactors(const Keyframes& keyframes, const WindowModel& model, double* time_offset_s,
                    std::vector<FactorSpec>& out) {
  const bool with_offset = time_offset_s != nullptr;
  bool offset_used = false;
  if (model.use_gyro) {
    for (std::size_t k = 1; k < keyframes.size(); ++k) {
      Keyframe* i = keyframes[k - 1];
      Keyframe* j = keyframes[k];
      if (i->segment != j->segment || !j->preint_from_prev) continue;
      FactorSpec g;
      g.kind = FactorKind::kGyro;
      g.blocks = {gyroRotation(*i, model), gyroRotation(*j, model), i->b_g};
      if (with_offset) {
        // The offset the preintegration was made at: its interval starts at t_i - offset.
        const double td_lin = toSeconds(i->t_ns - j->preint_from_prev->tStart());
        g.cost = std::make_unique<factors::GyroTimeOffsetFactor>(j->preint_from_prev, td_lin);
        g.blocks.push_back(time_offset_s);
        offset_used = true;
      } else {
        g.cost = std::make_unique<factors::GyroFactor>(j->preint_from_prev);
      }
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
  return offset_used;
}

// The accelerometer between each three consecutive keyframes of one segment, on the middle one's
// orientation (the gyro chain's), the three positions and the run's gravity state; true when a
// factor uses that state.
bool addAccelFactors(const Keyframes& keyframes, const WindowModel& model, double* gravity,
                     std::vector<FactorSpec>& out) {
  if (gravity == nullptr || !usesAccel(model)) return false;
  bool used = false;
  for (std::size_t k = 1; k + 1 < keyframes.size(); ++k) {
    Keyframe* i = keyframes[k - 1];
    Keyframe* j = keyframes[k];
    Keyframe* l = keyframes[k + 1];
    if (i->segment != j->segment || j->segment != l->segment || !j->accel_from_prev ||
        !l->accel_from_prev)
      continue;
    FactorSpec a;
    a.kind = FactorKind::kAccel;
    a.cost = std::make_unique<factors::AccelerationFactor>(
        *j->accel_from_prev, *l->accel_from_prev, model.gravity_mps2, model.accel_sigma_mps2,
        model.accel_position_sigma_m);
    a.blocks = {gyroRotation(*j, model), i->p_W_B, j->p_W_B, l->p_W_B, gravity};
    a.kf_id = j->id;
    out.push_back(std::move(a));
    used = true;
  }
  return used;
}

// Each keyframe's vision orientation tied to its gyro chain's.
void addRotationTieFactors(const Keyframes& keyframes, const WindowModel& model,
                           std::vector<FactorSpec>& out) {
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
}

// The standstills' zero-rate updates on the keyframes' biases.
void addZeroRateFactors(const Keyframes& keyframes, const WindowModel& model,
                        std::vector<FactorSpec>& out) {
  if (model.use_gyro) {
    for (Keyframe* kf : keyframes) {
      if (!kf->zero_rate) continue;
      FactorSpec z;
      z.kind = FactorKind::kZeroRate;
      z.cost = std::make_unique<factors::BiasPriorFactor>(kf->zero_rate->bias_radps,
                                                          kf->zero_rate->sigma_radps);
      z.blocks = {kf->b_g};
      z.kf_id = kf->id;
      out.push_back(std::move(z));
    }
  }
}

// The gauge keyframe's pose prior and bias prior.
void addGaugeFactors(const KeyframesById& kf_of, const WindowModel& model, const WindowGauge& gauge,
                     std::vector<FactorSpec>& out) {
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
      b.cost = std::make_unique<factors::BiasPriorFactor>(
          gauge.b_g,
          gauge.b_g_sigma_radps > 0.0 ? gauge.b_g_sigma_radps : model.bias_prior_sigma_radps);
      b.blocks = {kf->b_g};
      b.kf_id = kf->id;
      out.push_back(std::move(b));
    }
  }
}

}  // namespace

std::vector<FactorSpec> buildFactors(const std::vector<Keyframe*>& keyframes,
                                     std::unordered_map<TrackId, Landmark>& landmarks,
                                     const WindowModel& model, const WindowGauge& gauge,
                                     const FactorLedger* ledger, double* time_offset_s,
                                     double* camera_height_offset_m, double* gravity,
                                     const Keyframe* seen_by) {
  std::vector<FactorSpec> out;
  const auto kf_of = keyframesById(keyframes);
  addBearingFactors(keyframes, kf_of, landmarks, model, seen_by, out);
  addTerrainFactors(keyframes, kf_of, landmarks, model, seen_by, out);
  const bool with_height = camera_height_offset_m != nullptr && estimatesCameraHeight(model);
  const bool height_used = addGroundFactors(
      kf_of, landmarks, model, with_height ? camera_height_offset_m : nullptr, seen_by, out);
  addCameraHeightPathFactors(keyframes, model, gauge, out);
  addLidarFactors(keyframes, kf_of, landmarks, model, seen_by, out);
  const bool with_offset = time_offset_s != nullptr && estimatesTimeOffset(model);
  const bool offset_used =
      addGyroFactors(keyframes, model, with_offset ? time_offset_s : nullptr, out);
  const bool gravity_used = addAccelFactors(keyframes, model, gravity, out);
  addRotationTieFactors(keyframes, model, out);
  addZeroRateFactors(keyframes, model, out);
  addGaugeFactors(kf_of, model, gauge, out);
  // The run's scalar states, each about the rig's value, in every solve that holds the state (a
  // factor of it, or the marginalisation prior): a plausibility bound that holds the time offset
  // while the motion does not show it (a constant rate), and the camera height while the LiDAR
  // sees little. They touch no keyframe: never marginalised.
  const auto held = [&](double* block, bool used) { return used || inPrior(gauge, block); };
  const auto scalarPrior = [&](double* block, bool used, FactorKind kind, double sigma) {
    if (!held(block, used)) return;
    FactorSpec p;
    p.kind = kind;
    p.cost = std::make_unique<factors::ScalarPriorFactor>(0.0, sigma);
    p.blocks = {block};
    out.push_back(std::move(p));
  };
  if (gravity != nullptr && usesAccel(model) && held(gravity, gravity_used)) {
    FactorSpec p;  // the accelerometer's bias about zero (gravity's direction is free)
    p.kind = FactorKind::kAccelBiasPrior;
    p.cost = std::make_unique<factors::AccelBiasPriorFactor>(model.accel_bias_sigma_mps2);
    p.blocks = {gravity};
    out.push_back(std::move(p));
  }
  if (with_offset)
    scalarPrior(time_offset_s, offset_used, FactorKind::kTimeOffsetPrior,
                model.time_offset_sigma_s);
  if (with_height)
    scalarPrior(camera_height_offset_m, height_used, FactorKind::kCameraHeightPrior,
                model.camera_height_offset_sigma_m);
  if (gauge.marginalization) {
    FactorSpec m;
    m.kind = FactorKind::kMarginal;
    m.cost = std::make_unique<factors::MarginalizationFactor>(gauge.marginalization);
    m.blocks = gauge.marginalization->keptBlocks();
    out.push_back(std::move(m));
  }
  if (ledger != nullptr && ledger->size() > 0)
    std::erase_if(out, [&](const FactorSpec& f) {
      return f.kind != FactorKind::kMarginal && ledger->fate(f.key()).has_value();
    });
  return out;
}

}  // namespace ovo::estimator
