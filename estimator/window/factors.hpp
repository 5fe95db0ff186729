// The window's factor graph as residual blocks: the model constants, what holds the gauge, and
// every factor over a set of keyframes and landmarks (bearing or bearing step, gyro, bias random
// walk and priors, LiDAR range, camera height, terrain plane, gauge, marginalisation prior).
#pragma once

#include <ceres/cost_function.h>
#include <ceres/loss_function.h>

#include <map>
#include <memory>
#include <optional>
#include <unordered_map>
#include <vector>

#include "estimator/estimator.hpp"
#include "estimator/window/map.hpp"
#include "estimator/window/options.hpp"
#include "factors/marginalization.hpp"

namespace ovo::estimator {

/// Constants of the window's factors.
struct WindowModel {
  SE3 T_B_C = SE3::Identity();             // (the LiDAR's pose is each keyframe's: Keyframe::T_B_L)
  double focal_px = 305.0;                 // the camera's focal length at the centre, px
  double pixel_sigma_px = 0.5;             // a sighting's noise, px
  double bearing_sigma_rad = 0.5 / 305.0;  // the same at the centre, rad (per-frame tracking)
  // Sightings' noise in the image: whitened by the camera's pixels per radian at each bearing
  // (TrackObservation::px_per_rad), else by focal_px alone.
  bool bearing_sigma_from_camera = true;
  double bearing_huber = 2.0;   // Huber threshold on the whitened residual (sigmas)
  double track_creep_px = 0.0;  // track creep per sqrt(frame) between anchor and observation, px
  bool bearing_steps = false;   // sightings after a track's first: BearingStepFactor from the
  double track_white_px = 0.0;  // previous one, whose sighting noise (px, each end) it carries
  double lidar_sigma_m = 0.02;  // a range to a landmark (range and association noise), m
  double lidar_range_sigma_m = 0.02;    // the LiDAR's range noise alone, m
  double lidar_ground_sigma_m = 0.002;  // the ground's own departure from a ground beam's plane, m
  double lidar_huber = 2.0;             // robust loss threshold on the whitened residual (sigmas)
  bool lidar_cauchy = false;         // Cauchy (an association far off pulls ever less), else Huber
  double bias_random_walk = 2.0e-5;  // rad/s^2/sqrt(Hz)
  double vision_rotation_sigma_rad = 0.0;  // a keyframe's orientation error as the vision sees
                                           // it (RotationTieFactor; 0: no tie, one orientation)
  double bias_prior_sigma_radps = 0.02;
  double gauge_sigma_position_m = 1e-4;
  double gauge_sigma_rotation_rad = 1e-4;
  double min_rho = 0.0;        // 1/m: points at infinity are kept (they hold the rotations)
  double max_rho = 1.0 / 0.1;  // 1/m: nearer landmarks are removed
  bool use_gyro = true;
  // A rolling shutter: image row v of image_rows is read out at the frame's time + v / rows *
  // this (s; 0: a global shutter, the rig's T_B_C for every sighting).
  double rolling_shutter_s = 0.0;
  double image_rows = 480.0;
  // The camera-gyro time offset on top of the rig's (WindowMap::time_offset_s): estimated with
  // this prior sigma about 0 when > 0 and there is a gyro, else held at its value.
  double time_offset_sigma_s = 0.0;
  double camera_height_m = 0.0;  // ground landmarks' depth below the camera, m (<= 0: no factor)
  // A correction of camera_height_m (WindowMap::camera_height_offset_m): estimated with this
  // prior sigma about 0 when > 0 (with a LiDAR to see it), else none.
  double camera_height_offset_sigma_m = 0.0;
  double ground_sigma_m = 0.03;  // camera-height factor noise, m
  double ground_huber = 2.0;     // its Huber threshold, sigmas
  // Terrain planes (with a camera height): a ground landmark also lies on its anchor's terrain
  // plane (noise ground_sigma_m), which walks between keyframes by these per sqrt(m) driven.
  bool terrain_planes = false;
  double terrain_slope_walk = 0.002;   // slope (dz/dx, dz/dy) per sqrt(m)
  double terrain_height_walk = 0.002;  // m per sqrt(m)
};

/// What fixes the gauge of the window: a pose prior on one keyframe (before the first
/// marginalisation) or the marginalisation prior (after), plus a bias prior.
struct WindowGauge {
  int kf_id = -1;                 // keyframe with the pose and bias prior (-1: none)
  SE3 T_W_B = SE3::Identity();    // its prior pose
  Vec3 b_g = Vec3::Zero();        // its prior bias
  double b_g_sigma_radps = -1.0;  // sigma of that bias prior, rad/s (<= 0: the model's)
  std::shared_ptr<const factors::MarginalizationInfo> marginalization;
};

enum class FactorKind {
  kBearing,           // a sighting of a landmark (anchor-relative or a step from the previous one)
  kGyro,              // preintegrated gyro rotation from the previous keyframe
  kBiasWalk,          // gyro bias random walk from the previous keyframe
  kBiasPrior,         // the gauge keyframe's bias prior
  kZeroRate,          // a standstill's zero-rate update on a keyframe's bias
  kPosePrior,         // the gauge keyframe's pose prior
  kLidar,             // a LiDAR range (or ground-plane height) to a landmark
  kMarginal,          // the marginalisation prior
  kGround,            // a ground landmark's height below its anchor camera
  kTerrain,           // a ground landmark on its anchor's terrain plane (track) or the plane's walk
  kRotationTie,       // a keyframe's vision orientation tied to its gyro chain's
  kTimeOffsetPrior,   // the camera-gyro time offset's prior (stays in the window)
  kCameraHeightPrior  // the camera height correction's prior (stays in the window)
};

/// The measurement a factor stands for: its kind, its landmark (-1: none) and its keyframe (the
/// observing keyframe of a sighting or range, the anchor of a ground or terrain point, the later
/// keyframe of a gyro, bias walk or terrain walk factor). The marginalisation prior has none.
struct FactorKey {
  FactorKind kind = FactorKind::kBearing;
  TrackId track = -1;
  int kf_id = -1;
  auto operator<=>(const FactorKey&) const = default;
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

/// Where each measurement that left the window went: into the marginalisation prior, or dropped
/// (its landmark or keyframe gone without it). A measurement is in the window, in the prior or
/// dropped, never two of these: buildFactors skips what the ledger holds. Entries of keyframes
/// that have left the window are forgotten (no factor can be built for them again).
class FactorLedger {
 public:
  enum class Fate { kPrior, kDropped };
  /// Records a measurement's fate; false when it had one already (a measurement counted twice).
  bool record(const FactorKey& key, Fate fate);
  std::optional<Fate> fate(const FactorKey& key) const;
  /// Forgets the entries of keyframes with an id below oldest_kf_id.
  void forgetBefore(int oldest_kf_id);
  std::size_t size() const { return fates_.size(); }
  const std::map<FactorKey, Fate>& entries() const { return fates_; }
  /// Over the ledger's life (forgetting keeps them): measurements of a kind given a fate, and
  /// records refused because the measurement had a fate already.
  int recorded(FactorKind kind, Fate fate) const;
  int refused() const { return refused_; }

