// The interface every estimator (vo, kf, window) implements. Measurements come in by calls in
// time order; poses come back by return value. An image goes through two stages: track() (the
// frontend) and update() (the estimator), so that an online runner can run them on two threads;
// addImage() is both in sequence. No threads, files or command line here (DESIGN section 1).
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "camera/camera.hpp"
#include "common/config.hpp"
#include "common/types.hpp"

namespace ovo::estimator {

/// The body's up axis (B: x forward, y left, z up) in the frame of a sensor mounted at T_B_S.
inline Vec3 bodyUpIn(const SE3& T_B_S) { return T_B_S.linear().transpose() * Vec3::UnitZ(); }

/// What the estimator knows about the sensors: camera model, extrinsics and noise figures.
struct SensorSetup {
  camera::Camera camera;
  SE3 T_B_C = SE3::Identity();  // camera -> body
  SE3 T_B_L = SE3::Identity();  // LiDAR -> body
  double camera_rate_hz = 20.0;
  double pixel_sigma = 0.5;                              // px, image measurement noise
  std::optional<double> camera_height_m = std::nullopt;  // above the ground, for ground-plane scale
  double time_offset_s = 0.0;          // image stamp = gyro-clock time + this (rig.yaml prior), s
  double rolling_shutter_s = 0.0;      // rows read out top to bottom over this (0: global), s
  double gyro_noise_density = 1.7e-4;  // rad/s/sqrt(Hz)
  double gyro_bias_random_walk = 2.0e-5;  // rad/s^2/sqrt(Hz)
  double lidar_range_sigma_m = 0.02;
  bool has_gyro = false;
  bool has_lidar = false;
};

/// A feature tracked into the current image, for viewers: its track id, pixel and age in frames.
struct TrackPx {
  std::uint64_t id = 0;
  Vec2 px = Vec2::Zero();
  int age = 1;  // frames the track has lived, including this one
};

/// The result for one camera frame.
struct FrameEstimate {
  Timestamp t_ns = 0;
  SE3 T_W_B = SE3::Identity();
  bool tracked = false;  // false: pose held or propagated (lost, standstill without vision)
  bool is_keyframe = false;
  Vec3 gyro_bias = Vec3::Zero();    // current estimate, rad/s
  double scale_source_lidar = 0.0;  // 1 when this frame's scale came from the LiDAR, 0 otherwise
  std::string status;  // short reason when not tracked ("low_parallax", "too_few_matches", ...)
  double frontend_ms = 0.0;
  double estimator_ms = 0.0;
  std::vector<TrackPx> tracks;  // optional (viewer): features of this image on tracks of age >= 2
};

/// Frees a kept estimate's tracks (clear() keeps their memory, which made a run's resident memory
/// grow with its length).
inline void dropTracks(FrameEstimate& f) { std::vector<TrackPx>().swap(f.tracks); }

/// Wall time since t0 in milliseconds (FrameEstimate::frontend_ms / estimator_ms).
inline double msSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

/// The order measurements reach an estimator (the offline runner, the tests, the replay into the
/// online pipeline): before an image, the gyro up to and including the first sample at or after
/// t_until, and the scans up to t_until, where t_until is the estimator's
/// measurementsUntil(image time) (the image time itself but for a camera found to run early).
/// next_imu / next_scan are cursors into imu / scans; sink is anything with addGyro and addScan
/// (an Estimator, WindowCore, the OnlinePipeline).
template <typename Sink>
void feedUntilImage(Timestamp t_until, const std::vector<ImuSample>& imu, std::size_t& next_imu,
                    const std::vector<LidarScan>& scans, std::size_t& next_scan, Sink& sink) {
  while (next_imu < imu.size()) {
    const bool past = imu[next_imu].t_ns >= t_until;
    sink.addGyro(imu[next_imu++]);
    if (past) break;
  }
  while (next_scan < scans.size() && scans[next_scan].t_ns <= t_until)
    sink.addScan(scans[next_scan++]);
}

/// What a full refinement (window --refine full, estimator/window/refine.hpp) did: its problem's
/// size, passes and costs (metrics.json "refine").
struct RefineInfo {
  int keyframes = 0;
  int landmarks = 0;         // landmark pieces with factors
  int bearing_factors = 0;   // in the last pass
  int lidar_factors = 0;     // in the last pass
  int ground_factors = 0;    // in the last pass
  int removed_outliers = 0;  // bearing observations and LiDAR associations, all passes
  int passes = 0;
  int iterations = 0;         // all passes
  double initial_cost = 0.0;  // first pass
  double final_cost = 0.0;    // last pass
  bool usable = false;        // every pass gave finite states (else the online poses are kept)
  std::string message;        // the last pass's solver message
};

/// How well the window's LiDAR range factors fit at the end (metrics.json "lidar_residuals"):
/// each range association (not the ground-plane ones) of each keyframe, measured against the
/// landmark's point as the window last estimated it, when the keyframe left the window (or at the
/// end). Turning: keyframes whose gyro turned faster than turning_deg_s since the previous one,
/// where an undeskewed sweep misplaces the beams most.
struct LidarResidualStats {
  static constexpr double kTurningDegS = 10.0;
  double range_sigma_m = 0.0;  // the LiDAR's range noise the residuals compare with, m
  int count = 0;
  double sum_sq_m2 = 0.0;  // sum of (predicted - measured range)^2, m^2
  int rejected = 0;        // associations removed as outliers (not in the sums)
  int turning_count = 0;
  double turning_sum_sq_m2 = 0.0;
  int turning_rejected = 0;
  double rmsM() const;  // 0 without residuals
  double turningRmsM() const;
};

/// Counters an estimator reports at the end of a run (merged into metrics.json).
struct EstimatorStats {
  int frames = 0;
  int frames_tracked = 0;
  int keyframes = 0;
  int lidar_scale_frames = 0;   // frames whose scale came from the LiDAR
  int ground_scale_frames = 0;  // frames that fell back to the ground-plane scale
  int lidar_keyframes = 0;      // window: keyframes with at least one LiDAR range factor
  int lidar_ranges = 0;         // window: LiDAR range factors over all keyframes
  int gyro_gaps = 0;
  int tracking_losses = 0;
  // window: keyframe solves that failed (Ceres failed, or a state came out non-finite; the
  // window's states were restored to their values before the solve) and marginalisations that
  // failed (the window's gauge then held by a pose prior on its oldest keyframe).
  int solve_failures = 0;
  int marginalization_failures = 0;
  std::vector<std::string> notes;    // fallbacks said once ("no gyro: vision-only rotation", ...)
  std::optional<RefineInfo> refine;  // window --refine full: the final batch
  // window: the camera-gyro time offset it estimated on top of the rig's (image stamp minus the
  // gyro clock's time of the image), s; none when it holds the rig's value.
  std::optional<double> time_offset_s;
  // window: the correction of the rig's camera height it estimated (the ground points it sees
  // lie this much further below the camera than the rig's height), m; none when not estimated.
  std::optional<double> camera_height_offset_m;
  // window with window.camera_height_path: each keyframe's correction as it left the window (the
  // last ones as they stand), in keyframe order, m; empty otherwise.
  std::vector<double> camera_height_path_m;
  // ... and its standard deviation along the path at the end (estimated or as set), m.
  std::optional<double> camera_height_path_sigma_m;
  // window: the LiDAR range factors' residuals; none without LiDAR ranges.
  std::optional<LidarResidualStats> lidar_residuals;
};

/// The frontend stage's result for one image, handed to the estimator stage. A self-contained
/// snapshot: the frontend may already be tracking the next image while update() reads it. Each
/// estimator derives its own (vo/kf: the chain step, window: the tracked bearings).
struct FrontendFrame {
  virtual ~FrontendFrame() = default;
  Timestamp t_ns = 0;
  double frontend_ms = 0.0;     // wall time of track()
  std::vector<TrackPx> tracks;  // features of this image on tracks of age >= 2 (viewers)
};

/// How far the frontend stage may run ahead of the estimator stage without changing the poses:
/// track(k)'s gyro prior uses the bias that update(k - 1 - kFrontendLeadFrames) published
/// (estimator::FrontendGyro), so a runner that starts track(k) once that update is done gets the
/// poses of the two stages run in sequence. Eight frames let the frontend go on through a
/// keyframe's solve (tens of ms). A bias 0.4 s older (at 20 Hz) moves the matching prior's
/// prediction by a small fraction of a pixel.
inline constexpr int kFrontendLeadFrames = 8;

/// Threads: track() and addFrontendGyro() touch only frontend state and may run on one thread
/// while update(), addEstimatorGyro(), addScan() and the rest run on another; addFrontendGyro()
/// may be called from any thread. Each stage sees its own calls in time order.
class Estimator {
 public:
  virtual ~Estimator() = default;
  virtual std::string name() const = 0;

