// Parameter-block conventions shared by every factor and by the estimator, and the small helpers
// that turn a Jacobian in rotation-vector coordinates into one on Ceres's ambient quaternion.
//
// Blocks (raw double arrays owned by the estimator):
//   q_W_B[4]  keyframe orientation R_W_B, Eigen quaternion storage order (x, y, z, w), manifold
//             ceres::EigenQuaternionManifold (Ceres 2.1 API). Ceres perturbs on the left and in
//             half-angle units: Plus(q, d) = [sin|d| d/|d|, cos|d|] * q, i.e.
//             R_W_B <- Exp(2 d) R_W_B (a rotation about a world-frame axis).
//   p_W_B[3]  keyframe position in W (m), Euclidean.
//   b_g[3]    gyro bias in B (rad/s), Euclidean.
//   rho[1]    landmark inverse depth (1/m) along its unit bearing b_a in the camera frame of its
//             anchor keyframe a; the point is p_Ca = b_a / rho and b_a is a constant of the factor.
//             Why inverse depth and not a 3-D point: a far point (rho -> 0) stays finite and its
//             direction is exact from the first observation, so the estimator can use points at
//             any distance (vine rows, sky line); the fisheye's rays near and beyond 90 degrees
//             off-axis have no usable image-plane depth, while rho along the ray is always defined.
//             Keep rho > 0: the estimator may set a lower bound on the block.
// Rig extrinsics T_B_C and T_B_L are constants held by the factors.
//
// Analytic Jacobians are derived for a world-frame rotation-vector perturbation
// R_W_B <- Exp(theta) R_W_B; since theta = 2 d, the tangent Jacobian is J_d = 2 J_theta, and the
// ambient 4-column Jacobian Ceres asks for is J_d * P^T with P = PlusJacobian(q) (P^T P = I for a
// unit quaternion, so J_ambient * P = J_d exactly).
#pragma once

#include <ceres/manifold.h>

#include <Eigen/Core>

#include "common/types.hpp"

namespace ovo::factors {

constexpr int kQuatSize = 4;     // ambient size of q_W_B
constexpr int kQuatTangent = 3;  // tangent size of q_W_B
constexpr int kPosSize = 3;
constexpr int kBiasSize = 3;
constexpr int kInvDepthSize = 1;

using Mat43 = Eigen::Matrix<double, 4, 3>;
using Mat34 = Eigen::Matrix<double, 3, 4>;

/// The manifold to give q_W_B blocks (AddParameterBlock / SetManifold). Ceres takes ownership of
/// the pointer passed to Problem, so this returns a fresh one each call.
inline ceres::Manifold* newQuaternionManifold() { return new ceres::EigenQuaternionManifold(); }

/// Quaternion block (x, y, z, w) as an Eigen rotation; the block need not be exactly unit.
inline Quat quatFromBlock(const double* q) { return Quat(q[3], q[0], q[1], q[2]).normalized(); }
inline void quatToBlock(const Quat& q, double* block) {
  block[0] = q.x();
  block[1] = q.y();
  block[2] = q.z();
  block[3] = q.w();
}

/// PlusJacobian of ceres::EigenQuaternionManifold at q (x, y, z, w): d(Plus(q, d))/dd at d = 0.
/// Top 3x3 = w I - [v]x, bottom row = -v^T (v = vector part).
inline Mat43 quaternionPlusJacobian(const double* q) {
  Mat43 P;
  P << q[3], q[2], -q[1],  //
      -q[2], q[3], q[0],   //
      q[1], -q[0], q[3],   //
      -q[0], -q[1], -q[2];
  return P;
}

/// Maps an m x 3 Jacobian w.r.t. the world-frame rotation vector theta (R <- Exp(theta) R) to the
/// m x 4 ambient Jacobian for an EigenQuaternionManifold block at q, written row-major into out.
template <int Rows>
inline void rotationJacobianToAmbient(const Eigen::Matrix<double, Rows, 3>& J_theta,
                                      const double* q, double* out) {
  Eigen::Map<Eigen::Matrix<double, Rows, 4, Eigen::RowMajor>> J(out);
  J = 2.0 * J_theta * quaternionPlusJacobian(q).transpose();
}

}  // namespace ovo::factors
