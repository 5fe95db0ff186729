// Gyro preintegration between two keyframe times and the rotation-only gyro factor
// (Forster, Carlone, Dellaert, Scaramuzza, "On-Manifold Preintegration for Real-Time
// Visual-Inertial Odometry", TRO 2017, sections V-A..C; the accelerometer is not used).
#pragma once

#include <ceres/sized_cost_function.h>

#include <memory>
#include <span>
#include <string>
#include <vector>

#include "common/types.hpp"

namespace ovo {
class Config;
}

namespace ovo::factors {

/// Gyro noise and gap handling for preintegration.
struct GyroPreintegrationOptions {
  double noise_density = 1.7e-4;  // gyro white noise, rad/s/sqrt(Hz) (EuRoC ADIS16448: 1.6968e-4)
  double max_gap_s = 0.05;        // a step between samples longer than this is a gap (s)
  double gap_rate_sigma_radps = 0.5;  // rate uncertainty assumed across a gap (rad/s)
  bool operator==(const GyroPreintegrationOptions&) const = default;
};
/// Reads <prefix>.noise_density, <prefix>.max_gap_s, <prefix>.gap_rate_sigma_radps.
GyroPreintegrationOptions readGyroPreintegrationOptions(const Config& config,
                                                        const std::string& prefix = "gyro");

/// Preintegrated rotation dR_ij = prod Exp((w_k - b_bar) dt_k) over [t_i, t_j] with its
/// covariance and bias Jacobian, for one bias linearisation point b_bar.
/// Integration: the rate is linearly interpolated at t_i and t_j (samples straddling a frame time),
/// and each step between consecutive knots uses the mean of its two end rates (trapezoidal rule on
/// the rate, "midpoint" integration as in VINS-Mono).
/// Noise: each step is one gyro reading with discrete sigma = noise_density / sqrt(dt) per axis.
/// Gaps: a step longer than max_gap_s, or time at either end that no sample covers (the nearest
/// rate is held there), adds (gap_rate_sigma_radps * dt)^2 per axis to the covariance and is
/// reported; the estimator decides whether to use the factor.
class GyroPreintegration {
 public:
  enum class Status {
    kOk,      // samples cover [t_i, t_j] with no step longer than max_gap_s
    kGap,     // a gap or an uncovered end: covariance inflated, see gapSeconds()
    kNoData,  // no sample at all in or around the interval: dR = I, covariance from the gap model
  };

  /// Integrates the samples (sorted by time; only those near [t_i, t_j] are used) over [t_i, t_j].
  GyroPreintegration(std::span<const ImuSample> samples, Timestamp t_i_ns, Timestamp t_j_ns,
                     const Vec3& bias_lin_radps, const GyroPreintegrationOptions& options = {});

  /// Integrates again from the stored samples with a new bias linearisation point (call between
  /// solves when the bias estimate has moved far from biasLinearization()).
  void repropagate(const Vec3& bias_lin_radps);
  /// True when |b_g - b_bar| exceeds threshold (rad/s), i.e. the first-order correction is poor.
  bool needsRepropagation(const Vec3& b_g_radps, double threshold_radps = 0.02) const {
    return (b_g_radps - bias_lin_).norm() > threshold_radps;
  }

  /// dR_ij at the linearisation bias.
  const Mat3& deltaR() const { return delta_R_; }
  /// First-order bias-corrected dR_ij(b_g) = dR_ij(b_bar) Exp(J_b (b_g - b_bar)).
  Mat3 deltaR(const Vec3& b_g_radps) const;
  /// Covariance of the rotation error Log(dR_true^T dR) in rad^2.
  const Mat3& covariance() const { return covariance_; }
  /// Upper-triangular S with S^T S = covariance^-1 (whitens a 3-vector residual: r_w = S r).
  const Mat3& sqrtInformation() const { return sqrt_information_; }
  /// J_b = d Log(dR(b)) / d b at b_bar (rad per rad/s, i.e. seconds).
  const Mat3& biasJacobian() const { return J_bias_; }
  const Vec3& biasLinearization() const { return bias_lin_; }

  Timestamp tStart() const { return t_i_; }
  Timestamp tEnd() const { return t_j_; }
  double dtSeconds() const { return toSeconds(t_j_ - t_i_); }
  Status status() const { return status_; }
  /// Total time inside gaps or uncovered ends (s) and the longest single gap (s).
  double gapSeconds() const { return gap_s_; }
  double longestGapSeconds() const { return longest_gap_s_; }
  /// Number of real gyro samples strictly inside (t_i, t_j).
  int numSamples() const { return num_inside_; }
  /// The measured rate (bias not removed) at t_i and at t_j, as integrated (interpolated between
  /// the samples around them; zero without data).
  Vec3 rateAtStart() const { return knots_.empty() ? Vec3::Zero() : knots_.front().w_radps; }
  Vec3 rateAtEnd() const { return knots_.empty() ? Vec3::Zero() : knots_.back().w_radps; }

 private:
  struct Knot {
    Timestamp t_ns;
    Vec3 w_radps;
  };
  void propagate();

  GyroPreintegrationOptions options_;
  Timestamp t_i_ = 0, t_j_ = 0;
  std::vector<Knot> knots_;      // rates at t_i, at samples inside, at t_j
  std::vector<bool> gap_after_;  // knot k -> k+1 is a gap step
  Vec3 bias_lin_ = Vec3::Zero();
  Mat3 delta_R_ = Mat3::Identity();
  Mat3 covariance_ = Mat3::Zero();
  Mat3 sqrt_information_ = Mat3::Identity();
  Mat3 J_bias_ = Mat3::Zero();
  Status status_ = Status::kOk;
  double gap_s_ = 0.0, longest_gap_s_ = 0.0;
  int num_inside_ = 0;
};

/// Gyro factor between keyframes i and j:
///   r = S Log( (dR_ij Exp(J_b (b_g_i - b_bar)))^T R_W_Bi^T R_W_Bj ),  S^T S = covariance^-1.
/// Blocks: q_W_Bi[4], q_W_Bj[4], b_g_i[3]. Holds the preintegration by shared pointer so that
/// repropagate() between solves is seen by the factor (never call it during a solve).
class GyroFactor final : public ceres::SizedCostFunction<3, 4, 4, 3> {
 public:
  explicit GyroFactor(std::shared_ptr<const GyroPreintegration> preintegration)
      : preint_(std::move(preintegration)) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  const GyroPreintegration& preintegration() const { return *preint_; }

 private:
  std::shared_ptr<const GyroPreintegration> preint_;
};

/// Bias random walk factor: r = (b_g_j - b_g_i) / (sigma_bw sqrt(t_j - t_i)) per axis.
/// Blocks: b_g_i[3], b_g_j[3].
class BiasRandomWalkFactor final : public ceres::SizedCostFunction<3, 3, 3> {
 public:
  /// sigma_bw: bias random walk, rad/s^2/sqrt(Hz) (EuRoC ADIS16448: 1.9393e-5); dt_s > 0.
  BiasRandomWalkFactor(double sigma_bw, double dt_s);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  double inv_sigma_;  // 1 / (sigma_bw sqrt(dt))
};

}  // namespace ovo::factors
