// The sliding-window estimator's per-frame logic without images (DESIGN section 7): fed with
// tracked bearings per frame (from the Frontend, or synthetic in tests), gyro samples and scans,
// it predicts each frame's pose, places it against the window's landmarks, decides keyframes,
// solves and marginalises, holds the pose at standstills and restarts after a tracking loss. Its
// own code is in core.cpp (the frame loop), core_gyro.cpp (the gyro side), core_keyframe.cpp (the
// keyframe step: solve, marginalisation, rescale, reset), core_standstill.cpp and starter.cpp
// (the start). The parts with a job of their own live beside it in estimator/window/: the scans
// (scans), LiDAR association (lidar_association), ranges (lidar_ranges), gate (lidar_gate) and
// rescale (rescale), standstills (standstill), the keyframe policy (keyframe_policy), landmarks
// (landmarks), the model and its factors (model, sighting, terrain, ledger, factors), the solve
// and marginalisation (solve, marginalize), ground labels (ground_labels), the per-frame pose
// (pose_refinement), the frame log the output is built from (frame_log) and the offline full
// refinement (refine).
#pragma once

#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "estimator/common/ground_plane.hpp"
#include "estimator/common/gyro_front.hpp"
#include "estimator/common/lidar_ground.hpp"
#include "estimator/common/lidar_scale.hpp"
#include "estimator/common/two_view.hpp"
#include "estimator/estimator.hpp"
#include "estimator/window/factors.hpp"
#include "estimator/window/frame_log.hpp"
#include "estimator/window/ground_chain.hpp"
#include "estimator/window/ground_labels.hpp"
#include "estimator/window/lidar_gate.hpp"
#include "estimator/window/lidar_ranges.hpp"
#include "estimator/window/map.hpp"
#include "estimator/window/marginalize.hpp"
#include "estimator/window/options.hpp"
#include "estimator/window/pose_refinement.hpp"
#include "estimator/window/refine.hpp"
#include "estimator/window/scans.hpp"
#include "estimator/window/sighting.hpp"
#include "estimator/window/solve.hpp"
#include "estimator/window/standstill.hpp"
#include "estimator/window/starter.hpp"
#include "estimator/window/terrain.hpp"

namespace ovo::estimator {

/// Timings and sizes of the last window solve (for benchmarks and diagnostics).
struct WindowSolveInfo {
  int keyframes = 0;
  int landmarks = 0;
  int residual_blocks = 0;
  int lidar_factors = 0;
  int iterations = 0;
  double solve_ms = 0.0;
  double marginalize_ms = 0.0;
};

class WindowCore {
 public:
  WindowCore(const SensorSetup& setup, const WindowOptions& options,
             const frontend::RelativePoseOptions& relpose_options = {},
             const GroundPlaneOptions& ground_options = {});
  ~WindowCore();
  WindowCore(const WindowCore&) = delete;
  WindowCore& operator=(const WindowCore&) = delete;

  void addGyro(const ImuSample& sample);
  void addScan(const LidarScan& scan);
  /// Estimator::measurementsUntil: with the camera found early by more than the scans' time
  /// tolerance, the image's time on the gyro clock plus that tolerance (a scan there is the
  /// frame's); else t_image.
  Timestamp measurementsUntil(Timestamp t_image) const;
  /// One camera frame's tracks -> the body pose at its time (always finite).
  FrameEstimate processFrame(VisualFrame frame);
  /// Gyro-predicted rotation of the camera from the last processed frame to t (bias-corrected),
  /// R_Ccur_Cprev, for the frontend's matching prior; nullopt without gyro or before any frame.
  std::optional<Mat3> predictRotationCurPrev(Timestamp t_ns) const;
  /// The gyro bias predictRotationCurPrev() uses (rad/s), for a frontend on another thread.
  const Vec3& gyroBias() const { return bias_; }
  /// Gyro samples held for later preintegrations (bounded: trimGyro).
  std::size_t gyroSamplesHeld() const { return gyro_.samples().size(); }

  /// false: the poses of frames settled for good are dropped instead of kept (FrameLog).
  void keepHistory(bool keep) { frames_.keepHistory(keep); }
  /// End of the sequence: final poses, optional full refinement.
  void finish();
  Trajectory trajectory() const;
  Trajectory keyframes() const;
  EstimatorStats stats() const;
  /// The covariance of the newest keyframe's pose (poseCovariance: rotation vector in the world
  /// frame, then position) from the window as it stands; nullopt before a window or when it
  /// cannot be computed.
  std::optional<Eigen::Matrix<double, 6, 6>> newestPoseCovariance();
  /// The gyro bias over time, on the gyro's clock as trajectory() and keyframes() are.
  std::vector<std::pair<Timestamp, Vec3>> biasHistory() const;

