#include "common/so3.hpp"

#include <Eigen/SVD>
#include <cmath>

namespace ovo::so3 {

Mat3 hat(const Vec3& w) {
  Mat3 W;
  W << 0.0, -w.z(), w.y(), w.z(), 0.0, -w.x(), -w.y(), w.x(), 0.0;
  return W;
}

Mat3 exp(const Vec3& w) {
  const double theta2 = w.squaredNorm();
  const Mat3 W = hat(w);
  if (theta2 < 1e-16) return Mat3::Identity() + W + 0.5 * W * W;
  const double theta = std::sqrt(theta2);
  return Mat3::Identity() + (std::sin(theta) / theta) * W +
         ((1.0 - std::cos(theta)) / theta2) * W * W;
}

Vec3 log(const Mat3& R) {
  // Via the quaternion: stable near 0 and near pi.
  Quat q(R);
  q.normalize();
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  const Vec3 v = q.vec();
  const double s = v.norm();
  if (s < 1e-12) return 2.0 * v;  // theta ~ 2 s
  const double theta = 2.0 * std::atan2(s, q.w());
  return (theta / s) * v;
}

Mat3 rightJacobian(const Vec3& w) {
  const double theta2 = w.squaredNorm();
  const Mat3 W = hat(w);
  if (theta2 < 1e-12) return Mat3::Identity() - 0.5 * W + W * W / 6.0;
  const double theta = std::sqrt(theta2);
  return Mat3::Identity() - ((1.0 - std::cos(theta)) / theta2) * W +
         ((theta - std::sin(theta)) / (theta2 * theta)) * W * W;
}

Mat3 rightJacobianInverse(const Vec3& w) {
  const double theta2 = w.squaredNorm();
  const Mat3 W = hat(w);
  if (theta2 < 1e-12) return Mat3::Identity() + 0.5 * W + W * W / 12.0;
  const double theta = std::sqrt(theta2);
  return Mat3::Identity() + 0.5 * W +
         (1.0 / theta2 - (1.0 + std::cos(theta)) / (2.0 * theta * std::sin(theta))) * W * W;
}

double angle(const Mat3& R) { return log(R).norm(); }

Mat3 orthonormalize(const Mat3& R) {
  Eigen::JacobiSVD<Mat3> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 out = svd.matrixU() * svd.matrixV().transpose();
  if (out.determinant() < 0.0) {
    Mat3 U = svd.matrixU();
    U.col(2) *= -1.0;
    out = U * svd.matrixV().transpose();
  }
  return out;
}

}  // namespace ovo::so3
