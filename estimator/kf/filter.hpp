// The Kalman-filter baseline's rotation core (DESIGN section 7): an error-state Kalman
// filter on SO(3) that fuses the gyro with the VO relative rotation and estimates the gyro bias.
//
// The dissertation's prototype filtered roll and two rates; this filters the full 3-axis rotation.
//
// Model (body frame B = gyro frame; right-perturbed error state, Sola, "Quaternion kinematics for
// the error-state Kalman filter", 2017, sections 5 and 7; Forster et al., TRO 2017, eqs. 5-8):
//   nominal state   x = {R_W_B, b_g, R_W_Bk}       R_W_Bk = clone of R_W_B at the last camera frame
//   error state     dx = [dtheta, db_g, dtheta_k]  R_true = R Exp(dtheta), b_true = b_g + db_g
//   (9-dim) gyro            w_m = w + b_g + n_g,  n_g white (density sigma_g, rad/s/sqrt(Hz)),
//                   db_g/dt = n_bw (density sigma_bw, rad/s^2/sqrt(Hz))
//   propagation     phi = (w_m - b_g) dt,  R <- R Exp(phi)
//                   F = [Exp(phi)^T, -Jr(phi) dt, 0; 0, I, 0; 0, 0, I]
//                   Q = diag(Jr sigma_g^2 dt Jr^T, sigma_bw^2 dt I, 0)   (exact white-noise
//                   discretisation of the two densities over dt)
//                   P <- F P F^T + Q
//   measurement     R_meas = R_Bk_B Exp(n_vo), n_vo ~ N(0, sigma_vo^2 I)  (VO, between frames)
//                   r = Log(R_meas^T R_W_Bk^T R_W_B)           (stochastic cloning: the rotation
//                   H = [Jr^-1(r), 0, -Jr^-1(r) R_Bk_B^T]        at the previous frame is a state)
//                   Joseph-form update, then the clone is reset to the current rotation.
//   noise schedule  sigma_vo = sigma_0 + k_turn |angle(R_meas)|  (the more it turns per frame, the
//                   more the gyro is trusted), and while |w| > w_freeze over the frame interval the
//                   bias rows of the gain are zeroed (bias frozen: a fast turn says more about VO
//                   failure than about the bias). Joseph form keeps P consistent for that gain.
//   standstill      zero-rate update (ZARU): while the robot stands still, the mean gyro rate over
//                   the frame interval T measures the bias directly:
//                   z = mean(w_m) = b_g + n,  n ~ N(0, sigma_g^2 / T I),  H = [0, I, 0]
//                   (the usual VIO practice; without it a standstill says nothing about the bias,
//                   because the VO keeps its reference frame and gives no rotation update).
//   gyro gaps       without a gyro sample for longer than max_gyro_gap_s the prediction holds the
//                   rotation and adds a rotation random walk sigma_gap^2 dt, so VO takes over.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <span>

#include "common/config.hpp"
#include "common/types.hpp"

namespace ovo::estimator {

/// Tuning of KfFilter. Keys under "kf." (readKfOptions). The two gyro noise figures default to the
/// rig defaults; the kf estimator fills them from SensorSetup unless the config sets them.
struct KfOptions {
  double gyro_noise_density = 1.7e-4;     // sigma_g, rad/s/sqrt(Hz)
  double gyro_bias_random_walk = 2.0e-5;  // sigma_bw, rad/s^2/sqrt(Hz)
  double init_rotation_sigma_rad = 0.01;  // prior on R_W_B at initialise(), rad
  double init_bias_sigma_radps = 0.03;    // prior on b_g at initialise(), rad/s
  double vo_sigma0_rad = 5.0e-5;   // sigma_0: VO rotation noise at zero rotation, rad (well below
                                   // the chain's real frame-to-frame yaw error: at that error the
                                   // bias was left to the standstills, and came out off)
  double vo_sigma_per_rad = 0.05;  // k_turn: extra VO noise per rad turned per frame, rad/rad
  double bias_freeze_rate_radps = 0.35;   // w_freeze: bias frozen above this turning rate, rad/s
  double vo_gate_chi2 = 16.0;             // reject VO updates with r^T S^-1 r above this; 0: off
                                          // (a looser gate let a stopping robot's low-parallax
                                          // rotation through as a jump of yaw in one update)
  double zero_rate_gate_chi2 = 0.0;       // ... and zero-rate updates; 0: off
  double zero_rate_sigma_radps = 1.0e-3;  // smallest noise of one zero-rate update, rad/s: a
                                          // standing robot's idle vibration, not only the
                                          // gyro's white noise (sigma_g / sqrt(T))
  double max_gyro_gap_s = 0.05;           // longer without gyro: predict without it, s
  double gap_rotation_noise = 1.0;  // sigma_gap, rotation random walk without gyro, rad/sqrt(s)
  bool operator==(const KfOptions&) const = default;
};

KfOptions readKfOptions(const Config& config);

/// What one VO update did (for diagnostics and tests).
struct KfUpdateResult {
  bool applied = false;          // false: first frame, gated out, or degenerate
  bool gated = false;            // rejected by the chi-square gate
  bool bias_frozen = false;      // turning faster than bias_freeze_rate_radps: bias not updated
  double sigma_vo_rad = 0.0;     // noise used for this measurement (per axis)
  double turn_rate_radps = 0.0;  // rotation rate over the frame interval
  double chi2 = 0.0;             // normalised innovation squared
};

/// Error-state KF on SO(3) x R^3 with one stochastic clone (see the model at the top of the file).
/// Feed gyro samples and camera frames in time order.
class KfFilter {
 public:
  static constexpr int kErrorDim = 9;
  using Mat9 = Eigen::Matrix<double, kErrorDim, kErrorDim>;
  using Mat6 = Eigen::Matrix<double, 6, 6>;