  bool initialized() const { return initialized_; }
  const FrameLog& frameLog() const { return frames_; }
  const WindowMap& map() const { return map_; }
  const WindowSolveInfo& lastSolve() const { return last_solve_; }
  /// What holds the window's gauge now (first-keyframe priors or the marginalisation prior).
  const WindowGauge& gauge() const { return gauge_; }
  /// Where the measurements that left the window went (prior or dropped).
  const FactorLedger& ledger() const { return ledger_; }
  const WindowOptions& options() const { return options_; }
  /// The constants of the window's factors (noise, losses, bounds) as the options and rig gave
  /// them.
  const WindowModel& model() const { return model_; }
  /// Pose of a keyframe now (window or archive), nullopt when unknown: as the vision sees it
  /// (Keyframe::pose, the frames' reference), or the body's (Keyframe::bodyPose, the output).
  std::optional<SE3> keyframePose(int kf_id, bool body = false) const;
  /// A keyframe's states now (window, archive or kept), nullopt when unknown.
  std::optional<KeyframeState> keyframeState(int kf_id) const;

 private:
  bool gyroOn() const { return use_gyro_ && !gyro_.empty(); }
  /// The gyro's rotation over [t0, t1] of image time (the gyro interval moved back by the time
  /// offset, gyroShift()).
  std::optional<factors::GyroPreintegration> preintegrate(Timestamp t0, Timestamp t1,
                                                          const Vec3& bias) const;
  /// The accelerometer over [t0, t1] of image time (factors::integrateAccel on the gyro's
  /// interval); nullopt unless usesAccel(model_) and the samples cover it.
  std::optional<factors::AccelInterval> accelInterval(Timestamp t0, Timestamp t1,
                                                      const Vec3& bias) const;
  /// Sets the run's gravity direction (WindowMap::gravity) from the first keyframe with an
  /// accelerometer interval, as if the robot did not accelerate there; once.
  void setGravity();
  /// The same over [t0, t1] of the gyro's clock.
  std::optional<factors::GyroPreintegration> preintegrateOnGyroClock(Timestamp t0, Timestamp t1,
                                                                     const Vec3& bias) const;
  /// The estimated time offset on top of the rig's (0 when not estimated), ns.
  Timestamp gyroShift() const;
  /// The scan made instantaneous at its stamp (options_.lidar_deskew and per-beam times).
  LidarScan deskewed(const LidarScan& scan) const;
  /// Poses stamped at image times moved to the gyro clock's (by gyroShift()).
  Trajectory ontoGyroClock(Trajectory poses) const;
  /// The gyro's rotation R_B0_B1 from t0 to t1 at the current bias when it covers the interval
  /// without a gap (the scans' placement).
  std::optional<Mat3> gyroRotation(Timestamp t0, Timestamp t1) const;
  /// The scan for the frame at t_ns (body pose T_W_B), placed (ScanTimeline::scanFor); nullopt
  /// without a LiDAR or a scan.
  std::optional<FrameScan> scanFor(Timestamp t_ns, const SE3& T_W_B) const;
  /// A frame a two-view reference may start at: with the LiDAR, one with a scan (both views then
  /// give range ratios for the scale).
  bool canReference(Timestamp t_ns) const;
  bool tryInitialize(const VisualFrame& frame, const SE3& T_W_B_pred, FrameEstimate* out);
  /// Starts the window from the initialiser's geometry: the two keyframes, the landmarks, the
  /// gauge and bias prior, and the frames since the reference placed between them.
  void startWindow(const VisualFrame& frame, const InitialGeometry& g);
  void startReference(const VisualFrame& frame, const SE3& T_W_B);
  Reference makeReference(const VisualFrame& frame, const SE3& T_W_B) const;
  /// A new keyframe observing `keep` and a spread selection of `candidates` (tracks next to
  /// LiDAR beams first); keep == nullptr and no scan: all candidates.
  Keyframe* addKeyframe(Timestamp t_ns, const SE3& T_W_B, const Vec3& bias,
                        const std::vector<TrackObservation>& candidates,
                        const std::unordered_map<TrackId, TrackObservation>* keep);
  /// The camera's pixels per radian at a bearing, in factors::BearingFactor::tangentBasis's axes
  /// (TrackObservation::px_per_rad); zero where the model gives none.
  Mat2 pixelsPerRadian(const Vec3& bearing_C) const;
  /// Pairs every window keyframe's landmarks with its scan's ranges (within the depth gate), after
  /// attachLateScans.
  void associateLidar();
  /// Gives a window keyframe without a scan the scan at its time that came after it.
  void attachLateScans();
  /// When the window's LiDAR ranges agree on a scale lidar_rescale_ratio off the window's, scales
  /// the window to them (rescale.hpp).
  bool rescaleToLidar();
  /// A segment started without a scale (unit baseline) and without LiDAR factors takes the ground
  /// plane's once the window's keyframes agree on the camera's height in its units
  /// (agreedGroundHeight over the last labelGround's planes): the window is rescaled to the rig's
  /// camera height. Without it, the ground and camera-height gates, made for a window at its true
  /// scale, reject every plane that would correct it.
  bool rescaleToGround();
  /// Scales the window by s (rescaleWindow), marks its scale known and drops the still reference
  /// (its pose is of the old scale).
  void rescaleBy(double s);
  void solveWindow();
  /// Forgets the gyro samples no later preintegration needs (memory stays flat over hours).
  void trimGyro();
  /// Preintegrates again the keyframes' gyro factors made across a gap that later samples have
  /// filled (samples that reached the estimator after their frame).
  void refreshGyroFactors();
  /// Camera-height factors: per keyframe, the plane fitted to the landmarks it anchors; its
  /// inliers near the camera get (or keep) the factor when the plane agrees with the camera height.
  void labelGround();
  void marginalize();
  void settleFrames();
  /// The model with the camera height as corrected by the window so far (no correction state).
  WindowModel heightCorrectedModel() const;
  void resetWindow();
  /// A frame's pose predicted from the last one: the gyro's rotation (a prior of rot_sigma when
  /// the gyro gave one) and the constant velocity (decaying over long gaps); dt since the last
  /// frame, s.
  struct Prediction {
    Timestamp t_ns = 0;  // the frame's
    SE3 T_W_B = SE3::Identity();
    double dt = 0.0;
    double rot_sigma = 0.0;
    bool rotation_prior = false;
    double rate_radps = 0.0;  // the gyro's mean rate over dt (0 without it)
  };
  Prediction predict(Timestamp t_ns);
  /// The body's motion through a rolling shutter's readout of the frame at t_ns with pose T_W_B:
  /// the gyro's rate just before it (the samples of the readout itself may not have come yet;
  /// bias removed) and the frames' velocity. Zero with a global shutter.
  Readout readoutAt(Timestamp t_ns, const SE3& T_W_B, const Vec3& bias) const;
  /// The gyro's mean rate (bias removed) over the `span` before t_ns; zero without samples.
  Vec3 gyroRateBefore(Timestamp t_ns, Timestamp span, const Vec3& bias) const;
  /// The standstill test of the frame with its tracks `obs` and the prediction's gyro rate.
  bool still(const VisualFrame& frame, const std::unordered_map<TrackId, TrackObservation>& obs,
             const Prediction& pred) const;
  /// processFrame's three cases once the standstill test is done: a still frame, a moving frame
  /// before initialisation, a moving frame after it. Each fills e and returns the frame's
  /// reference keyframe (-1: none).
  int processStill(const VisualFrame& frame, const Prediction& pred,
                   const std::unordered_map<TrackId, TrackObservation>& obs, FrameEstimate& e);
  int processBeforeInit(const VisualFrame& frame, const Prediction& pred, FrameEstimate& e);
  int processTracked(const VisualFrame& frame, const Prediction& pred,
                     std::unordered_map<TrackId, TrackObservation>& obs, FrameEstimate& e);
  /// Motion-only refinement of a frame's pose against the window's landmarks it sees (obs),
  /// started at the prediction. *ids: the landmarks used, in the order of
  /// PoseRefinement::inlier; *landmarks_seen: their number. nullopt unless the frame fits:
  /// min_landmark_observations inliers and min_inlier_fraction of the landmarks seen.
  std::optional<PoseRefinement> refineAgainstMap(
      const std::unordered_map<TrackId, TrackObservation>& obs, const Prediction& pred,
      std::vector<TrackId>* ids, std::size_t* landmarks_seen) const;
  void note(const std::string& text);
  /// Adds a keyframe (as it stands when it leaves the window) to stats: its LiDAR associations,
  /// their number and their residuals against the landmarks' points now (call while the
  /// landmarks' anchors are still in the map), and its camera-height correction along the path.
  void countKeyframe(const Keyframe& kf, EstimatorStats& stats) const;
  void recordFrame(const FrameEstimate& e, int ref_kf);
  /// A frame placed after keyframe kf: its orientation is kf's (the gyro chain's) turned by the
  /// gyro since, at kf's bias (frame_rotation_from_gyro); kept for the output to re-evaluate at
  /// kf's final bias (FrameRecord::gyro).
  void carryGyroRotation(const Keyframe& kf, FrameEstimate& e);
  void refineAll();
  std::vector<Keyframe*> windowKeyframes();
  /// The first moving frame after still ones (at t_ns): closes the streak.
  void endStandstill(Timestamp t_ns);
  // A bias sigma after dt_s of random walk: sqrt(sigma^2 + walk^2 dt).
  double walkedBiasSigma(double sigma_radps, double dt_s) const;