  /// Frontend stage: detection, matching, tracks and relative pose of one grey image (CV_8UC1),
  /// with the gyro rotation prior from the samples given to addFrontendGyro() and the bias the
  /// estimator stage published kFrontendLeadFrames + 1 frames before.
  virtual std::unique_ptr<FrontendFrame> track(Timestamp t_ns, const cv::Mat& grey) = 0;
  /// Estimator stage: the body pose at the time of a frame from this estimator's track() (frames
  /// in the order they were tracked). Throws ovo::Error for a frame of another estimator.
  virtual FrameEstimate update(std::unique_ptr<FrontendFrame> frame) = 0;
  /// Both stages in sequence (the offline runner).
  FrameEstimate addImage(Timestamp t_ns, const cv::Mat& grey) { return update(track(t_ns, grey)); }

  /// Frontend stage's gyro (the matching prior); thread-safe, may run ahead of the estimator.
  virtual void addFrontendGyro(const ImuSample& /*sample*/) {}
  /// Estimator stage's gyro, before the frames whose time the sample precedes.
  virtual void addEstimatorGyro(const ImuSample& sample) = 0;
  /// Both stages (sequential use).
  void addGyro(const ImuSample& sample) {
    addFrontendGyro(sample);
    addEstimatorGyro(sample);
  }
  /// Estimator stage.
  virtual void addScan(const LidarScan& scan) = 0;
  /// The gyro-clock time up to which the gyro and the scans should reach the estimator stage
  /// before the image stamped t_image: t_image, or later when the estimator has found that the
  /// camera's stamps run early (a negative time offset on top of the rig's): the image was
  /// exposed after its stamp, and the gyro up to that instant and its scan belong before it.
  virtual Timestamp measurementsUntil(Timestamp t_image) const { return t_image; }

