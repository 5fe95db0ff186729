#include "factors/gyro_preintegration.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>

#include "common/config.hpp"
#include "common/so3.hpp"
#include "factors/parameterization.hpp"

namespace ovo::factors {

GyroPreintegrationOptions readGyroPreintegrationOptions(const Config& config,
                                                        const std::string& prefix) {
  GyroPreintegrationOptions o;
  o.noise_density = config.getInRange(prefix + ".noise_density", o.noise_density, 1e-9, 1.0);
  o.max_gap_s = config.getInRange(prefix + ".max_gap_s", o.max_gap_s, 1e-4, 10.0);
  o.gap_rate_sigma_radps =
      config.getInRange(prefix + ".gap_rate_sigma_radps", o.gap_rate_sigma_radps, 0.0, 100.0);
  return o;
}

namespace {

// Rate at time t: linear interpolation between the samples around t, the nearest one held
// beyond the ends. samples is non-empty and sorted.
Vec3 rateAt(std::span<const ImuSample> samples, Timestamp t) {
  const auto it = std::lower_bound(samples.begin(), samples.end(), t,
                                   [](const ImuSample& s, Timestamp v) { return s.t_ns < v; });
  if (it == samples.begin()) return it->gyro_radps;
  if (it == samples.end()) return samples.back().gyro_radps;
  if (it->t_ns == t) return it->gyro_radps;
  const ImuSample& a = *(it - 1);
  const ImuSample& b = *it;
  const double s = static_cast<double>(t - a.t_ns) / static_cast<double>(b.t_ns - a.t_ns);
  return (1.0 - s) * a.gyro_radps + s * b.gyro_radps;
}

}  // namespace

GyroPreintegration::GyroPreintegration(std::span<const ImuSample> samples, Timestamp t_i_ns,
                                       Timestamp t_j_ns, const Vec3& bias_lin_radps,
                                       const GyroPreintegrationOptions& options)
    : options_(options), t_i_(t_i_ns), t_j_(t_j_ns), bias_lin_(bias_lin_radps) {
  const Timestamp max_gap_ns = fromSeconds(options_.max_gap_s);
  if (samples.empty() || t_j_ <= t_i_) {
    knots_ = {{t_i_, Vec3::Zero()}, {t_j_, Vec3::Zero()}};
    gap_after_ = {samples.empty()};
    status_ = samples.empty() ? Status::kNoData : Status::kOk;
    propagate();
    return;
  }
  const auto by_time = [](const ImuSample& s, Timestamp v) { return s.t_ns < v; };
  const auto first_inside = std::upper_bound(
      samples.begin(), samples.end(), t_i_,
      [](Timestamp v, const ImuSample& s) { return v < s.t_ns; });  // first with t > t_i
  const auto end_inside = std::lower_bound(samples.begin(), samples.end(), t_j_, by_time);

  knots_.clear();
  knots_.push_back({t_i_, rateAt(samples, t_i_)});
  for (auto it = first_inside; it < end_inside; ++it) knots_.push_back({it->t_ns, it->gyro_radps});
  knots_.push_back({t_j_, rateAt(samples, t_j_)});
  num_inside_ = static_cast<int>(std::max<std::ptrdiff_t>(0, end_inside - first_inside));

  // A step is a gap when the real samples enclosing it are further apart than max_gap_s, or when
  // no sample encloses it on one side (an uncovered end).
  gap_after_.assign(knots_.size() - 1, false);
  for (std::size_t k = 0; k + 1 < knots_.size(); ++k) {
    const Timestamp a = knots_[k].t_ns, b = knots_[k + 1].t_ns;
    const auto after = std::lower_bound(samples.begin(), samples.end(), b, by_time);  // t >= b
    const auto upto = std::upper_bound(samples.begin(), samples.end(), a,
                                       [](Timestamp v, const ImuSample& s) { return v < s.t_ns; });
    const bool covered = upto != samples.begin() && after != samples.end();
    gap_after_[k] = !covered || (after->t_ns - (upto - 1)->t_ns) > max_gap_ns;
  }
  status_ = Status::kOk;
  if (std::find(gap_after_.begin(), gap_after_.end(), true) != gap_after_.end())
    status_ = Status::kGap;
  if (num_inside_ == 0 && status_ == Status::kGap) status_ = Status::kNoData;
  propagate();
}

void GyroPreintegration::repropagate(const Vec3& bias_lin_radps) {
  bias_lin_ = bias_lin_radps;
  propagate();
}

// Forster et al. TRO 2017, eqs. 35 (rotation), 59-63 (covariance) and appendix B (bias Jacobian):
//   dR_{k+1} = dR_k Exp(w dt)
//   Sigma_{k+1} = Exp(w dt)^T Sigma_k Exp(w dt) + Jr(w dt) Sigma_eta Jr(w dt)^T dt^2
//   J_{k+1} = Exp(w dt)^T J_k - Jr(w dt) dt,  with w = mean rate - b_bar, Sigma_eta = nd^2/dt I.
void GyroPreintegration::propagate() {
  delta_R_.setIdentity();
  covariance_.setZero();
  J_bias_.setZero();
  gap_s_ = 0.0;
  longest_gap_s_ = 0.0;
  const double nd2 = options_.noise_density * options_.noise_density;
  const double gap_var_rate = options_.gap_rate_sigma_radps * options_.gap_rate_sigma_radps;
  for (std::size_t k = 0; k + 1 < knots_.size(); ++k) {
    const double dt = toSeconds(knots_[k + 1].t_ns - knots_[k].t_ns);
    if (dt <= 0.0) continue;
    const Vec3 w = 0.5 * (knots_[k].w_radps + knots_[k + 1].w_radps) - bias_lin_;
    const Vec3 phi = w * dt;
    const Mat3 dR = so3::exp(phi);
    const Mat3 Jr = so3::rightJacobian(phi);
    covariance_ = dR.transpose() * covariance_ * dR + (nd2 * dt) * Jr * Jr.transpose();
    if (gap_after_[k]) {
      covariance_ += (gap_var_rate * dt * dt) * Mat3::Identity();
      gap_s_ += dt;
      longest_gap_s_ = std::max(longest_gap_s_, dt);
    }
    J_bias_ = dR.transpose() * J_bias_ - dt * Jr;
    delta_R_ = delta_R_ * dR;
  }
  delta_R_ = so3::orthonormalize(delta_R_);
  // A floor of (1e-7 rad)^2 keeps the information finite for an empty or zero-length interval.
  const Mat3 cov = covariance_ + 1e-14 * Mat3::Identity();
  const Mat3 information = cov.inverse();
  const Eigen::LLT<Mat3> llt(0.5 * (information + information.transpose()));
  sqrt_information_ = llt.matrixU();
}

Mat3 GyroPreintegration::deltaR(const Vec3& b_g_radps) const {
  return delta_R_ * so3::exp(J_bias_ * (b_g_radps - bias_lin_));
}

bool GyroFactor::Evaluate(double const* const* parameters, double* residuals,
                          double** jacobians) const {
  const double* q_i = parameters[0];
  const double* q_j = parameters[1];
  const Eigen::Map<const Vec3> b_g(parameters[2]);
  const Mat3 R_W_Bi = quatFromBlock(q_i).toRotationMatrix();
  const Mat3 R_W_Bj = quatFromBlock(q_j).toRotationMatrix();

  const Vec3 phi_b = preint_->biasJacobian() * (b_g - preint_->biasLinearization());
  const Mat3 dR_corr = preint_->deltaR() * so3::exp(phi_b);
  const Mat3 E = dR_corr.transpose() * R_W_Bi.transpose() * R_W_Bj;
  const Vec3 r = so3::log(E);
  const Mat3& S = preint_->sqrtInformation();
  Eigen::Map<Vec3> residual(residuals);
  residual = S * r;
  if (!jacobians) return true;

  // With R <- Exp(theta) R: dr/dtheta_i = -Jr^-1(r) R_j^T, dr/dtheta_j = Jr^-1(r) R_j^T,
  // dr/db = -Jr^-1(r) E^T Jr(phi_b) J_b (Forster et al. eq. 44 with the world-frame perturbation).
  const Mat3 Jr_inv = so3::rightJacobianInverse(r);
  const Mat3 S_Jinv = S * Jr_inv;
  if (jacobians[0]) {
    const Mat3 J_theta = -S_Jinv * R_W_Bj.transpose();
    rotationJacobianToAmbient<3>(J_theta, q_i, jacobians[0]);
  }
  if (jacobians[1]) {
    const Mat3 J_theta = S_Jinv * R_W_Bj.transpose();
    rotationJacobianToAmbient<3>(J_theta, q_j, jacobians[1]);
  }
  if (jacobians[2]) {
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> J(jacobians[2]);
    J = -S_Jinv * E.transpose() * so3::rightJacobian(phi_b) * preint_->biasJacobian();
  }
  return true;
}

BiasRandomWalkFactor::BiasRandomWalkFactor(double sigma_bw, double dt_s)
    : inv_sigma_(1.0 / (sigma_bw * std::sqrt(std::max(dt_s, 1e-9)))) {}

bool BiasRandomWalkFactor::Evaluate(double const* const* parameters, double* residuals,
                                    double** jacobians) const {
  const Eigen::Map<const Vec3> b_i(parameters[0]), b_j(parameters[1]);
  Eigen::Map<Vec3> residual(residuals);
  residual = inv_sigma_ * (b_j - b_i);
  if (!jacobians) return true;
  if (jacobians[0]) {
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> J(jacobians[0]);
    J = -inv_sigma_ * Mat3::Identity();
  }
  if (jacobians[1]) {
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> J(jacobians[1]);
    J = inv_sigma_ * Mat3::Identity();
  }
  return true;
}

}  // namespace ovo::factors