  SensorSetup setup_;
  WindowOptions options_;
  WindowModel model_;
  GroundPlaneOptions ground_options_;
  GroundPlaneOptions label_ground_options_;  // the keyframes' planes for camera-height factors
  // Before initialisation, with a camera height: the positions, chained over short baselines.
  std::optional<GroundChain> ground_chain_;
  bool use_gyro_ = true;
  bool use_lidar_ = true;

  GyroFront gyro_;                              // the estimator stage's samples (spikes left out)
  static constexpr double kSettleAfterS = 5.0;  // frames are settled this long after at least, s
  static constexpr double kGyroKeepS = 30.0;    // gyro history kept at most (a long stop), s
  static constexpr double kReshiftS = 0.001;    // a keyframe's gyro interval is integrated again
                                                // when the time offset moved this far from it, s
  ScanTimeline scans_;
  WindowLidar lidar_;
  WindowStarter starter_;

  WindowMap map_;
  WindowGauge gauge_;
  FactorLedger ledger_;  // the measurements that left the window
  bool initialized_ = false;
  int next_kf_id_ = 0;
  int segment_ = 0;
  // The bias estimate when the window was reset after a loss, and the time of its keyframe: the
  // next segment starts from it instead of the loose first-start prior.
  std::optional<std::pair<Timestamp, Vec3>> carried_bias_;
  bool lidar_scale_ = false;  // the current segment's scale came from the LiDAR
  // A scale found by the search (WindowLidar::scaleRatio) waits for the next keyframe's search to
  // find it again before the window is rescaled to it: one keyframe's chance agreement (rows of
  // vines repeat) must not rescale a window whose ranges merely disagree.
  std::optional<double> searched_ratio_;
  bool scale_known_ = true;  // false: the segment started at a unit baseline (rescaleToGround)
  std::vector<double> ground_heights_;  // the last labelGround's plane heights (rescaleToGround)
  // The ground's roughness in the recent scans (the camera height along the path's estimated
  // sigma), the newest last.
  std::deque<GroundRoughness> ground_roughness_;

