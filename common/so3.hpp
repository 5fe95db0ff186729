// SO(3) helpers on plain Eigen matrices: hat, Exp, Log and the right Jacobians used by
// gyro preintegration (Forster et al., "On-Manifold Preintegration", TRO 2017, eqs. 1-8).
#pragma once

#include "common/types.hpp"

namespace ovo::so3 {

/// [w]x such that hat(w) * v = w.cross(v).
Mat3 hat(const Vec3& w);
/// Exp: axis-angle vector -> rotation matrix (Rodrigues), exact for small angles too.
Mat3 exp(const Vec3& w);
/// Log: rotation matrix -> axis-angle vector with angle in [0, pi].
Vec3 log(const Mat3& R);
/// Right Jacobian Jr(w): Exp(w + dw) ~ Exp(w) Exp(Jr(w) dw).
Mat3 rightJacobian(const Vec3& w);
/// Inverse of the right Jacobian: Log(Exp(w) Exp(dw)) ~ w + Jr^-1(w) dw.
Mat3 rightJacobianInverse(const Vec3& w);
/// Angle of a rotation in radians, in [0, pi].
double angle(const Mat3& R);
/// Projects a near-rotation matrix onto SO(3) (SVD), for re-orthonormalisation.
Mat3 orthonormalize(const Mat3& R);

}  // namespace ovo::so3
