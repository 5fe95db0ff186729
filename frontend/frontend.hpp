// The fisheye frontend of one camera (DESIGN section 4): per frame it detects libviso2-style
// features inside the camera's valid area, matches them with the previous frame (optionally guided
// by a gyro rotation prior), continues tracks, and estimates the relative pose with RANSAC.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "camera/camera.hpp"
#include "common/config.hpp"
#include "common/types.hpp"
#include "frontend/features.hpp"
#include "frontend/matcher.hpp"
#include "frontend/relative_pose.hpp"
#include "frontend/track_refine.hpp"
#include "frontend/tracker.hpp"

namespace ovo::frontend {

struct FrontendOptions {
  DetectorOptions detector;  // frontend.nms_n, nms_n_sparse, nms_tau, margin_px,
                             // bin_size_px, bin_max_features, half_resolution
  MatcherOptions
      matcher;  // frontend.search_radius_px, search_radius_predicted_px,
                // sparse_pass, flow_margin_px, max_cost_ratio, subpixel,
                // max_refine_steps, min_cost_contrast,
                // max_queries_per_bin, delaunay_filter, delaunay_flow_tol_px, delaunay_min_support
  TrackerOptions tracker;                // frontend.max_track_history
  RelativePoseOptions relative_pose;     // ransac.* (readRelativePoseOptions)
  int mask_border_px = 8;                // features at least this far inside the valid area (px)
  int bucket_size_px = 50;               // bucketing cell (px)
  int bucket_max_matches = 4;            // matches per cell passed to RANSAC (0 = all)
  bool use_rotation_prior = true;        // use R_cur_prev priors given to process()
  bool break_tracks_on_outliers = true;  // a RANSAC outlier does not continue its track
  // ... nor does any match (bucketed or not) further than this from the frame's epipolar geometry
  // (angle on the sphere, rad; 0 = off). 1e-3 halves the tracks that jump to a neighbouring
  // feature, but the window estimator did better with the longer tracks: off by default.
  double track_epipolar_gate_rad = 0.0;
  // Lucas-Kanade step of every continued track (frontend.track_refine*): it lowers the ground
  // tracks' drift; why it is on, and with which patch: track_refine.hpp.
  TrackRefineOptions track_refine;
  bool operator==(const FrontendOptions&) const = default;
};
/// Reads the keys under "frontend." (names in the field comments above) and "ransac.".
FrontendOptions readFrontendOptions(const Config& cfg);

/// The matches between the previous and the current frame that went into the relative pose.
struct FrameMatches {
  std::vector<Vec3> bearings_prev, bearings_cur;  // unit, camera frame
  std::vector<Vec2> px_prev, px_cur;              // full-resolution pixels
  std::vector<std::uint64_t> track_ids;           // track of the current feature
  std::size_t size() const { return px_cur.size(); }
};

/// Time of the stages of one process() call (milliseconds).
struct FrontendTimings {
  double filter_ms = 0.0;
  double nms_ms = 0.0;     // NMS, binning and descriptors
  double match_ms = 0.0;   // prediction, matching, sub-pixel, Delaunay, bucketing
  double ransac_ms = 0.0;  // relative pose
  double track_ms = 0.0;   // bearings and track bookkeeping
  double total_ms = 0.0;
};

struct FrontendResult {
  std::int64_t frame_index = 0;
  Timestamp t_ns = 0;
  int num_features = 0;
  std::vector<FeatureObservation> observations;     // every current feature with its track
  FrameMatches matches;                             // empty on the first frame
  std::optional<RelativePoseResult> relative_pose;  // absent on the first frame
  MatchStats match_stats;
  int num_matches_before_bucketing = 0;
  FrontendTimings timings;      // wall time
  FrontendTimings cpu_timings;  // CPU time of the calling thread (RANSAC worker threads excluded)
};

/// Owns the camera, its mask, the matcher, the tracks and the RANSAC. Not thread-safe.
class Frontend {
 public:
  Frontend(const camera::Camera& camera, const FrontendOptions& options);

  /// Processes the next grey image (CV_8UC1 of the camera's size; throws ovo::Error otherwise).
  /// R_cur_prev_prior: the rotation from the previous to the current camera frame (e.g. from
  /// the gyro); shifts each feature's search window to its predicted pixel.
  FrontendResult process(Timestamp t_ns, const cv::Mat& grey,
                         const std::optional<Mat3>& R_cur_prev_prior = std::nullopt);

  const camera::Camera& camera() const { return camera_; }
  const cv::Mat& mask() const { return mask_; }
  const TrackManager& tracks() const { return tracker_; }
  const FrontendOptions& options() const { return options_; }
  /// Forgets the previous frame and every track (e.g. after tracking loss).
  void reset();

 private:
  Vec3 bearingOf(const Vec2& px) const;
  void featureBearings(const FeatureFrame& frame, std::vector<Vec3>* bearings) const;
  void predict(const Mat3& R_cur_prev, MatchPrediction* prediction) const;

  camera::Camera camera_;
  FrontendOptions options_;
  cv::Mat mask_;
  std::vector<float> bearing_table_;
  Matcher matcher_;
  TrackManager tracker_;
  RelativePoseEstimator relative_pose_;
  TrackStepRefiner step_refiner_;
  FeatureFrame prev_, cur_;
  // Bearing of each feature's detected pixel (FeatureFrame::pixel(i)), looked up once per frame
  // when a rotation prior needs them (empty otherwise).
  std::vector<Vec3> prev_feature_bearing_, cur_feature_bearing_;
  bool has_prev_ = false;
  std::int64_t frame_index_ = -1;
  std::vector<Vec2> prev_px_;       // observation pixel of each previous feature
  std::vector<Vec3> prev_bearing_;  // and its bearing
  cv::Mat prev_grey_;               // the previous image (kept when track_refine is on)
};

}  // namespace ovo::frontend
