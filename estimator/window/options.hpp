// Tuning of the sliding-window estimator (`--estimator window`, DESIGN section 7). Keys
// under "window." (readWindowOptions); gyro preintegration under "gyro.", the frontend's own
// blocks ("frontend.", "ransac.") are read by their readers.
#pragma once

#include "common/config.hpp"
#include "estimator/common/gyro_front.hpp"
#include "factors/gyro_preintegration.hpp"

namespace ovo::estimator {

/// How the window's problem is solved: the window's own Levenberg-Marquardt with the inverse
/// depths eliminated by hand (landmark_schur.hpp; Ceres' steps in less time), or Ceres with a
/// dense or sparse Schur solver (DESIGN section 7: both measured, dense wins at 10 keyframes).
enum class LinearSolver { kLandmarkSchur, kDenseSchur, kSparseSchur };
/// Whether the run ends with a batch re-optimisation of every keyframe (offline only).
enum class RefineMode { kNone, kFull };
/// How a LiDAR beam that ends on the ground constrains the landmark next to it.
enum class GroundBeams {
  kPlane,  // the landmark lies on the ground plane through the beam end (lidarSigma's noise)
  kSkip,   // not used
  kRaw,    // the beam's range, as for any other beam (biased long at grazing angles)
};
/// Robust loss of the LiDAR range factors.
enum class RobustLoss { kHuber, kCauchy };
/// What enters the marginalisation prior of a landmark that outlives the oldest keyframe (it is
/// re-anchored in the next keyframe that sees it).
enum class ReanchoredPrior {
  kLink,  // the oldest keyframe's own factors and the sighting that links the old anchor to the
          // new one; the later sightings stay in the window (each measurement counted once)
  kNone,  // none (the prior keeps little but the gyro)
};

struct WindowOptions {
  // Sensors.
  bool use_gyro = true;   // false: vision-only rotation even when the dataset has a gyro
  bool use_lidar = true;  // false: ground-plane scale even when the dataset has scans

  // Window and keyframes.
  int window_size = 10;          // keyframes in the window
  double kf_parallax_deg = 5.0;  // rotation-compensated median parallax to the last kf, deg
  double kf_parallax_scan_fraction = 0.6;  // a frame with a scan needs this fraction of it
  double kf_track_fraction = 0.6;          // new kf when fewer of the last kf's tracks are alive
  // ... at a frame without a scan whose successor is expected to bring one (at most the above):
  double kf_track_fraction_between_scans = 0.5;
  double kf_max_interval_s = 1.0;      // new kf at the latest after this time (when moving), s
  int min_landmark_observations = 12;  // fewer landmarks seen in a frame: tracking lost
  double min_inlier_fraction = 0.15;   // ... or fewer of them fit the frame's pose: lost
  int max_features = 500;              // tracks a keyframe keeps (spread over the image)
  int max_lidar_features = 60;         // ... of which tracks picked next to LiDAR beams
  double feature_cell_px = 40.0;       // spreading grid cell, px
  int features_per_cell = 2;           // tracks per grid cell

  // Landmarks.
  double landmark_min_parallax_deg = 1.0;  // triangulation angle needed to create a landmark, deg
  double landmark_min_depth_m = 0.2;       // nearer points are rejected, m (after scale init)
  double landmark_max_depth_m = 80.0;      // farther triangulations start as points at
                                           // infinity (inverse depth 0; the solve may bring
                                           // them nearer), m
  double outlier_sigmas = 5.0;     // after a solve a sighting further than this from its landmark's
                                   // prediction, in its own sigmas (pixel noise and the track's
                                   // creep since the anchor, through the camera), is removed;
                                   // the full refinement's passes use the same gate
  double outlier_angle_deg = 0.5;  // the gate in degrees for a frame's own pose against the
                                   // window's landmarks, deg

