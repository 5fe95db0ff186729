#include "factors/terrain_plane_factor.hpp"

#include <algorithm>
#include <cmath>

#include "common/so3.hpp"
#include "factors/parameterization.hpp"

namespace ovo::factors {
namespace {

/// p's offset over the plane g along z (e) and the length of g's normal (a, b, -1) (norm): the
/// height over the plane is e / norm.
struct TerrainOffset {
  double e, norm;
};

TerrainOffset terrainOffset(const Vec3& p, const double* g) {
  return {p.z() - g[0] * p.x() - g[1] * p.y() - g[2], std::sqrt(1.0 + g[0] * g[0] + g[1] * g[1])};
}

}  // namespace

double heightOverTerrain(const Vec3& p, const double* g) {
  const TerrainOffset o = terrainOffset(p, g);
  return o.e / o.norm;
}

void terrainBelow(const SE3& T_W_B, const SE3& T_B_C, double camera_height_m, double* g) {
  Vec3 up = T_W_B.linear().col(2);
  if (up.z() < 0.1) up = Vec3::UnitZ();  // the body on its side: no plane z = f(x, y) along it
  const Vec3 foot = T_W_B * T_B_C.translation() - camera_height_m * up;
  g[0] = -up.x() / up.z();
  g[1] = -up.y() / up.z();
  g[2] = foot.z() - g[0] * foot.x() - g[1] * foot.y();
}

TerrainScaling terrainScaling(const Vec3& centre, double s) {
  // z' - C_z = s (z - C_z) for every point: the slopes stay, the height at the centre scales,
  // c' = s c + (s - 1) (a C_x + b C_y) + (1 - s) C_z.
  TerrainScaling t{Mat3::Identity(), Vec3::Zero()};
  t.M.row(2) << (s - 1.0) * centre.x(), (s - 1.0) * centre.y(), s;
  t.k.z() = (1.0 - s) * centre.z();
  return t;
}

void scaleTerrain(double* g, const Vec3& centre, double s) {
  const TerrainScaling t = terrainScaling(centre, s);
  Eigen::Map<Vec3> v(g);
  v = (t.M * v + t.k).eval();
}

TerrainPointFactor::TerrainPointFactor(const Vec3& bearing_Ca, const SE3& T_B_C, double sigma_m)
    : dir_B_(T_B_C.rotation() * bearing_Ca.normalized()),
      t_B_C_(T_B_C.translation()),
      inv_sigma_(1.0 / sigma_m) {}

bool TerrainPointFactor::Evaluate(double const* const* parameters, double* residuals,
                                  double** jacobians) const {
  const double* q = parameters[0];
  const Eigen::Map<const Vec3> p(parameters[1]);
  const double rho = parameters[2][0];
  const double* g = parameters[3];
  if (!(rho > 1e-6)) return false;
  const Mat3 R = quatFromBlock(q).toRotationMatrix();
  const Vec3 Ru = R * (dir_B_ / rho + t_B_C_);
  const Vec3 p_W = Ru + p;
  const auto [e, norm] = terrainOffset(p_W, g);
  residuals[0] = e / norm * inv_sigma_;
  if (!jacobians) return true;
  const Eigen::RowVector3d dr_dpW = Eigen::RowVector3d(-g[0], -g[1], 1.0) * (inv_sigma_ / norm);
  if (jacobians[0]) {
    const Eigen::RowVector3d J_theta = dr_dpW * (-so3::hat(Ru));
    rotationJacobianToAmbient<1>(J_theta, q, jacobians[0]);
  }
  if (jacobians[1]) Eigen::Map<Eigen::RowVector3d>{jacobians[1]} = dr_dpW;
  if (jacobians[2]) jacobians[2][0] = -dr_dpW.dot(R * dir_B_) / (rho * rho);
  if (jacobians[3]) {
    const double k = inv_sigma_ / norm;
    const double e_n2 = e / (norm * norm);
    jacobians[3][0] = k * (-p_W.x() - e_n2 * g[0]);
    jacobians[3][1] = k * (-p_W.y() - e_n2 * g[1]);
    jacobians[3][2] = -k;
  }
  return true;
}

TerrainWalkFactor::TerrainWalkFactor(const Vec3& midpoint_W, double distance_m, double slope_walk,
                                     double height_walk) {
  const double root_d = std::sqrt(std::max(distance_m, 0.05));
  const double is = 1.0 / (slope_walk * root_d), ih = 1.0 / (height_walk * root_d);
  J_ << is, 0.0, 0.0, 0.0, is, 0.0, midpoint_W.x() * ih, midpoint_W.y() * ih, ih;
}

bool TerrainWalkFactor::Evaluate(double const* const* parameters, double* residuals,
                                 double** jacobians) const {
  const Eigen::Map<const Vec3> gi(parameters[0]), gj(parameters[1]);
  Eigen::Map<Vec3>{residuals} = J_ * (gj - gi);
  if (!jacobians) return true;
  using RowMat3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
  if (jacobians[0]) Eigen::Map<RowMat3>{jacobians[0]} = -J_;
  if (jacobians[1]) Eigen::Map<RowMat3>{jacobians[1]} = J_;
  return true;
}

}  // namespace ovo::factors