  /// false: trajectory(), keyframes() and biasHistory() hold only the recent past (what the
  /// estimator may still change), so that memory stays flat over hours; for a long online run
  /// that takes its poses from update(). true (the default): every frame's. Call before the
  /// first frame.
  virtual void keepHistory(bool /*keep*/) {}
  /// Called once after the last measurement (offline refinement may change earlier poses).
  virtual void finish() {}
  /// Final poses of all frames (after finish(); may differ from what update() returned).
  virtual Trajectory trajectory() const = 0;
  /// Keyframe poses (empty for estimators without keyframes).
  virtual Trajectory keyframes() const { return {}; }
  virtual EstimatorStats stats() const = 0;
  /// Gyro bias estimate over time (for reports), empty when not estimated.
  virtual std::vector<std::pair<Timestamp, Vec3>> biasHistory() const { return {}; }
};

/// For keepHistory(false): drops the entries of a time-ordered history (time_of(entry) gives an
/// entry's stamp) older than keep_from_ns, in batches once they are half of it, so that a vector
/// costs O(1) a call on average and never holds more than twice what is kept.
template <typename History, typename TimeOf>
void trimHistory(History& history, Timestamp keep_from_ns, TimeOf time_of) {
  auto first_kept = history.begin();
  while (first_kept != history.end() && time_of(*first_kept) < keep_from_ns) ++first_kept;
  const auto dropped = first_kept - history.begin();
  if (dropped > 0 && 2 * dropped >= static_cast<decltype(dropped)>(history.size()))
    history.erase(history.begin(), first_kept);
}

/// How much of the past vo and kf keep without the history: what they look back to (the chain's
/// reference frames, the LiDAR baseline) with room to spare.
inline constexpr double kRecentHistoryS = 10.0;

/// Throws the ovo::Error of frontendFrameAs().
[[noreturn]] void failFrontendFrame(const char* estimator, bool non_null);

/// The estimator's own FrontendFrame type out of update()'s argument; throws ovo::Error when the
/// frame is null or came from another estimator (a caller's mistake).
template <typename Frame>
std::unique_ptr<Frame> frontendFrameAs(std::unique_ptr<FrontendFrame> frame,
                                       const char* estimator) {
  auto* typed = dynamic_cast<Frame*>(frame.get());
  if (!typed) failFrontendFrame(estimator, frame != nullptr);
  frame.release();
  return std::unique_ptr<Frame>(typed);
}

/// Raises the rig's noise figures to the floors the estimators can weigh (pixel 0.05 px, gyro
/// noise 1e-6 rad/s/sqrt(Hz), bias walk 1e-7 rad/s^2/sqrt(Hz), LiDAR range 1 mm): a figure of 0,
/// as a noise-free simulation writes, would give its factors infinite weight (NaN in the solver).
/// Returns one note per figure raised.
std::vector<std::string> applyNoiseFloors(SensorSetup& setup);

/// Creates "vo", "kf" or "window" from the configuration (throws ovo::Error for unknown names).
std::unique_ptr<Estimator> makeEstimator(const std::string& name, const SensorSetup& setup,
                                         const Config& config);

/// True when the estimator makeEstimator(name, ..., config) would use the LiDAR's scans given a
/// dataset that has them: kf and window unless their use_lidar is false; vo (the plain camera
/// chain) and unknown names never. Callers set up what only a LiDAR user needs (the camera height
/// measured from the scans) before creating the estimator.
bool estimatorUsesLidar(const std::string& name, const Config& config);

}  // namespace ovo::estimator