 private:
  std::map<FactorKey, Fate> fates_;
  std::map<std::pair<FactorKind, Fate>, int> recorded_;
  int refused_ = 0;
};

/// The window's model from the rig and the options (an option < 0 takes the rig's figure).
WindowModel makeWindowModel(const SensorSetup& setup, const WindowOptions& options);

/// A sighting's noise (px) against one `frames` earlier on the same track: white_px2 (px^2) of the
/// sightings' own noise and the track's creep in between, which random-walks.
double sightingSigmaPx(double white_px2, double frames, const WindowModel& model);
/// The noise (px) of a sighting o against its landmark's anchor keyframe (pixel noise and creep).
double anchorSigmaPx(const Keyframe& anchor, const TrackObservation& o, const WindowModel& model);
/// The square-root information of a sighting with noise sigma_px in
/// factors::BearingFactor::tangentBasis(o.bearing_C)'s axes: the camera's pixels per radian there
/// over sigma_px (bearing_sigma_from_camera and known), else focal_px / sigma_px.
Mat2 sightingSqrtInformation(const TrackObservation& o, double sigma_px, const WindowModel& model);

/// The camera's pose in the body of keyframe kf when it took sighting o: the rig's T_B_C, moved
/// by the body's motion from the keyframe's time to o's row's (Keyframe::readout_rate_B and
/// readout_velocity_B over rolling_shutter_s * row / image_rows) with a rolling shutter.
SE3 sightingExtrinsics(const Keyframe& kf, const TrackObservation& o, const WindowModel& model);

/// True when the model gives keyframes terrain planes (terrain_planes and a camera height).
bool usesTerrain(const WindowModel& model);
/// Seeds the terrain plane of each keyframe that has none: the previous keyframe's, else the
/// ground below it (factors::terrainBelow). Call before building the factors of a solve.
void seedTerrain(const std::vector<Keyframe*>& keyframes, const WindowModel& model);

/// All factors over `keyframes` (time order) and `landmarks`. Landmarks whose anchor is not among
/// the keyframes, or with fewer than one usable non-anchor observation, get no factor; nor do
/// keyframes whose terrain plane is not seeded, nor measurements the ledger holds. With a
/// time_offset_s block (WindowMap::time_offset_s) and estimatesTimeOffset(model), the gyro
/// factors take it as a state and it gets its prior; likewise the camera-height factors with a
/// camera_height_offset_m block (WindowMap::camera_height_offset_m) and
/// estimatesCameraHeight(model).
std::vector<FactorSpec> buildFactors(const std::vector<Keyframe*>& keyframes,
                                     std::unordered_map<TrackId, Landmark>& landmarks,
                                     const WindowModel& model, const WindowGauge& gauge,
                                     const FactorLedger* ledger = nullptr,
                                     double* time_offset_s = nullptr,
                                     double* camera_height_offset_m = nullptr);

/// True when the model estimates a correction of the camera height (a height and a prior sigma).
inline bool estimatesCameraHeight(const WindowModel& model) {
  return model.camera_height_m > 0.0 && model.camera_height_offset_sigma_m > 0.0;
}

/// True when the model estimates the camera-gyro time offset (a gyro and a prior sigma).
inline bool estimatesTimeOffset(const WindowModel& model) {
  return model.use_gyro && model.time_offset_sigma_s > 0.0;
}

/// True when the keyframes' gyro factors see an orientation of their own (q_W_G), tied to q_W_B.
bool tiedRotations(const WindowModel& model);
/// The keyframes by id.
std::unordered_map<int, Keyframe*> keyframesById(const std::vector<Keyframe*>& keyframes);

/// The noise of association a's measurement (m): lidar_sigma_m for a range; for a ground-plane
/// association (ground_up_L non-zero), the beam's range noise seen off the plane
/// (lidar_range_sigma_m * ground_sin: a beam meeting the ground at a grazing angle pins the plane's
/// height far better than its range) and the ground's own departure from the plane
/// (lidar_ground_sigma_m), in quadrature.
double lidarSigma(const LidarAssociation& a, const WindowModel& model);

/// The predicted minus the measured value of association a (m): the range to the landmark point
/// p_W seen from where kf's scan was taken (kf.T_B_L; in the scan plane when planar), or its
/// height off the ground-beam plane; nullopt when the point sits on the LiDAR.
std::optional<double> lidarResidualM(const LidarAssociation& a, const Vec3& p_W,
                                     const Keyframe& kf);

/// The window's LiDAR gate: true when the range association a of keyframe kf measured and the
/// range to the landmark point p_W, seen from where kf's scan was taken (kf.T_B_L; in the scan
/// plane when planar), differ by more than max(gate_sigmas * lidar_sigma_m, gate_fraction *
/// range); for a ground-plane association, when the landmark's height off that plane exceeds
/// gate_sigmas * lidarSigma(a).
bool lidarOutlier(const LidarAssociation& a, const Vec3& p_W, const Keyframe& kf,
                  const WindowModel& model, double gate_sigmas, double gate_fraction);

}  // namespace ovo::estimator
