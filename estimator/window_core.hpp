// The sliding-window estimator's per-frame logic without images (DESIGN section 7): fed with
// tracked bearings per frame (from the Frontend, or synthetic in tests), gyro samples and scans;
// keeps the window of keyframes, initialises, detects standstill, recovers from tracking loss,
// solves and marginalises, and refines everything at the end when asked.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "estimator/estimator.hpp"
#include "estimator/ground_plane.hpp"
#include "estimator/gyro_buffer.hpp"
#include "estimator/lidar_scale.hpp"
#include "estimator/window_ground_chain.hpp"
#include "estimator/window_init.hpp"
#include "estimator/window_lidar.hpp"
#include "estimator/window_map.hpp"
#include "estimator/window_options.hpp"
#include "estimator/window_problem.hpp"
#include "estimator/window_refine.hpp"

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

  void addGyro(const ImuSample& sample);
  void addScan(const LidarScan& scan);
  /// One camera frame's tracks -> the body pose at its time (always finite).
  FrameEstimate processFrame(const VisualFrame& frame);
  /// Gyro-predicted rotation of the camera from the last processed frame to t (bias-corrected),
  /// R_Ccur_Cprev, for the frontend's matching prior; nullopt without gyro or before any frame.
  std::optional<Mat3> predictRotationCurPrev(Timestamp t_ns) const;
  /// The gyro bias predictRotationCurPrev() uses (rad/s), for a frontend on another thread.
  const Vec3& gyroBias() const { return bias_; }

  /// End of the sequence: final poses, optional full refinement.
  void finish();
  Trajectory trajectory() const;
  Trajectory keyframes() const;
  EstimatorStats stats() const;
  std::vector<std::pair<Timestamp, Vec3>> biasHistory() const { return bias_history_; }

  bool initialized() const { return initialized_; }
  const WindowMap& map() const { return map_; }
  const WindowSolveInfo& lastSolve() const { return last_solve_; }
  /// What holds the window's gauge now (first-keyframe priors or the marginalisation prior).
  const WindowGauge& gauge() const { return gauge_; }
  const WindowOptions& options() const { return options_; }
  /// Pose of a keyframe now (window or archive), nullopt when unknown: as the vision sees it
  /// (Keyframe::pose, the frames' reference), or the body's (Keyframe::bodyPose, the output).
  std::optional<SE3> keyframePose(int kf_id, bool body = false) const;

 private:
  struct FrameRecord {
    Timestamp t_ns = 0;
    SE3 T_W_B = SE3::Identity();   // as returned online
    int ref_kf = -1;               // keyframe the pose is expressed against (-1: none)
    SE3 T_kf_B = SE3::Identity();  // pose relative to that keyframe
    bool tracked = false;
    bool is_keyframe = false;
  };

  bool gyroOn() const { return use_gyro_ && !gyro_.empty(); }
  std::optional<factors::GyroPreintegration> preintegrate(Timestamp t0, Timestamp t1,
                                                          const Vec3& bias) const;
  const LidarScan* scanAt(Timestamp t_ns) const;
  /// A scan for the frame at t_ns (body pose T_W_B) and the LiDAR's pose when it took it, in
  /// that frame's body frame: the scan at the frame (scanAt, the rig's T_B_L), else the latest
  /// scan up to lidar_scan_max_age_s older, its LiDAR pose moved back by the gyro's rotation over
  /// the gap and by the position interpolated between the frames around the scan (needs the
  /// gyro). Before initialisation those positions are not yet metric: an older scan there
  /// carries the motion over its age as an error (1.6 cm at 0.8 m/s and 20 ms). nullopt: none.
  struct FrameScan {
    const LidarScan* scan = nullptr;
    SE3 T_B_L = SE3::Identity();
  };
  std::optional<FrameScan> scanFor(Timestamp t_ns, const SE3& T_W_B) const;
  /// Which scan scanFor takes for the frame at t_ns, without placing it: the scan at the frame
  /// (R_Bscan_Bframe nullopt), or the older one with the gyro's rotation over the gap
  /// (preintegrated from the scan to the frame). nullopt: none.
  struct ScanChoice {
    const LidarScan* scan = nullptr;
    std::optional<Mat3> R_Bscan_Bframe;
  };
  std::optional<ScanChoice> chooseScan(Timestamp t_ns) const;
  /// Whether the frame after the one at t_ns (one frame period on) is expected to come with a
  /// scan (within lidar_scan_time_tol_s): the first buffered scan after t_ns, or else the last
  /// scan plus the last scan period, falls on it.
  bool scanExpectedAfter(Timestamp t_ns) const;
  /// A frame a two-view reference may start at: with the LiDAR, one with a scan (both views then
  /// give range ratios for the scale).
  bool canReference(Timestamp t_ns) const { return !use_lidar_ || chooseScan(t_ns).has_value(); }
  bool tryInitialize(const VisualFrame& frame, const SE3& T_W_B_pred, FrameEstimate* out);
  void startReference(const VisualFrame& frame, const SE3& T_W_B);
  // Before initialisation: the frame's rotation, the gyro's (in T_W_B_pred), else the two-view
  // one from its sightings of the reference's tracks (its position comes from the ground chain).
  // A reference that restarts (its tracks ran out, or no scale came) starts from there, so the
  // motion since the old one is kept.
  Mat3 rotationFromReference(const VisualFrame& frame, const SE3& T_W_B_pred) const;
  /// A new keyframe observing `keep` and a spread selection of `candidates` (tracks next to
  /// LiDAR beams first); keep == nullptr and no scan: all candidates.
  Keyframe* addKeyframe(Timestamp t_ns, const SE3& T_W_B, const Vec3& bias,
                        const std::vector<TrackObservation>& candidates,
                        const std::unordered_map<TrackId, TrackObservation>* keep);
  std::vector<LidarAssociation> lidarCandidates(const VisualFrame& frame,
                                                const std::optional<FrameScan>& scan) const;
  // The scan's beams on smooth surfaces, in the image (to pair with features by their pixel).
  std::vector<BeamInImage> usableBeams(const FrameScan& scan) const;
  void triangulateNewLandmarks(Keyframe& kf);
  // A range of the keyframe's scan to a landmark it sees, and the landmark's distance as the
  // window has it (both in the scan plane for interpolated ranges).
  struct LidarRange {
    LidarAssociation association;
    double landmark_m = 0.0;  // the landmark's distance from the LiDAR now
    double measured_m = 0.0;  // the range it must agree with (ground beams: along the ray)
    bool ground = false;      // a beam ending on the ground (lidar_ground_beams plane)
  };
  std::vector<LidarRange> lidarRangesAt(const Keyframe& kf) const;
  /// Pairs the keyframe's landmarks with its scan's ranges (gate_depth: only those within
  /// lidar_depth_gate of the landmark's distance), except those paired or rejected before.
  void associateLidar(Keyframe& kf, bool gate_depth);
  /// The window's landmark distances over the LiDAR's ranges to them, when enough ranges from
  /// enough landmarks agree on one ratio (lidar_rescale_*); nullopt otherwise.
  std::optional<double> lidarScaleRatio() const;
  /// When that ratio is off by more than lidar_rescale_ratio, scales the window to the LiDAR
  /// (about its oldest keyframe: positions, landmarks, the marginalisation prior, the velocity).
  /// The depth gate and the outlier test reject every range once the scale is off by more than
  /// they allow, e.g. after a headland turn with nothing in LiDAR range: without this the window
  /// kept a wrong scale for good when no camera-height factor held it.
  bool rescaleToLidar();
  void solveWindow();
  void removeOutliers();
  /// Camera-height factors: per keyframe, the plane fitted to the landmarks it anchors; its
  /// inliers near the camera get (or keep) the factor when the plane agrees with the camera height.
  void labelGround();
  void marginalize();
  void resetWindow();
  /// Keyframe decision (DESIGN section 7): rotation-compensated parallax, track loss, interval.
  /// With the LiDAR, frames with a scan are preferred: they need less parallax, and a frame
  /// without one whose successor is expected to bring a scan tolerates more track loss.
  bool isKeyframe(const VisualFrame& frame, const SE3& T_W_B, bool has_scan) const;
  /// A frame's pose predicted from the last one: the gyro's rotation (a prior of rot_sigma when
  /// the gyro gave one) and the constant velocity (decaying over long gaps); dt since the last
  /// frame, s.
  struct Prediction {
    SE3 T_W_B = SE3::Identity();
    double dt = 0.0;
    double rot_sigma = 0.0;
    bool rotation_prior = false;
  };
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
  /// Adds a keyframe's LiDAR associations (as they stand when it leaves the window) to stats.
  static void countLidar(const Keyframe& kf, EstimatorStats& stats);
  void recordFrame(const FrameEstimate& e, int ref_kf);
  void refineAll();
  std::vector<Keyframe*> windowKeyframes();

  SensorSetup setup_;
  WindowOptions options_;
  WindowModel model_;
  GroundPlaneOptions ground_options_;
  GroundPlaneOptions label_ground_options_;  // the keyframes' planes for camera-height factors
  std::unique_ptr<frontend::RelativePoseEstimator> relpose_;
  // Before initialisation, with a camera height: the positions, chained over short baselines.
  std::optional<GroundChain> ground_chain_;
  bool use_gyro_ = true;
  bool use_lidar_ = true;

  GyroBuffer gyro_;
  std::vector<LidarScan> scans_;  // recent scans (and all of them before initialisation)

  WindowMap map_;
  WindowGauge gauge_;
  bool initialized_ = false;
  int next_kf_id_ = 0;
  int segment_ = 0;
  // The bias estimate when the window was reset after a loss, and the time of its keyframe: the
  // next segment starts from it instead of the loose first-start prior.
  std::optional<std::pair<Timestamp, Vec3>> carried_bias_;
  bool lidar_scale_ = false;  // the current segment's scale came from the LiDAR
  // Initialisations put off in a row for an ambiguous or missing scale; at the limit the ground
  // plane is used, and without a scale the reference restarts.
  static constexpr int kMaxScaleDeferrals = 20;
  int scale_deferrals_ = 0;
  // Since when no initialisation found a scale (with a scale sensor; a standstill restarts it):
  // references restart for up to kMaxScaleWaitS of motion before a unit baseline is accepted.
  static constexpr double kMaxScaleWaitS = 2.0;
  static constexpr int kMinReferenceTracks =
      20;  // shared tracks to measure a pose before initialisation
  std::optional<Timestamp> scale_wait_since_;

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
  /// The first moving frame after still ones (at t_ns): closes the streak.
  void endStandstill(Timestamp t_ns);
  // A bias sigma after dt_s of random walk: sqrt(sigma^2 + walk^2 dt).
  double walkedBiasSigma(double sigma_radps, double dt_s) const;

  // Initialisation reference.
  struct Reference {
    Timestamp t_ns = 0;
    SE3 T_W_B = SE3::Identity();
    std::unordered_map<TrackId, TrackObservation> obs;
    int frame_index = 0;
    // Frames since the reference (record index, their sightings of the reference's tracks):
    // refined against the first landmarks once the window initialises.
    std::vector<std::pair<int, std::vector<TrackObservation>>> pending;
    /// Adds the frame's sightings of the reference's tracks to `pending`.
    void keepSightings(int frame_record, const VisualFrame& frame);
    /// The bearings of the tracks the frame shares with the reference: b0 here, b1 in the frame
    /// (and their ids when asked for), in the frame's order.
    void sharedBearings(const VisualFrame& frame, std::vector<Vec3>* b0, std::vector<Vec3>* b1,
                        std::vector<TrackId>* ids = nullptr) const;
  };
  std::optional<Reference> reference_;
  Reference makeReference(const VisualFrame& frame, const SE3& T_W_B) const;
  // The last still frame (while initialised) as a two-view reference at its held pose, with the
  // frames since: the window restarts there when the tracks no longer fit its landmarks within
  // kStillRestartS of the standstill's end (they crept while the robot stood).
  std::optional<Reference> still_reference_;
  static constexpr double kStillRestartS = 1.0;

  std::vector<FrameRecord> frames_;
  struct KeyframePoses {
    SE3 vision, body;  // Keyframe::pose, Keyframe::bodyPose
  };
  // Keyframe id -> its poses when it left the window (or at the end).
  std::map<int, KeyframePoses> kf_poses_;
  void keepPoses(const Keyframe& kf) { kf_poses_[kf.id] = {kf.pose(), kf.bodyPose()}; }
  std::map<int, Timestamp> kf_times_;
  std::vector<std::pair<Timestamp, Vec3>> bias_history_;
  EstimatorStats stats_;
  WindowSolveInfo last_solve_;
  bool in_gap_ = false;
  bool finished_ = false;
};

}  // namespace ovo::estimator