  // Noise and losses.
  double pixel_sigma = -1.0;               // image noise, px; < 0: the rig's value
  bool bearing_sigma_from_camera = false;  // a sighting's angular noise from the camera model's
                                           // pixels per radian at its bearing (false: the centre
                                           // focal length for the whole image; measured better,
                                           // README "Accuracy and known limits")
  double bearing_huber_sigmas = 2.0;       // Huber loss threshold, in units of the bearing sigma
  double track_creep_px = 0.2;   // a track's random walk, px per sqrt(frame): the sigma between
                                 // two sightings grows with the frames between them
  bool bearing_steps = true;     // a track's sightings after its first are tied to the previous
                                 // sighting (BearingStepFactor), not to the anchor: the steps of
                                 // a random walk are independent, its errors against the anchor
                                 // are not (no effect with track_creep_px 0)
  double track_white_px = 0.16;  // the sighting noise of each end of a step, px
  double lidar_range_sigma_m = -1.0;       // LiDAR range noise, m; < 0: the rig's value
  double lidar_association_sigma_m = 0.0;  // added in quadrature to the range noise: a
                                           // landmark off the scan plane, on foliage, m
  double lidar_huber_sigmas = 2.0;         // robust loss threshold of LiDAR factors, sigmas
  double gyro_max_jump_radps = 10.0;       // a gyro sample whose rate jumps more than this from the
                                           // last one used, on any axis, is a spike and unused (a
                                           // clipped reading); <= 0: all used
  double gyro_max_spike_s = 0.05;       // ... for at most this long, s: a jump that lasts is real
  double gyro_bias_random_walk = -1.0;  // rad/s^2/sqrt(Hz); < 0: the rig's value
  double gyro_bias_prior_sigma_radps = 0.02;  // prior on the first keyframe's bias, rad/s
  // The camera-gyro time offset as a state of the window (factors/time_offset_factor.hpp), on
  // top of the rig's camera.time_offset_s (the runners move the image stamps by that first).
  bool estimate_time_offset = true;
  double time_offset_sigma_s = 0.02;  // its prior about the rig's value, s
  double time_offset_max_s = 0.1;     // and the furthest it may move from it, s
  // A rolling shutter (the rig's camera.rolling_shutter_s > 0): each sighting is predicted from
  // the camera's pose at its row's time (the keyframe's pose moved by the gyro's rate and the
  // velocity); false: every row at the frame's time.
  bool rolling_shutter = true;
  // The accelerometer as a tilt reference (factors/accel_factor.hpp): the specific force between
  // three keyframes against their positions' acceleration and gravity, with this noise (the
  // robot's vibration and the keyframes' position noise; 0: unused), m/s^2; the accelerometer's
  // bias a state with this prior sigma, m/s^2.
  double accel_sigma_mps2 = 0.01;
  double accel_position_sigma_m = 5e-4;  // the keyframes' positions' noise in that factor, m
  double accel_bias_sigma_mps2 = 0.1;
  double vision_rotation_sigma_rad = 1e-3;  // a keyframe's orientation as the vision sees it is
                                            // tied to the gyro chain's with this sigma (0: one
                                            // orientation for both), rad
  double reinit_bias_sigma_radps = 1e-3;   // ... after a loss: the previous estimate's sigma, rad/s
  double gauge_sigma_position_m = 1e-4;    // first-keyframe pose prior before the first marg., m
  double gauge_sigma_yaw_rad = 1e-4;       // ... and its yaw/roll/pitch sigma, rad
  double rotation_prior_sigma_rad = 2e-3;  // per-frame motion-only refinement: gyro rotation
                                           // prior sigma on top of the preintegration noise, rad

