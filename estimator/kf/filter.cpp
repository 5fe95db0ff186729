// The kf's error-state Kalman filter on SO(3): gyro propagation, VO and zero-rate updates.
#include "estimator/kf/filter.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>

#include "common/so3.hpp"

namespace ovo::estimator {

KfOptions readKfOptions(const Config& config) {
  KfOptions o;
  o.gyro_noise_density =
      config.getInRange("kf.gyro_noise_density", o.gyro_noise_density, 1e-9, 1.0);
  o.gyro_bias_random_walk =
      config.getInRange("kf.gyro_bias_random_walk", o.gyro_bias_random_walk, 0.0, 1.0);
  o.init_rotation_sigma_rad =
      config.getInRange("kf.init_rotation_sigma_rad", o.init_rotation_sigma_rad, 1e-9, 3.2);
  o.init_bias_sigma_radps =
      config.getInRange("kf.init_bias_sigma_radps", o.init_bias_sigma_radps, 1e-9, 10.0);
  o.vo_sigma0_rad = config.getInRange("kf.vo_sigma0_rad", o.vo_sigma0_rad, 1e-9, 1.0);
  o.vo_sigma_per_rad = config.getInRange("kf.vo_sigma_per_rad", o.vo_sigma_per_rad, 0.0, 10.0);
  o.bias_freeze_rate_radps =
      config.getInRange("kf.bias_freeze_rate_radps", o.bias_freeze_rate_radps, 0.0, 100.0);
  o.vo_gate_chi2 = config.getInRange("kf.vo_gate_chi2", o.vo_gate_chi2, 0.0, 1e9);
  o.zero_rate_gate_chi2 =
      config.getInRange("kf.zero_rate_gate_chi2", o.zero_rate_gate_chi2, 0.0, 1e9);
  o.zero_rate_sigma_radps =
      config.getInRange("kf.zero_rate_sigma_radps", o.zero_rate_sigma_radps, 0.0, 1.0);
  o.max_gyro_gap_s = config.getInRange("kf.max_gyro_gap_s", o.max_gyro_gap_s, 1e-4, 10.0);
  o.gap_rotation_noise =
      config.getInRange("kf.gap_rotation_noise", o.gap_rotation_noise, 1e-6, 100.0);
  return o;
}

KfFilter::KfFilter(const KfOptions& options) : options_(options) {}

void KfFilter::initialise(Timestamp t_ns, const Mat3& R_W_B, const Vec3& b_g,
                          double rotation_sigma_rad, double bias_sigma_radps) {
  t_ns_ = t_ns;
  last_gyro_.reset();
  t_clone_ns_.reset();
  R_W_B_ = so3::orthonormalize(R_W_B);
  R_W_Bk_ = R_W_B_;
  b_g_ = b_g;
  P_.setZero();
  P_.block<3, 3>(0, 0).diagonal().setConstant(rotation_sigma_rad * rotation_sigma_rad);
  P_.block<3, 3>(3, 3).diagonal().setConstant(bias_sigma_radps * bias_sigma_radps);
  P_.block<3, 3>(6, 6) = P_.block<3, 3>(0, 0);
  P_.block<3, 3>(0, 6) = P_.block<3, 3>(0, 0);
  P_.block<3, 3>(6, 0) = P_.block<3, 3>(0, 0);
  max_rate_since_clone_radps_ = 0.0;
  last_sigma_vo_rad_ = 0.0;
}

void KfFilter::initialise(Timestamp t_ns, const Mat3& R_W_B, const Vec3& b_g) {
  initialise(t_ns, R_W_B, b_g, options_.init_rotation_sigma_rad, options_.init_bias_sigma_radps);
}

void KfFilter::integrate(const Vec3& w_radps, double dt_s) {
  // phi = (w_m - b_g) dt; R <- R Exp(phi); error-state transition and noise as in the header.
  const Vec3 w_true = w_radps - b_g_;
  const Vec3 phi = w_true * dt_s;
  const Mat3 dR = so3::exp(phi);
  const Mat3 Jr = so3::rightJacobian(phi);
  R_W_B_ = R_W_B_ * dR;

  Mat9 F = Mat9::Identity();
  F.block<3, 3>(0, 0) = dR.transpose();
  F.block<3, 3>(0, 3) = -Jr * dt_s;
  P_ = F * P_ * F.transpose();
  const double sg2 = options_.gyro_noise_density * options_.gyro_noise_density;
  const double sbw2 = options_.gyro_bias_random_walk * options_.gyro_bias_random_walk;
  P_.block<3, 3>(0, 0) += (sg2 * dt_s) * Jr * Jr.transpose();
  P_.block<3, 3>(3, 3).diagonal().array() += sbw2 * dt_s;
  max_rate_since_clone_radps_ = std::max(max_rate_since_clone_radps_, w_true.norm());
}

void KfFilter::predictWithoutGyro(double dt_s) {
  // Rotation held, uncertainty grows as a random walk sigma_gap^2 dt; bias as its random walk.
  const double sgap2 = options_.gap_rotation_noise * options_.gap_rotation_noise;
  const double sbw2 = options_.gyro_bias_random_walk * options_.gyro_bias_random_walk;
  P_.block<3, 3>(0, 0).diagonal().array() += sgap2 * dt_s;
  P_.block<3, 3>(3, 3).diagonal().array() += sbw2 * dt_s;
}

void KfFilter::propagate(const ImuSample& sample) {
  if (!sample.gyro_radps.allFinite()) return;
  if (!t_ns_) {
    initialise(sample.t_ns);
    last_gyro_ = sample;
    return;
  }
  const Timestamp t_now = *t_ns_;
  if (sample.t_ns <= t_now) {
    // Already past it (a frame was predicted beyond this sample): only remember the rate.
    if (!last_gyro_ || sample.t_ns > last_gyro_->t_ns) last_gyro_ = sample;
    return;
  }
  const double dt_s = toSeconds(sample.t_ns - t_now);
  const Timestamp max_gap_ns = fromSeconds(options_.max_gyro_gap_s);
  if (last_gyro_ && sample.t_ns - last_gyro_->t_ns <= max_gap_ns) {
    // Rate at the midpoint of [t_now, sample.t], linear between the two samples.
    const double span_ns = static_cast<double>(sample.t_ns - last_gyro_->t_ns);
    const double t_mid_ns = 0.5 * static_cast<double>(t_now + sample.t_ns);
    const double alpha =
        span_ns > 0.0 ? (t_mid_ns - static_cast<double>(last_gyro_->t_ns)) / span_ns : 1.0;
    integrate(last_gyro_->gyro_radps + alpha * (sample.gyro_radps - last_gyro_->gyro_radps), dt_s);
  } else if (!last_gyro_ && sample.t_ns - t_now <= max_gap_ns) {
    integrate(sample.gyro_radps, dt_s);
  } else {
    predictWithoutGyro(dt_s);
  }
  last_gyro_ = sample;
  t_ns_ = sample.t_ns;
}

void KfFilter::propagateTo(Timestamp t_ns) {
  if (!t_ns_) {
    initialise(t_ns);
    return;
  }
  if (t_ns <= *t_ns_) return;
  const double dt_s = toSeconds(t_ns - *t_ns_);
  if (last_gyro_ && t_ns - last_gyro_->t_ns <= fromSeconds(options_.max_gyro_gap_s)) {
    integrate(last_gyro_->gyro_radps, dt_s);
  } else {
    predictWithoutGyro(dt_s);
  }
  t_ns_ = t_ns;
}

void KfFilter::cloneCurrent(Timestamp t_ns) {
  // x_k <- x: P <- A P A^T with A = [I 0 0; 0 I 0; I 0 0].
  R_W_B_ = so3::orthonormalize(R_W_B_);
  R_W_Bk_ = R_W_B_;
  P_.block<3, 9>(6, 0) = P_.block<3, 9>(0, 0);
  P_.block<9, 3>(0, 6) = P_.block<9, 3>(0, 0);
  t_clone_ns_ = t_ns;
  max_rate_since_clone_radps_ = 0.0;
}

KfUpdateResult KfFilter::zeroRateUpdate(const Vec3& mean_rate_radps, double window_s) {
  KfUpdateResult result;
  if (!t_ns_ || !mean_rate_radps.allFinite() || !(window_s > 0.0)) return result;
  // z = b_g + n, n ~ N(0, sigma_g^2 / T); H = [0, I, 0].
  const Vec3 r = mean_rate_radps - b_g_;
  const double sigma =
      std::max(options_.gyro_noise_density / std::sqrt(window_s), options_.zero_rate_sigma_radps);
  result.sigma_vo_rad = sigma;
  Eigen::Matrix<double, 3, kErrorDim> H = Eigen::Matrix<double, 3, kErrorDim>::Zero();
  H.block<3, 3>(0, 3).setIdentity();
  const Mat3 R_noise = Mat3::Identity() * (sigma * sigma);
  const Mat3 S = P_.block<3, 3>(3, 3) + R_noise;
  const Eigen::LDLT<Mat3> S_ldlt(S);
  if (S_ldlt.info() != Eigen::Success || !S_ldlt.isPositive()) return result;
  result.chi2 = r.dot(S_ldlt.solve(r));
  if (options_.zero_rate_gate_chi2 > 0.0 && result.chi2 > options_.zero_rate_gate_chi2) {
    result.gated = true;
    return result;
  }
  const Eigen::Matrix<double, kErrorDim, 3> K = S_ldlt.solve(H * P_).transpose();  // P H^T S^-1
  result.applied = applyCorrection(K, H, R_noise, K * r);
  return result;
}

void KfFilter::markFrame(Timestamp t_ns) {
  propagateTo(t_ns);
  cloneCurrent(time());
}

KfUpdateResult KfFilter::update(Timestamp t_ns, const Mat3& R_Bprev_Bcur,
                                std::optional<double> sigma0_rad) {
  KfUpdateResult result;
  propagateTo(t_ns);
  const Timestamp t_frame = time();
  if (!t_clone_ns_ || !R_Bprev_Bcur.allFinite()) {
    cloneCurrent(t_frame);
    return result;
  }

  // Noise schedule: sigma_vo = sigma_0 + k_turn |angle(R_meas)|.
  const double angle_meas = so3::angle(R_Bprev_Bcur);
  const double sigma0 = sigma0_rad.value_or(options_.vo_sigma0_rad);
  const double sigma = std::max(sigma0, 1e-12) + options_.vo_sigma_per_rad * angle_meas;
  result.sigma_vo_rad = sigma;
  last_sigma_vo_rad_ = sigma;

  // Turning rate over the frame interval: the largest of the gyro rates seen, the predicted and
  // the measured rotation per second.
  const Mat3 R_Bk_B = R_W_Bk_.transpose() * R_W_B_;
  const double dt_frame_s = toSeconds(t_frame - *t_clone_ns_);
  double rate = max_rate_since_clone_radps_;
  if (dt_frame_s > 0.0)
    rate = std::max({rate, angle_meas / dt_frame_s, so3::angle(R_Bk_B) / dt_frame_s});
  result.turn_rate_radps = rate;
  result.bias_frozen = rate > options_.bias_freeze_rate_radps;

  // r = Log(R_meas^T R_W_Bk^T R_W_B), H = [Jr^-1(r), 0, -Jr^-1(r) R_Bk_B^T].
  const Vec3 r = so3::log(so3::orthonormalize(R_Bprev_Bcur).transpose() * R_Bk_B);
  const Mat3 Jr_inv = so3::rightJacobianInverse(r);
  Eigen::Matrix<double, 3, kErrorDim> H = Eigen::Matrix<double, 3, kErrorDim>::Zero();
  H.block<3, 3>(0, 0) = Jr_inv;
  H.block<3, 3>(0, 6) = -Jr_inv * R_Bk_B.transpose();
  const Mat3 R_noise = Mat3::Identity() * (sigma * sigma);
  const Mat3 S = H * P_ * H.transpose() + R_noise;
  const Eigen::LDLT<Mat3> S_ldlt(S);
  if (S_ldlt.info() != Eigen::Success || !S_ldlt.isPositive()) {
    cloneCurrent(t_frame);
    return result;
  }
  result.chi2 = r.dot(S_ldlt.solve(r));
  if (options_.vo_gate_chi2 > 0.0 && result.chi2 > options_.vo_gate_chi2) {
    result.gated = true;
    cloneCurrent(t_frame);
    return result;
  }

  Eigen::Matrix<double, kErrorDim, 3> K = S_ldlt.solve(H * P_).transpose();  // P H^T S^-1
  if (result.bias_frozen) K.middleRows<3>(3).setZero();
  result.applied = applyCorrection(K, H, R_noise, K * (-r));
  cloneCurrent(t_frame);
  return result;
}

bool KfFilter::applyCorrection(const Eigen::Matrix<double, kErrorDim, 3>& K,
                               const Eigen::Matrix<double, 3, kErrorDim>& H, const Mat3& R_noise,
                               const Eigen::Matrix<double, kErrorDim, 1>& dx) {
  if (!dx.allFinite()) return false;
  R_W_B_ = R_W_B_ * so3::exp(dx.segment<3>(0));
  b_g_ += dx.segment<3>(3);
  R_W_Bk_ = R_W_Bk_ * so3::exp(dx.segment<3>(6));
  // Joseph form: valid for any gain (also the frozen-bias, suboptimal one).
  const Mat9 IKH = Mat9::Identity() - K * H;
  P_ = IKH * P_ * IKH.transpose() + K * R_noise * K.transpose();
  P_ = 0.5 * (P_ + P_.transpose()).eval();
  return true;
}

Mat3 predictGyroRotation(std::span<const ImuSample> samples, Timestamp t0_ns, Timestamp t1_ns,
                         const Vec3& bias_radps, double max_gap_s) {
  const Timestamp max_gap_ns = fromSeconds(max_gap_s);
  Mat3 R_B0_B = Mat3::Identity();
  const ImuSample* last = nullptr;
  Timestamp t_now = t0_ns;
  for (const ImuSample& sample : samples) {
    if (sample.t_ns > t1_ns) break;
    if (sample.t_ns > t_now) {
      const double dt_s = toSeconds(sample.t_ns - t_now);
      if (last && sample.t_ns - last->t_ns <= max_gap_ns) {
        // Rate at the midpoint of [t_now, sample.t], linear between the two samples.
        const double span_ns = static_cast<double>(sample.t_ns - last->t_ns);
        const double t_mid_ns = 0.5 * static_cast<double>(t_now + sample.t_ns);
        const double alpha =
            span_ns > 0.0 ? (t_mid_ns - static_cast<double>(last->t_ns)) / span_ns : 1.0;
        const Vec3 w = last->gyro_radps + alpha * (sample.gyro_radps - last->gyro_radps);
        R_B0_B = R_B0_B * so3::exp((w - bias_radps) * dt_s);
      } else if (!last && sample.t_ns - t_now <= max_gap_ns) {
        R_B0_B = R_B0_B * so3::exp((sample.gyro_radps - bias_radps) * dt_s);
      }
      t_now = sample.t_ns;
    }
    last = &sample;
  }
  if (t1_ns > t_now && last && t1_ns - last->t_ns <= max_gap_ns)
    R_B0_B = R_B0_B * so3::exp((last->gyro_radps - bias_radps) * toSeconds(t1_ns - t_now));
  return R_B0_B;
}

}  // namespace ovo::estimator
