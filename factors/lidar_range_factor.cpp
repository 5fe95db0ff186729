#include "factors/lidar_range_factor.hpp"

#include "common/so3.hpp"

namespace ovo::factors {

namespace {
constexpr double kMinInverseDepth = 1e-6;  // 1/m: 1000 km
constexpr double kMinDistance = 1e-9;      // m
}  // namespace

std::optional<double> lidarMeasuredValue(Vec3 p_L, bool planar, const Vec3& ground_up_L,
                                         Eigen::RowVector3d* grad) {
  if (!ground_up_L.isZero()) {
    if (grad) *grad = ground_up_L.transpose();
    return ground_up_L.dot(p_L);
  }
  if (planar) p_L.z() = 0.0;  // the distance in the scan plane; its gradient has no z part
  const double d = p_L.norm();
  if (!(d > kMinDistance)) return std::nullopt;
  if (grad) *grad = (p_L / d).transpose();
  return d;
}

LidarRangeFactor::LidarRangeFactor(const Vec3& bearing_Ca, double range_m, const SE3& T_B_C,
                                   const SE3& T_B_L, double sigma_m, bool planar,
                                   const Vec3& ground_up_L)
    : bearing_Ca_(bearing_Ca.normalized()),
      range_m_(range_m),
      inv_sigma_(1.0 / sigma_m),
      R_B_C_(T_B_C.rotation()),
      R_L_B_(T_B_L.rotation().transpose()),
      t_B_C_(T_B_C.translation()),
      t_B_L_(T_B_L.translation()),
      planar_(planar),
      ground_up_L_(ground_up_L) {}

bool LidarRangeFactor::Evaluate(double const* const* parameters, double* residuals,
                                double** jacobians) const {
  const double* q_a = parameters[0];
  const double* q_k = parameters[2];
  const Eigen::Map<const Vec3> p_a(parameters[1]), p_k(parameters[3]);
  const double rho = parameters[4][0];
  if (!(rho > kMinInverseDepth)) return false;

  const Mat3 R_W_Ba = quatFromBlock(q_a).toRotationMatrix();
  const Mat3 R_W_Bk = quatFromBlock(q_k).toRotationMatrix();
  const Vec3 p_Ba = R_B_C_ * bearing_Ca_ / rho + t_B_C_;
  const Vec3 Rp_W = R_W_Ba * p_Ba;
  const Vec3 p_W = Rp_W + p_a;
  const Mat3 R_L_W = R_L_B_ * R_W_Bk.transpose();
  const Vec3 p_L = R_L_W * (p_W - p_k) - R_L_B_ * t_B_L_;
  Eigen::RowVector3d grad;
  const auto value = lidarMeasuredValue(p_L, planar_, ground_up_L_, &grad);
  if (!value) return false;
  residuals[0] = (*value - range_m_) * inv_sigma_;
  if (!jacobians) return true;

  const Eigen::RowVector3d dr_dpW = inv_sigma_ * grad * R_L_W;  // dr/dp_W
  if (jacobians[0]) {
    const Eigen::RowVector3d J_theta = dr_dpW * (-so3::hat(Rp_W));
    rotationJacobianToAmbient<1>(J_theta, q_a, jacobians[0]);
  }
  if (jacobians[1]) Eigen::Map<Eigen::RowVector3d>{jacobians[1]} = dr_dpW;
  if (jacobians[2]) {
    const Eigen::RowVector3d J_theta = dr_dpW * so3::hat(p_W - p_k);
    rotationJacobianToAmbient<1>(J_theta, q_k, jacobians[2]);
  }
  if (jacobians[3]) Eigen::Map<Eigen::RowVector3d>{jacobians[3]} = -dr_dpW;
  if (jacobians[4]) jacobians[4][0] = -dr_dpW.dot(R_W_Ba * R_B_C_ * bearing_Ca_) / (rho * rho);
  return true;
}

LidarRangeAnchorFactor::LidarRangeAnchorFactor(const Vec3& bearing_Ca, double range_m,
                                               const SE3& T_B_C, const SE3& T_B_L, double sigma_m,
                                               bool planar, const Vec3& ground_up_L)
    : range_m_(range_m), inv_sigma_(1.0 / sigma_m), planar_(planar), ground_up_L_(ground_up_L) {
  const SE3 T_L_C = T_B_L.inverse() * T_B_C;
  bearing_L_ = T_L_C.rotation() * bearing_Ca.normalized();
  t_L_C_ = T_L_C.translation();
}

bool LidarRangeAnchorFactor::Evaluate(double const* const* parameters, double* residuals,
                                      double** jacobians) const {
  const double rho = parameters[0][0];
  if (!(rho > kMinInverseDepth)) return false;
  Eigen::RowVector3d grad;
  const auto value = lidarMeasuredValue(bearing_L_ / rho + t_L_C_, planar_, ground_up_L_, &grad);
  if (!value) return false;
  residuals[0] = (*value - range_m_) * inv_sigma_;
  if (jacobians && jacobians[0])
    jacobians[0][0] = inv_sigma_ * grad.dot(bearing_L_) * (-1.0 / (rho * rho));
  return true;
}

}  // namespace ovo::factors