  // Camera-height factor (ground landmarks near the camera; needs the rig's camera height).
  bool use_ground_height = true;        // false: scale from the LiDAR (and initialisation) only
  double ground_height_sigma_m = 0.06;  // noise of a ground point's height below the camera, m
  bool estimate_camera_height = false;  // with a LiDAR: a correction of the rig's camera height is
                                        // a state (on rough ground the ground points the camera
                                        // sees lie higher or lower than the rig's height says).
                                        // Off: it lets the LiDAR's own scale bias in (README)
  double camera_height_sigma_m = 0.02;  // its prior about 0 (bounded to 5 of these), m
  // The camera's height over the ground it sees as a state of every keyframe (with a LiDAR; not
  // with estimate_camera_height): a correction of the rig's height that follows the terrain along
  // the path, a Gauss-Markov process in the distance driven (factors::CameraHeightWalkFactor),
  // observed by the ground landmarks against the LiDAR's scale.
  bool camera_height_path = false;
  double camera_height_path_sigma_m = 0.0;      // its standard deviation about the rig's height, m
                                                // (0: estimated from the ground seen, kPathHeight*)
  double camera_height_path_length_m = 3.0;     // its correlation length along the path, m
  double ground_max_distance_heights = 6.0;     // ground points used up to this distance, in camera
                                                // heights (6 m at 1 m; 9.9 m at KITTI's 1.65 m,
                                                // whose nearest visible ground is 6.3 m away)
  double ground_min_depression_deg = 8.0;       // ... and at least this far below the horizon, deg
  double ground_scale_gate = 0.2;               // the keyframe's fitted plane must be within this
                                                // fraction of the camera height (scale sanity)
  double ground_scale_gate_no_lidar = 0.5;      // ... without a LiDAR, where the ground is the only
                                                // scale after the start
  double ground_normal_max_deg_no_lidar = 5.0;  // ... and without a LiDAR its normal within
                                                // this of the body's up (else vo.ground's), deg
  double ground_inlier_fraction = 0.04;  // a point is on the plane within this fraction of the
                                         // camera height; after a solve it keeps its factor
                                         // within twice that

  // Terrain planes: with the camera height, each keyframe carries the ground plane in the world
  // frame; ground landmarks lie on it (ground_height_sigma_m) and it walks between keyframes, so
  // the roll and pitch the gyro drifts in are seen against the ground.
  bool terrain_planes = false;
  double terrain_slope_walk = 0.002;   // change of the ground's slope per sqrt(m) driven
  double terrain_height_walk = 0.002;  // change of its height, m per sqrt(m) driven

  // LiDAR association.
  double lidar_radius_px = 4.0;    // beam end point to observation, px
  double lidar_depth_gate = 0.25;  // relative depth agreement once the scale is set
  double lidar_edge_step = 0.05;   // beams used only on smooth surfaces: adjacent ranges
                                   // differ by less than this fraction of the range
  int lidar_edge_neighbours = 2;   // ... over this many beams on each side (0: off)
  // With lidar_interpolate, beams ending on the ground (0.7 camera heights below the camera; needs
  // the rig's camera height) meet it grazing, so their range hangs on the elevation.
  GroundBeams lidar_ground_beams = GroundBeams::kPlane;
  double lidar_ground_sigma_m = 0.002;   // the ground's own departure from that plane (its
                                         // roughness, the body's tilt against it), m
  bool lidar_interpolate = true;         // associate landmarks near the scan plane with the range
  double lidar_max_elevation_deg = 1.0;  // interpolated at their azimuth (false: nearest beam end
                                         // within lidar_radius_px); elevation gate, deg
  double lidar_outlier_sigmas = 3.0;     // after a solve an association is removed when its
  double lidar_outlier_fraction = 0.05;  // residual exceeds this many sigmas and this fraction
                                         // of the range
  RobustLoss lidar_loss = RobustLoss::kHuber;  // robust loss of the LiDAR factors
  double lidar_scan_time_tol_s = 0.004;        // a scan belongs to a frame within this time, s
  // A frame without one takes the latest scan up to this much older, its LiDAR pose moved by the
  // motion since (a LiDAR out of step with the camera; scanFor); 0: none, s.
  double lidar_scan_max_age_s = 0.05;
  // A scan with per-beam times (a swept LiDAR) is made instantaneous at its stamp from the gyro
  // and the velocity (estimator/common/lidar_deskew.hpp) when it arrives.
  bool lidar_deskew = true;
  int lidar_min_associations = 8;        // fewer (or disagreeing) at initialisation: ground plane
  double lidar_rescale_ratio = 0.1;      // the window's landmark distances over the LiDAR's
                                         // ranges to them this far from 1: the window is
                                         // rescaled to the ranges (0: never) ...
  int lidar_rescale_min_ranges = 8;      // ... when at least this many ranges (and half of
  double lidar_rescale_agreement = 0.1;  // them) agree on the ratio within this fraction

