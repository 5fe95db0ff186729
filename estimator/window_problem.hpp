// Building and solving the window's Ceres problem (bearing or bearing-step, gyro, bias random walk,
// LiDAR range, camera-height and terrain-plane, gauge and marginalisation factors), the
// marginalisation of the oldest keyframe, the per-frame motion-only pose refinement, and the
// offline full refinement over every keyframe.
#pragma once

#include <ceres/cost_function.h>
#include <ceres/loss_function.h>
#include <ceres/sized_cost_function.h>

#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "estimator/window_map.hpp"
#include "factors/marginalization.hpp"

namespace ovo::estimator {

/// Prior on one gyro bias: r = (b_g - b_0) / sigma.
class BiasPriorFactor final : public ceres::SizedCostFunction<3, 3> {
 public:
  BiasPriorFactor(const Vec3& b0, double sigma) : b0_(b0), inv_sigma_(1.0 / sigma) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    for (int i = 0; i < 3; ++i) residuals[i] = (parameters[0][i] - b0_[i]) * inv_sigma_;
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> J(jacobians[0]);
      J = Mat3::Identity() * inv_sigma_;
    }
    return true;
  }

 private:
  Vec3 b0_;
  double inv_sigma_;
};

/// Constants of the window's factors.
struct WindowModel {
  SE3 T_B_C = SE3::Identity();             // (the LiDAR's pose is each keyframe's: Keyframe::T_B_L)
  double bearing_sigma_rad = 0.5 / 305.0;  // pixel sigma / focal px
  double bearing_huber = 2.0;              // Huber threshold on the whitened residual (sigmas)
  double bearing_creep_rad = 0.0;     // track creep per sqrt(frame) between anchor and observation
  bool bearing_steps = false;         // sightings after a track's first: BearingStepFactor from the
  double step_white_rad = 0.0;        // previous one, whose sighting noise it carries too
  double lidar_sigma_m = 0.02;        // a range to a landmark (range and association noise), m
  double lidar_range_sigma_m = 0.02;  // the LiDAR's range noise alone, m
  double lidar_ground_sigma_m = 0.002;  // the ground's own departure from a ground beam's plane, m
  double lidar_huber = 2.0;             // robust loss threshold on the whitened residual (sigmas)
  bool lidar_cauchy = false;         // Cauchy (an association far off pulls ever less), else Huber
  double bias_random_walk = 2.0e-5;  // rad/s^2/sqrt(Hz)
  double vision_rotation_sigma_rad = 0.0;  // a keyframe's orientation error as the vision sees
                                           // it (RotationTieFactor; 0: no tie, one orientation)
  double bias_prior_sigma_radps = 0.02;
  double gauge_sigma_position_m = 1e-4;
  double gauge_sigma_rotation_rad = 1e-4;
  double min_rho = 1.0 / 1000.0;  // 1/m
  double max_rho = 1.0 / 0.1;     // 1/m
  bool use_gyro = true;
  double camera_height_m = 0.0;  // ground landmarks' depth below the camera, m (<= 0: no factor)
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
  kBearing,
  kGyro,
  kBiasWalk,
  kBiasPrior,
  kPosePrior,
  kLidar,
  kMarginal,
  kGround,
  kTerrain,
  kRotationTie
};

/// One residual block before it goes into a Problem or a MarginalizationInfo.
struct FactorSpec {
  FactorKind kind = FactorKind::kBearing;
  std::unique_ptr<ceres::CostFunction> cost;
  std::unique_ptr<ceres::LossFunction> loss;
  std::vector<double*> blocks;
  TrackId track = -1;  // bearing / LiDAR: the landmark
  int kf_id = -1;      // bearing: observing keyframe; LiDAR: scan keyframe; gyro: later keyframe
};

/// True when the model gives keyframes terrain planes (terrain_planes and a camera height).
bool usesTerrain(const WindowModel& model);
/// Seeds the terrain plane of each keyframe that has none: the previous keyframe's, else the
/// ground below it (factors::terrainBelow). Call before building the factors of a solve.
void seedTerrain(const std::vector<Keyframe*>& keyframes, const WindowModel& model);

