// The window's factor graph as residual blocks: what holds the gauge, and every factor over a set
// of keyframes and landmarks (bearing or bearing step, gyro, bias random walk and priors, LiDAR
// range, camera height, terrain plane, gauge, marginalisation prior).
#pragma once

#include <ceres/cost_function.h>
#include <ceres/loss_function.h>

#include <map>
#include <memory>
#include <optional>
#include <unordered_map>
#include <vector>

#include "estimator/estimator.hpp"
#include "estimator/window/ledger.hpp"
#include "estimator/window/map.hpp"
#include "estimator/window/model.hpp"
#include "estimator/window/options.hpp"
#include "factors/marginalization.hpp"

namespace ovo::estimator {

/// What fixes the gauge of the window: a pose prior on one keyframe (before the first
/// marginalisation) or the marginalisation prior (after), plus a bias prior.
struct WindowGauge {
  int kf_id = -1;                 // keyframe with the pose and bias prior (-1: none)
  SE3 T_W_B = SE3::Identity();    // its prior pose
  Vec3 b_g = Vec3::Zero();        // its prior bias
  double b_g_sigma_radps = -1.0;  // sigma of that bias prior, rad/s (<= 0: the model's)
  std::shared_ptr<const factors::MarginalizationInfo> marginalization;
};

/// One residual block before it goes into a Problem or a MarginalizationInfo.
struct FactorSpec {
  FactorKind kind = FactorKind::kBearing;
  std::unique_ptr<ceres::CostFunction> cost;
  std::unique_ptr<ceres::LossFunction> loss;
  std::vector<double*> blocks;
  TrackId track = -1;  // bearing / LiDAR: the landmark
  int kf_id = -1;      // bearing: observing keyframe; LiDAR: scan keyframe; gyro: later keyframe
  FactorKey key() const { return {kind, track, kf_id}; }
};

/// All factors over `keyframes` (time order) and `landmarks`. Landmarks whose anchor is not among
/// the keyframes, or with fewer than one usable non-anchor observation, get no factor; nor do
/// keyframes whose terrain plane is not seeded, nor measurements the ledger holds. With a
/// time_offset_s block (WindowMap::time_offset_s) and estimatesTimeOffset(model), the gyro
/// factors take it as a state and it gets its prior; likewise the camera-height factors with a
/// camera_height_offset_m block (WindowMap::camera_height_offset_m) and
/// estimatesCameraHeight(model); and the accelerometer's factors with a gravity block
/// (WindowMap::gravity) and usesAccel(model). With `seen_by`, the landmarks' factors (bearing,
/// terrain point, ground, LiDAR) are built only for the landmarks it observes or anchors (the
/// marginalisation wants those touching its keyframe; the camera height's prior then counts
/// only their ground factors as its use).
std::vector<FactorSpec> buildFactors(const std::vector<Keyframe*>& keyframes,
                                     std::unordered_map<TrackId, Landmark>& landmarks,
                                     const WindowModel& model, const WindowGauge& gauge,
                                     const FactorLedger* ledger = nullptr,
                                     double* time_offset_s = nullptr,
                                     double* camera_height_offset_m = nullptr,
                                     double* gravity = nullptr,
                                     const Keyframe* seen_by = nullptr);

}  // namespace ovo::estimator
