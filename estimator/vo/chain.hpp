// Frame-to-frame monocular motion shared by the `vo` chain and the `kf` baseline: the frontend's
// relative pose between consecutive frames, its inliers triangulated at unit baseline, and the
// scale helpers (ground plane; the LiDAR scale lives in lidar_scale.hpp).
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "estimator/common/ground_plane.hpp"
#include "estimator/estimator.hpp"
#include "frontend/frontend.hpp"

namespace ovo::estimator {

/// An earlier sighting of a track (a copy of the frontend's track history).
struct TrackSighting {
  Timestamp t_ns = 0;
  Vec3 bearing_C = Vec3::Zero();
};

/// One frame's motion relative to the chain's reference frame (the previous frame, or an older one
/// kept while the parallax is too small, as libviso2 does), in the camera frame, up to scale.
/// "prev" in the names below is that reference frame.
struct ChainStep {
  frontend::RelativePoseResult::Status status =
      frontend::RelativePoseResult::Status::kTooFewMatches;
  bool first_frame = false;
  Timestamp ref_t_ns = 0;          // time of the reference frame the motion is measured from
  bool reference_advances = true;  // false: low parallax, the next frame is measured from ref too
  Mat3 R_cur_prev = Mat3::Identity();   // camera rotation, X_cur = R X_ref + t
  Vec3 t_cur_prev_unit = Vec3::Zero();  // unit length when status is kOk
  std::vector<Vec3> points_cur_unit;    // inliers triangulated with |t| = 1, current camera frame
  std::vector<Vec2> px_cur;             // their pixels in the current image
  std::vector<Vec3> bearings_prev, bearings_cur;  // the inlier bearing pairs
  std::vector<Vec2> px_all_cur;                   // current pixel of every inlier pair (same order)
  std::vector<std::uint64_t> track_ids;  // frontend track of every inlier pair (same order)
  // Sightings of every inlier track (same order) before this frame and at most
  // VoChain::setHistorySpan() older, oldest first: the estimator stage's copy of the history.
  std::vector<std::vector<TrackSighting>> track_history;
  int matches = 0;
  double frontend_ms = 0.0;
};

struct VoChainOptions {
  int max_reference_frames = 6;  // frames a low-parallax reference is kept at most
  int min_pairs = 12;            // tracked pairs needed to measure from the reference
  int bucket_px = 40;            // pairs are thinned to at most bucket_max per cell of this size
  int bucket_max = 3;            // (oldest tracks first) before RANSAC; 0 = all pairs
  bool operator==(const VoChainOptions&) const = default;
};
VoChainOptions readVoChainOptions(const Config& cfg);  // keys under "vo."

/// The frontend stage's result of the vo and kf estimators: one ChainStep.
struct ChainFrame : FrontendFrame {
  ChainStep step;
};

/// Turns images into ChainSteps, measuring each frame from the reference frame through the
/// frontend's tracks (the reference is kept while the parallax is below ransac.min_parallax_deg).
/// All of it is frontend-stage work: the steps are self-contained snapshots.
class VoChain {
 public:
  VoChain(const camera::Camera& camera, const Config& config);
  /// Processes one image; R_cur_prev_prior (camera frame) helps matching in fast turns.
  ChainStep step(Timestamp t_ns, const cv::Mat& grey,
                 const std::optional<Mat3>& R_cur_prev_prior = std::nullopt);
  /// Copy the inlier tracks' sightings up to this much older than the frame into each step
  /// (ChainStep::track_history); 0 (default): none.
  void setHistorySpan(Timestamp span_ns) { history_span_ns_ = span_ns; }
  /// The features of the last image on tracks of age >= 2 (viewers).
  std::vector<TrackPx> currentTracks() const;
  /// The frontend-stage snapshot of one image for Estimator::track(): step() and the viewer's
  /// tracks; frontend_ms is the wall time since t0 (the start of the caller's track()).
  std::unique_ptr<ChainFrame> track(Timestamp t_ns, const cv::Mat& grey,
                                    const std::optional<Mat3>& R_cur_prev_prior,
                                    std::chrono::steady_clock::time_point t0);
  const frontend::Frontend& frontend() const { return frontend_; }

 private:
  VoChainOptions options_;
  frontend::Frontend frontend_;
  frontend::RelativePoseEstimator relative_pose_;
  std::int64_t ref_frame_ = -1;
  Timestamp ref_t_ns_ = 0;
  Timestamp history_span_ns_ = 0;
};

/// Indices of the pixels kept when at most per_cell are taken per cell_px square of the image, in
/// the given order (the caller puts the preferred ones first).
std::vector<std::size_t> thinToGrid(const std::vector<Vec2>& px, int cell_px, int per_cell);

/// Translation direction for a known rotation: t minimises sum (b_c . (t x R b_p))^2 over the
/// inlier pairs (t is the null vector of the rows (R b_p x b_c)^T), signed so that the points lie
/// in front (positive depth along both bearings). nullopt when degenerate.
std::optional<Vec3> translationGivenRotation(const Mat3& R_cur_prev,
                                             const std::vector<Vec3>& bearings_prev,
                                             const std::vector<Vec3>& bearings_cur);

/// Triangulates the pairs at unit baseline in the current camera frame (points in front only).
void triangulateUnit(const Mat3& R_cur_prev, const Vec3& t_unit,
                     const std::vector<Vec3>& bearings_prev, const std::vector<Vec3>& bearings_cur,
                     std::vector<Vec3>* points_cur, std::vector<std::uint8_t>* valid);

/// Metric scale of a unit-baseline step from the ground plane and the configured camera height.
/// up_C: the body's up axis in the camera frame (R_C_B z_B).
std::optional<double> groundPlaneScale(const ChainStep& step, const Vec3& up_C,
                                       double camera_height_m, const GroundPlaneOptions& options);

/// The pose stamped t_ns in a time-ordered, non-empty sequence of StampedPose (searched from the
/// newest end, where a chain's reference frame is), or the newest pose when no stamp matches.
template <typename Poses>
SE3 poseAtOrNewest(const Poses& poses, Timestamp t_ns) {
  for (auto it = poses.rbegin(); it != poses.rend(); ++it)
    if (it->t_ns == t_ns) return it->T_W_B;
  return poses.back().T_W_B;
}

/// T_W_Bcur from T_W_Bprev and the camera motion (R, t metric), via the rig's T_B_C.
SE3 chainPose(const SE3& T_W_Bprev, const SE3& T_B_C, const Mat3& R_cur_prev,
              const Vec3& t_cur_prev);

}  // namespace ovo::estimator