  // Initialisation.
  double init_parallax_deg = 1.5;  // rotation-compensated median parallax to initialise, deg
  int init_min_tracks = 30;        // shared tracks needed between the two views
  double init_max_wait_s = 2.0;    // after this long without init, half the parallax suffices, s

  // Standstill.
  double standstill_flow_px = 0.3;           // median flow to the previous frame below this ...
  double standstill_gyro_std_radps = 0.005;  // ... and the frame's gyro samples this quiet
                                             // (2x a MEMS gyro's noise at 200 Hz; ride
                                             // vibration gives 0.004-0.01), rad/s ...
  double standstill_gyro_radps = 0.02;       // ... and, once initialised, |w - b_g| below this
  double standstill_min_bias_s = 0.25;       // standstill this long: its mean gyro rate is the bias
                                        // (prior on the first keyframe before initialisation, a
                                        // zero-rate factor on the last keyframe after), s
  double standstill_trim_s = 0.3;    // the last still frames before the motion was seen are
                                     // left out of that mean (they hold its start), s
  double standstill_settle_s = 0.3;  // still frames this soon after the streak began are still
                                     // placed against the landmarks (the robot creeps to rest
                                     // below the flow threshold), later ones hold the pose, s

  // Tracking loss.
  double velocity_decay_per_s = 0.5;  // constant-velocity decay while lost and over gaps in
                                      // the frames beyond 1 s (fraction kept per s)
  int reinit_after_lost_frames = 5;   // lost this long: restart the window at the current pose

  // Solver.
  LinearSolver linear_solver = LinearSolver::kLandmarkSchur;
  int max_iterations = 4;                 // per window solve (warm-started by the last)
  double solver_stop_decrease = 0.01;     // landmark_schur: stop after a step that lowered the
                                          // cost by less than this fraction (0: off)
  double max_solver_time_s = 0.0;         // per window solve, s; 0 = no limit (online: ~0.04)
  int motion_only_iterations = 5;         // per-frame pose refinement
  bool frame_rotation_from_gyro = true;   // a frame between keyframes takes its keyframe's
                                          // orientation turned by the gyro since (false: its
                                          // own refinement's against the landmarks)
  RefineMode refine = RefineMode::kNone;  // full: re-optimise all keyframes at the end
  int refine_iterations = 30;             // full refinement iterations per pass
  int refine_passes = 2;                  // solves, outliers removed between them
  bool refine_bearing_steps = false;      // the refinement's own bearing_steps
  int refine_max_span_frames = 40;        // a track becomes a new landmark after this many
                                          // frames (tracks creep: a long span ties far
                                          // keyframes with a biased ray); 0: never. Not
                                          // with refine_bearing_steps: they model the creep
  bool refine_ground = true;              // camera-height factors in the refinement
  int marginalize_max_landmarks = 0;      // ending landmarks Schur-complemented into the prior,
                                          // strongest first (the rest are dropped); 0: all
  ReanchoredPrior marginalize_reanchored = ReanchoredPrior::kLink;

  factors::GyroPreintegrationOptions gyro;  // "gyro." keys
  bool operator==(const WindowOptions&) const = default;
};

/// Reads every "window." key (and "gyro." through factors::readGyroPreintegrationOptions).
WindowOptions readWindowOptions(const Config& config);

/// The window's gyro front (the estimator stage's and the frontend's matching prior's): its spike
/// filter and preintegration.
inline GyroFrontOptions gyroFrontOptions(const WindowOptions& options) {
  return {options.gyro_max_jump_radps, options.gyro_max_spike_s, options.gyro};
}

/// Whether bearing steps are used where `requested` (bearing_steps online, refine_bearing_steps in
/// the refinement): they model the tracks' creep, so without one (track_creep_px 0) the sightings
/// are tied to the anchor.
inline bool useBearingSteps(bool requested, const WindowOptions& options) {
  return requested && options.track_creep_px > 0.0;
}

}  // namespace ovo::estimator
