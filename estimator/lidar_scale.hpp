// The Kalman-filter baseline's metric scale from a planar LiDAR (DESIGN section 7, issue 6): scan
// points projected into the image are associated with triangulated features, and the scale of the
// unit-scale two-view reconstruction is a robust mean of LiDAR range over feature range.
//
// Model: a feature's unit-scale point X_unit (current camera frame C, from the two-view solution
// with |t| = 1) and a LiDAR beam end point p_C = T_C_L p_L that lands within a pixel radius of the
// feature see the same surface, so metric = scale * unit along that bearing:
//   s_i = |p_C| / |X_unit|                       (ranges from the camera centre)
//   m = median(s_i); keep |s_i - m| <= gate m    (a canopy point in front of a far trunk is close
//                                                 in the image but not in depth)
//   scale = Huber mean of the kept s_i around m (threshold huber_k * 1.4826 MAD).
#pragma once

#include <optional>
#include <vector>

#include "camera/camera.hpp"
#include "common/config.hpp"
#include "common/types.hpp"

namespace ovo::estimator {

/// Tuning of estimateLidarScale. Keys under "kf.lidar_scale." (readLidarScaleOptions).
struct LidarScaleOptions {
  double association_radius_px = 3.0;  // scan point to feature, pixels
  int min_associations = 5;            // fewer kept samples: no estimate
  double gate_relative = 0.2;          // keep samples within this fraction of the median
  double huber_k = 1.5;                // Huber threshold in robust standard deviations
  double min_range_m = 0.2;            // scan points closer to the camera centre are skipped, m
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

/// Associates each scan end point (projected with T_C_L into cam) with the nearest feature within
/// the radius (one scan point per feature: the closest in the image) and returns the robust scale,
/// or nullopt when fewer than min_associations survive the gate. The scan should be the one
/// nearest the image time (no motion compensation here).
std::optional<ScaleEstimate> estimateLidarScale(const LidarScan& scan, const SE3& T_C_L,
                                                const camera::Camera& cam,
                                                const std::vector<ScaleFeature>& features,
                                                const LidarScaleOptions& options = {});

}  // namespace ovo::estimator
