// A LiDAR association's noise, residual and outlier gate.
#include "estimator/window/lidar_gate.hpp"

#include <algorithm>
#include <cmath>

#include "factors/lidar_range_factor.hpp"

namespace ovo::estimator {

double lidarSigma(const LidarAssociation& a, const WindowModel& model) {
  if (a.ground_up_L.isZero()) return model.lidar_sigma_m;
  return std::hypot(model.lidar_range_sigma_m * a.ground_sin, model.lidar_ground_sigma_m);
}

std::optional<double> lidarResidualM(const LidarAssociation& a, const Vec3& p_W,
                                     const Keyframe& kf) {
  const SE3 T_L_W = (kf.pose() * kf.T_B_L).inverse();
  const auto value = factors::lidarMeasuredValue(T_L_W * p_W, a.planar, a.ground_up_L);
  if (!value) return std::nullopt;
  return *value - a.range_m;
}

bool lidarOutlier(const LidarAssociation& a, const Vec3& p_W, const Keyframe& kf,
                  const WindowModel& model, double gate_sigmas, double gate_fraction) {
  const auto residual = lidarResidualM(a, p_W, kf);
  if (!residual) return true;  // the landmark sits on the LiDAR
  const double gate_sigma = gate_sigmas * lidarSigma(a, model);
  const double gate =
      a.ground_up_L.isZero() ? std::max(gate_sigma, gate_fraction * a.range_m) : gate_sigma;
  return std::abs(*residual) > gate;
}

}  // namespace ovo::estimator
