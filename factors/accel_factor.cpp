#include "factors/accel_factor.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "common/so3.hpp"
#include "factors/parameterization.hpp"

namespace ovo::factors {
namespace {

struct Knot {
  double t;  // s from t0
  Vec3 w, f;
};

// The samples' gyro and accelerometer at time t (linear between the two around it; the span
// covers t).
Knot interpolate(std::span<const ImuSample> s, Timestamp t_ns, Timestamp t0_ns) {
  auto hi = std::lower_bound(s.begin(), s.end(), t_ns,
                             [](const ImuSample& x, Timestamp t) { return x.t_ns < t; });
  if (hi == s.end()) hi = s.end() - 1;
  auto lo = hi == s.begin() ? hi : hi - 1;
  const double span = toSeconds(hi->t_ns - lo->t_ns);
  const double a = span > 0.0 ? std::clamp(toSeconds(t_ns - lo->t_ns) / span, 0.0, 1.0) : 1.0;
  return {toSeconds(t_ns - t0_ns), (1.0 - a) * lo->gyro_radps + a * hi->gyro_radps,
          (1.0 - a) * lo->accel_mps2 + a * hi->accel_mps2};
}

}  // namespace

std::optional<AccelInterval> integrateAccel(std::span<const ImuSample> samples, Timestamp t0_ns,
                                            Timestamp t1_ns, const Vec3& gyro_bias_radps,
                                            double max_gap_s) {
  if (samples.size() < 2 || t1_ns <= t0_ns || samples.front().t_ns > t0_ns ||
      samples.back().t_ns < t1_ns)
    return std::nullopt;
  bool any_accel = false;
  std::vector<Knot> knots;
  knots.push_back(interpolate(samples, t0_ns, t0_ns));
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const ImuSample& s = samples[i];
    any_accel = any_accel || s.accel_mps2.squaredNorm() > 0.0;
    if (!s.accel_mps2.allFinite() || !s.gyro_radps.allFinite()) return std::nullopt;
    const bool overlaps = i > 0 && s.t_ns > t0_ns && samples[i - 1].t_ns < t1_ns;
    if (overlaps && toSeconds(s.t_ns - samples[i - 1].t_ns) > max_gap_s) return std::nullopt;
    if (s.t_ns > t0_ns && s.t_ns < t1_ns)
      knots.push_back({toSeconds(s.t_ns - t0_ns), s.gyro_radps, s.accel_mps2});
  }
  if (!any_accel) return std::nullopt;
  knots.push_back(interpolate(samples, t1_ns, t0_ns));

  const double T = toSeconds(t1_ns - t0_ns);
  Mat3 R = Mat3::Identity();  // R_B0_B(t) at the current knot
  Vec3 rise_B0 = Vec3::Zero(), fall_B0 = Vec3::Zero();
  for (std::size_t k = 0; k + 1 < knots.size(); ++k) {
    const Knot& a = knots[k];
    const Knot& b = knots[k + 1];
    const double h = b.t - a.t;
    if (h <= 0.0) continue;
    const Mat3 R_next = R * so3::exp((0.5 * (a.w + b.w) - gyro_bias_radps) * h);
    const Vec3 fa = R * a.f, fb = R_next * b.f;  // in B0
    // Trapezoids of w(t) R f with the rising and falling weights.
    rise_B0 += 0.5 * h * (a.t / T * fa + b.t / T * fb);
    fall_B0 += 0.5 * h * ((T - a.t) / T * fa + (T - b.t) / T * fb);
    R = R_next;
  }
  AccelInterval out;
  out.rise_B1 = R.transpose() * rise_B0;
  out.fall_B0 = fall_B0;
  out.dt_s = T;
  return out;
}

Vec3 gravityDirection(const double* s) {
  const double ca = std::cos(s[0]), sa = std::sin(s[0]), cb = std::cos(s[1]), sb = std::sin(s[1]);
  return {-sb, cb * sa, -cb * ca};
}

void setGravityDirection(const Vec3& down_W, double* s) {
  const Vec3 d = down_W.normalized();
  s[1] = std::asin(std::clamp(-d.x(), -1.0, 1.0));
  s[0] = std::atan2(d.y(), -d.z());
}

