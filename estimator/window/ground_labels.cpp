// Labelling ground landmarks from each anchor keyframe's plane, and the agreed height.
#include "estimator/window/ground_labels.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include "common/stats.hpp"

namespace ovo::estimator {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

}  // namespace

std::optional<double> agreedGroundHeight(std::vector<double> heights, int min_keyframes,
                                         double agreement) {
  if (static_cast<int>(heights.size()) < std::max(1, min_keyframes)) return std::nullopt;
  const double median = upperMedian(heights);
  const auto agreeing = std::count_if(heights.begin(), heights.end(), [&](double x) {
    return std::abs(x - median) <= agreement * median;
  });
  if (2 * agreeing <= static_cast<std::ptrdiff_t>(heights.size())) return std::nullopt;
  return median;
}

std::vector<double> labelGroundLandmarks(std::unordered_map<TrackId, Landmark>& landmarks,
                                         const WindowModel& model, const WindowOptions& options,
                                         const GroundPlaneOptions& ground_options) {
  std::vector<double> heights;
  if (!(model.camera_height_m > 0.0)) return heights;
  const double h = model.camera_height_m;
  const Vec3 up_prior_C = bodyUpIn(model.T_B_C);
  const double min_down = std::sin(options.ground_min_depression_deg * kDegToRad);
  std::map<int, std::vector<Landmark*>> by_anchor;  // (in the order of the keyframe ids)
  for (auto& [id, lm] : landmarks)
    if (lm.rho[0] > 1e-6)  // (not the points at infinity)
      by_anchor[lm.anchor_kf].push_back(&lm);
  for (auto& [kf_id, lms] : by_anchor) {
    std::vector<Vec3> points_C;
    for (const Landmark* lm : lms) points_C.push_back(lm->bearing_anchor_C / lm->rho[0]);
    const auto plane = fitGroundPlane(points_C, up_prior_C, ground_options);
    if (plane && plane->height > 0.0) heights.push_back(plane->height);
    const bool plane_ok = plane && std::abs(plane->height - h) <= options.ground_scale_gate * h;
    for (std::size_t k = 0; k < lms.size(); ++k) {
      Landmark& lm = *lms[k];
      const Vec3& p_C = points_C[k];
      if (lm.on_ground) {  // keeps its factor while it stays near the plane it was given
        const double depth_below = -lm.ground_up_C.dot(p_C);
        if (std::abs(depth_below - h) > 2.0 * options.ground_inlier_fraction * h)
          lm.on_ground = false;
        continue;
      }
      if (!plane_ok) continue;
      const double down = -plane->up_C.dot(lm.bearing_anchor_C);
      const double depth_below = -plane->up_C.dot(p_C);
      const double dist = (p_C + depth_below * plane->up_C).norm();  // along the ground
      if (down < min_down || dist > options.ground_max_distance_heights * h ||
          std::abs(depth_below - plane->height) > options.ground_inlier_fraction * h)
        continue;
      lm.on_ground = true;
      lm.ground_up_C = plane->up_C;
    }
  }
  return heights;
}

}  // namespace ovo::estimator