  explicit KfFilter(const KfOptions& options = {});

  /// Starts (or restarts) at time t_ns with a rotation and bias prior (sigmas in rad and rad/s);
  /// forgets the last frame and the last gyro sample.
  void initialise(Timestamp t_ns, const Mat3& R_W_B, const Vec3& b_g, double rotation_sigma_rad,
                  double bias_sigma_radps);
  /// initialise() with the option priors.
  void initialise(Timestamp t_ns, const Mat3& R_W_B = Mat3::Identity(),
                  const Vec3& b_g = Vec3::Zero());

  /// Integrates up to sample.t_ns (rate interpolated linearly between the previous and this sample)
  /// and keeps this sample's rate for later. Samples older than the filter time are ignored.
  void propagate(const ImuSample& sample);
  /// Integrates up to t_ns holding the last gyro rate (or without gyro past max_gyro_gap_s).
  /// Also the call for a camera frame whose VO keeps its reference frame (low parallax): the clone
  /// stays at the reference, and the next update() measures R_Bref_Bcur from there.
  void propagateTo(Timestamp t_ns);

  /// A camera frame at t_ns with the VO rotation R_Bprev_Bcur since the previous (cloned) frame,
  /// so that R_W_Bcur = R_W_Bprev R_Bprev_Bcur; from a camera-frame rotation it is
  /// R_B_C R_Cprev_Ccur R_B_C^T. sigma0_rad overrides vo_sigma0_rad for this frame (e.g. from the
  /// inlier count). The first frame only sets the clone; afterwards the clone moves to t_ns.
  KfUpdateResult update(Timestamp t_ns, const Mat3& R_Bprev_Bcur,
                        std::optional<double> sigma0_rad = std::nullopt);
  /// Zero-rate update while standing still (see the model above): mean_rate_radps is the mean of
  /// the gyro samples over the last window_s seconds. Does not move the clone.
  KfUpdateResult zeroRateUpdate(const Vec3& mean_rate_radps, double window_s);
  /// A camera frame at t_ns without a VO rotation (tracking lost): only moves the clone.
  void markFrame(Timestamp t_ns);

  bool initialised() const { return t_ns_.has_value(); }
  Timestamp time() const { return t_ns_.value_or(0); }
  const Mat3& R_W_B() const { return R_W_B_; }
  const Vec3& gyroBias() const { return b_g_; }
  /// Covariance of [dtheta (rad), db_g (rad/s)], 6x6.
  Mat6 covariance() const { return P_.topLeftCorner<6, 6>(); }
  /// Full covariance including the clone, 9x9.
  const Mat9& fullCovariance() const { return P_; }
  /// sigma_vo used by the last update() that had a previous frame (rad), 0 before.
  double lastSigmaVo() const { return last_sigma_vo_rad_; }
  const KfOptions& options() const { return options_; }

 private:
  void integrate(const Vec3& w_radps, double dt_s);
  void predictWithoutGyro(double dt_s);
  void cloneCurrent(Timestamp t_ns);
  /// x <- x [+] dx and the Joseph-form covariance update for gain K; false (nothing changed) when
  /// dx is not finite.
  bool applyCorrection(const Eigen::Matrix<double, kErrorDim, 3>& K,
                       const Eigen::Matrix<double, 3, kErrorDim>& H, const Mat3& R_noise,
                       const Eigen::Matrix<double, kErrorDim, 1>& dx);

  KfOptions options_;
  std::optional<Timestamp> t_ns_;        // filter time
  std::optional<ImuSample> last_gyro_;   // last sample seen
  std::optional<Timestamp> t_clone_ns_;  // time of the last camera frame
  Mat3 R_W_B_ = Mat3::Identity();
  Vec3 b_g_ = Vec3::Zero();
  Mat3 R_W_Bk_ = Mat3::Identity();  // clone at the last camera frame
  Mat9 P_ = Mat9::Zero();
  double max_rate_since_clone_radps_ = 0.0;  // largest |w - b_g| since the last frame
  double last_sigma_vo_rad_ = 0.0;
};

/// The filter's gyro propagation from a frame at t0 to t1 (KfFilter::propagate for the samples up
/// to t1, then KfFilter::propagateTo) with the bias held, as the rotation R_B0_B1 it adds: what
/// the filter predicts for the matcher, from the frontend stage's copy of the gyro. samples: the
/// last one at or before t0 and those after it.
Mat3 predictGyroRotation(std::span<const ImuSample> samples, Timestamp t0_ns, Timestamp t1_ns,
                         const Vec3& bias_radps, double max_gap_s);

}  // namespace ovo::estimator