AccelerationFactor::AccelerationFactor(const AccelInterval& first, const AccelInterval& second,
                                       double gravity_mps2, double sigma_mps2,
                                       double position_sigma_m)
    : dt1_(std::max(first.dt_s, 1e-6)),
      dt2_(std::max(second.dt_s, 1e-6)),
      gravity_(gravity_mps2) {
  // c (p2/dt2 - p1 (1/dt1 + 1/dt2) + p0/dt1) with independent position noises.
  const double c = 2.0 / (dt1_ + dt2_);
  const double k1 = 1.0 / dt1_, k2 = 1.0 / dt2_;
  const double from_positions =
      position_sigma_m * c * std::sqrt(k1 * k1 + (k1 + k2) * (k1 + k2) + k2 * k2);
  inv_sigma_ = 1.0 / std::max(std::hypot(sigma_mps2, from_positions), 1e-12);
  // int M over [t0, t2] with the hat's height 2 / (dt1 + dt2) is 1: F is the two halves scaled.
  f_mean_B1_ = 2.0 / (dt1_ + dt2_) * (first.rise_B1 + second.fall_B0);
}

bool AccelerationFactor::Evaluate(double const* const* parameters, double* residuals,
                                  double** jacobians) const {
  const Mat3 R = quatFromBlock(parameters[0]).toRotationMatrix();
  const Eigen::Map<const Vec3> p0(parameters[1]), p1(parameters[2]), p2(parameters[3]);
  const double* s = parameters[4];
  const Eigen::Map<const Vec3> b_a(s + 2);
  const double c = 2.0 / (dt1_ + dt2_);
  const Vec3 a_W = c * ((p2 - p1) / dt2_ - (p1 - p0) / dt1_);
  const Vec3 v_W = a_W - gravity_ * gravityDirection(s);  // what the accelerometer should read
  Eigen::Map<Vec3> r(residuals);
  r = inv_sigma_ * (f_mean_B1_ - b_a - R.transpose() * v_W);
  if (!jacobians) return true;
  if (jacobians[0]) {
    // R <- Exp(theta) R: R^T v <- R^T Exp(-theta) v = R^T (v + [v]x theta).
    const Mat3 J = -inv_sigma_ * R.transpose() * so3::hat(v_W);
    rotationJacobianToAmbient<3>(J, parameters[0], jacobians[0]);
  }
  const auto setPos = [&](int i, double k) {
    if (!jacobians[i]) return;
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> J(jacobians[i]);
    J = -inv_sigma_ * k * R.transpose();
  };
  setPos(1, c / dt1_);
  setPos(2, -c * (1.0 / dt1_ + 1.0 / dt2_));
  setPos(3, c / dt2_);
  if (jacobians[4]) {
    Eigen::Map<Eigen::Matrix<double, 3, kGravityStateSize, Eigen::RowMajor>> J(jacobians[4]);
    const double ca = std::cos(s[0]), sa = std::sin(s[0]), cb = std::cos(s[1]),
                 sb = std::sin(s[1]);
    J.col(0) = inv_sigma_ * gravity_ * R.transpose() * Vec3(0.0, cb * ca, cb * sa);
    J.col(1) = inv_sigma_ * gravity_ * R.transpose() * Vec3(-cb, -sb * sa, sb * ca);
    J.rightCols<3>() = -inv_sigma_ * Mat3::Identity();
  }
  return true;
}

AccelBiasPriorFactor::AccelBiasPriorFactor(double sigma_mps2)
    : inv_sigma_(1.0 / std::max(sigma_mps2, 1e-12)) {}

bool AccelBiasPriorFactor::Evaluate(double const* const* parameters, double* residuals,
                                    double** jacobians) const {
  for (int i = 0; i < 3; ++i) residuals[i] = inv_sigma_ * parameters[0][2 + i];
  if (jacobians && jacobians[0]) {
    Eigen::Map<Eigen::Matrix<double, 3, kGravityStateSize, Eigen::RowMajor>> J(jacobians[0]);
    J.setZero();
    J.rightCols<3>() = inv_sigma_ * Mat3::Identity();
  }
  return true;
}

}  // namespace ovo::factors