/// All factors over `keyframes` (time order) and `landmarks`. Landmarks whose anchor is not among
/// the keyframes, or with fewer than one usable non-anchor observation, get no factor; nor do
/// keyframes whose terrain plane is not seeded.
std::vector<FactorSpec> buildFactors(const std::vector<Keyframe*>& keyframes,
                                     std::unordered_map<TrackId, Landmark>& landmarks,
                                     const WindowModel& model, const WindowGauge& gauge);

struct SolveOptions {
  std::string linear_solver = "dense_schur";  // dense_schur | sparse_schur
  int max_iterations = 8;
  double max_time_s = 0.0;  // 0: unlimited
  int num_threads = 1;
};

struct SolveSummary {
  bool usable = false;  // the solver ran and every state is finite
  int iterations = 0;
  int residual_blocks = 0;
  double initial_cost = 0.0, final_cost = 0.0;
  std::string message;
};

/// Solves the window in place. On failure (non-finite states) the states are restored.
SolveSummary solveFactors(std::vector<FactorSpec> factors, const std::vector<Keyframe*>& keyframes,
                          std::unordered_map<TrackId, Landmark>& landmarks,
                          const WindowModel& model, const SolveOptions& options);

/// Angular error (rad) of every bearing observation at the current states, by (kf id, track).
struct ObservationError {
  int kf_id;
  TrackId track;
  double angle_rad;
};
std::vector<ObservationError> observationErrors(const std::vector<Keyframe*>& keyframes,
                                                const std::unordered_map<TrackId, Landmark>& lms,
                                                const WindowModel& model);

/// The noise of association a's measurement (m): lidar_sigma_m for a range; for a ground-plane
/// association (ground_up_L non-zero), the beam's range noise seen off the plane
/// (lidar_range_sigma_m * ground_sin: a beam meeting the ground at a grazing angle pins the plane's
/// height far better than its range) and the ground's own departure from the plane
/// (lidar_ground_sigma_m), in quadrature.
double lidarSigma(const LidarAssociation& a, const WindowModel& model);

/// The window's LiDAR gate: true when the range association a of keyframe kf measured and the
/// range to the landmark point p_W, seen from where kf's scan was taken (kf.T_B_L; in the scan
/// plane when planar), differ by more than max(gate_sigmas * lidar_sigma_m, gate_fraction *
/// range); for a ground-plane association, when the landmark's height off that plane exceeds
/// gate_sigmas * lidarSigma(a).
bool lidarOutlier(const LidarAssociation& a, const Vec3& p_W, const Keyframe& kf,
                  const WindowModel& model, double gate_sigmas, double gate_fraction);

/// Re-propagates the gyro preintegrations (keyframes in time order) whose bias linearisation is
/// now more than 0.002 rad/s from the previous keyframe's estimate.
void repropagateGyro(const std::vector<Keyframe*>& keyframes);

/// Marginalises the oldest keyframe of `map` (VINS-Mono / OKVIS style, DESIGN section 6): its
/// states, its gyro / bias / gauge factors, the previous prior, and the landmarks it anchors that
/// are keys of `marginalize_tracks` (Schur-complemented out) go into the new prior. The value -1
/// takes all of a landmark's factors (one that ends here); a keyframe id takes only the factors
/// of the anchor itself and of that keyframe (a landmark the caller re-anchors there: its other
/// observations stay in the window, so each measurement counts once). Factors of the other
/// landmarks it anchors are dropped. Each landmark is Schur-complemented on its own (a 1x1
/// block). Returns the new prior (null when the marginalisation failed; the caller then keeps a
/// pose prior instead).
std::shared_ptr<const factors::MarginalizationInfo> marginalizeOldest(
    WindowMap& map, const WindowModel& model, const WindowGauge& gauge,
    const std::unordered_map<TrackId, int>& marginalize_tracks);

/// Motion-only refinement of one frame pose against landmarks fixed at their current values
/// (world points), with a rotation prior (e.g. from the gyro). Returns the pose and, per point,
/// whether it is an inlier (angle error below outlier_rad); nullopt when it fails.
struct PoseRefinement {
  SE3 T_W_B;
  std::vector<char> inlier;
  int num_inliers = 0;
};
std::optional<PoseRefinement> refinePose(const std::vector<Vec3>& points_W,
                                         const std::vector<Vec3>& bearings_C, const SE3& T_W_B_init,
                                         const std::optional<Mat3>& R_W_B_prior,
                                         double prior_sigma_rad, const WindowModel& model,
                                         int max_iterations, double outlier_rad);

}  // namespace ovo::estimator