  // Last frame.
  bool have_last_ = false;
  Timestamp last_t_ = 0;
  SE3 last_T_W_B_ = SE3::Identity();
  Vec3 velocity_W_ = Vec3::Zero();  // m/s
  Vec3 bias_ = Vec3::Zero();
  std::unordered_map<TrackId, TrackObservation> last_obs_;
  int lost_frames_ = 0;

  // Standstills: their mean gyro rate measures the bias (zero-rate update). Before
  // initialisation the still frames of every streak add up to the first keyframe's bias prior;
  // after it each streak gives a zero-rate factor on the last keyframe when it ends.
  StandstillBias still_bias_;
  std::optional<Timestamp> still_since_;     // the first frame of the current still streak
  std::vector<WindowGauge> segment_gauges_;  // each segment's gauge at its start (refine full)
  // The last zero-rate update while initialised, and when its streak ended: the bias prior of
  // a segment that starts soon after it (e.g. the restart from the last still frame).
  std::optional<std::pair<Timestamp, StandstillBias::Estimate>> recent_zero_rate_;

  // Initialisation reference.
  std::optional<Reference> reference_;
  // The last still frame (while initialised) as a two-view reference at its held pose, with the
  // frames since: the window restarts there when the tracks no longer fit its landmarks within
  // kStillRestartS of the standstill's end (they crept while the robot stood).
  std::optional<Reference> still_reference_;
  static constexpr double kStillRestartS = 1.0;

  FrameLog frames_;
  std::optional<GyroSpan> frame_gyro_;  // the current frame's, for recordFrame
  EstimatorStats stats_;
  WindowSolveInfo last_solve_;
  bool in_gap_ = false;
  bool finished_ = false;
};

}  // namespace ovo::estimator
