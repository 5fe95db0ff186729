// The Kalman-filter baseline's metric scale from a planar LiDAR (DESIGN section 7): scan
// points projected into the image are associated with triangulated features, and the scale of the
// unit-scale two-view reconstruction is a robust mean of LiDAR range over feature range.
//
// Model: a feature's unit-scale point X_unit (current camera frame C, from the two-view solution
// with |t| = 1) and a LiDAR beam end point p_C = T_C_L p_L that lands within a pixel radius of the
// feature see the same surface, so metric = scale * unit along that bearing:
//   s_i = |p_C| / |X_unit|                       (ranges from the camera centre)
//   beams on depth edges are skipped first (a feature is usually an edge in the image, where a
//   beam a pixel off may hit the foreground or the background: the see-through canopy)
//   m = median(s_i); keep |s_i - m| <= gate m    (a canopy point in front of a far trunk is close
//                                                 in the image but not in depth)
//   scale = Huber mean of the kept s_i around m (threshold huber_k * 1.4826 MAD).
//
// Along tracks (estimateLidarScaleCorrection): a one-frame baseline makes X_unit noisy (a few
// pixels of parallax) and skews s_i, so the kf baseline instead checks its own trajectory over a
// longer baseline. The beam end point p_C is metric in the current camera; the feature's bearing b
// in an older camera must see it after the true motion X_old = R_old_cur p_C + kappa t_old_cur,
// where (R, t) is the estimated motion and kappa the factor by which its translation is too short.
// The beam lands a pixel or two off the feature, an angle comparable to the parallax, so the point
// X_C is taken where the feature's own current bearing b_c meets the surface the beam hit (a
// vertical plane along the scan: canopy, trunks and posts; ground beams are skipped), and
//   b x (R X_C + kappa t) = 0  =>  kappa_i = -(b x t).(b x R X_C) / |b x t|^2  (least squares)
// then the same gate and Huber mean over the kappa_i.
#pragma once

#include <optional>
#include <vector>

#include "camera/camera.hpp"
#include "common/config.hpp"
#include "common/types.hpp"

namespace ovo::estimator {

/// Tuning of estimateLidarScale. Keys under "kf.lidar_scale." (readLidarScaleOptions).
struct LidarScaleOptions {
  double association_radius_px = 5.0;  // scan point to feature, pixels
  int min_associations = 5;            // fewer kept samples: no estimate
  double gate_relative = 0.2;          // keep samples within this fraction of the median
  double huber_k = 1.5;                // Huber threshold in robust standard deviations
  double min_range_m = 0.2;            // scan points closer to the camera centre are skipped, m
  double min_parallax_deg = 1.0;       // along tracks: angle between the old and current ray, deg
  double edge_relative = 0.05;  // beams whose neighbours' ranges differ by more than this fraction
                                // (depth edges: leaf in front of a gap) are skipped; 0: off
  bool operator==(const LidarScaleOptions&) const = default;
};

LidarScaleOptions readLidarScaleOptions(const Config& config);

/// A tracked feature in the current image: its pixel and its unit-scale triangulated point in C.
struct ScaleFeature {
  Vec2 px;
  Vec3 p_C_unit;
};

/// The scale (metric = scale * unit), how many associations agreed, how many the gate rejected,
/// and the robust standard deviation of the kept samples (same unit as scale).
struct ScaleEstimate {
  double scale = 1.0;
  int associations = 0;
  int rejected = 0;
  double spread = 0.0;
};

/// T_C_L from the rig extrinsics: T_B_C^-1 T_B_L.
inline SE3 cameraFromLidar(const SE3& T_B_C, const SE3& T_B_L) { return T_B_C.inverse() * T_B_L; }

/// A beam end point p_C (camera frame) on the ground: more than 0.7 camera heights below the
/// camera along up_C (the ground normal). A pitched LiDAR meets the ground at a grazing angle,
/// where the range hangs on the slope and changes fast with elevation: a feature a fraction of a
/// degree off the scan plane reads tens of centimetres off. camera_height_m <= 0: no ground known.
inline bool isGroundBeam(const Vec3& p_C, const Vec3& up_C, double camera_height_m) {
  return camera_height_m > 0.0 && -up_C.dot(p_C) > 0.7 * camera_height_m;
}

/// Associates each scan end point (projected with T_C_L into cam) with the nearest feature within
/// the radius (one scan point per feature: the closest in the image) and returns the robust scale,
/// or nullopt when fewer than min_associations survive the gate. The scan should be the one
/// nearest the image time (no motion compensation here).
std::optional<ScaleEstimate> estimateLidarScale(const LidarScan& scan, const SE3& T_C_L,
                                                const camera::Camera& cam,
                                                const std::vector<ScaleFeature>& features,
                                                const LidarScaleOptions& options = {});

/// A feature of the current image also seen in an older frame: its pixel and bearing now, its
/// bearing in the older camera, and the estimated motion X_old = R_old_cur X_cur + t_old_cur (t at
/// the estimate's scale, metres).
struct TrackScaleFeature {
  Vec2 px;
  Vec3 bearing_C;      // current camera
  Vec3 bearing_old_C;  // older camera
  Mat3 R_old_cur = Mat3::Identity();
  Vec3 t_old_cur = Vec3::Zero();
};

/// The factor kappa by which the estimated translations are too short (true = kappa * estimated),
/// from scan end points associated with tracked features as in estimateLidarScale (see the model at
/// the top). up_C: the world's up axis in the current camera; camera_height_m tells ground beams
/// from the rest (nullopt: every surface taken as vertical). nullopt when fewer than
/// min_associations survive the gate.
std::optional<ScaleEstimate> estimateLidarScaleCorrection(
    const LidarScan& scan, const SE3& T_C_L, const camera::Camera& cam,
    const std::vector<TrackScaleFeature>& features, const Vec3& up_C,
    std::optional<double> camera_height_m, const LidarScaleOptions& options = {});

}  // namespace ovo::estimator
