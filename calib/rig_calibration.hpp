// The camera-to-body rotation R_B_C and the camera-gyro time offset t_d (image stamp = gyro-clock
// time + t_d, DESIGN section 12) from a sequence with rotation: the frontend's frame-to-frame
// camera rotations against the gyro integrated over the same (shifted) intervals.
//  1. t_d by a search over candidate offsets: the correlation of the camera's and the gyro's
//     angular speeds (norms, so the rotation between the frames does not matter);
//  2. R_B_C in closed form: the rotation that best maps the camera rotations' axis-angle vectors
//     onto the body's (log dR_B = R_B_C log dR_C; Kabsch/SVD), with the gyro bias fitted in turn;
//  3. R_B_C, t_d and the gyro bias refined together by Ceres (robust loss on the rotation
//     residuals Log(dR_B(t_d, b)^T R_B_C dR_C R_B_C^T)), each weighted by its camera rotation's
//     covariance (when the rotations carry one) and the gyro's noise over the pair.
#pragma once

#include <functional>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "camera/camera.hpp"
#include "common/types.hpp"
#include "frontend/frontend.hpp"

namespace ovo::calib {

struct RigCalibrationOptions {
  double max_offset_s = 0.1;           // offsets searched: [-max, max]
  double search_step_s = 0.0005;       // grid of the correlation search
  double min_rotation_deg = 0.2;       // frame pairs rotating less take no part in the Kabsch step
  int min_pairs = 20;                  // fewer usable frame pairs: an error
  double min_axis_spread_deg = 3.0;    // rotations about one axis only leave R_B_C undetermined
  double gyro_noise_density = 1.7e-4;  // rad/s/sqrt(Hz): the gyro's share of a pair's residual
};

/// A camera rotation between two frames (image stamps): X_1 = R_C1_C0 X_0.
struct CameraRotation {
  Timestamp t0_ns = 0, t1_ns = 0;
  Mat3 R_C1_C0 = Mat3::Identity();
  int inliers = 0;
  /// Covariance of the rotation's axis-angle vector log(R_C1_C0^T) in C0 [rad^2]; zero when
  /// unknown (then every pair is weighted alike).
  Mat3 covariance = Mat3::Zero();
  /// The pair had too little parallax for the frontend's translation (a turn on the spot, a
  /// stop): its rotation's errors are of another size, so its weights are scaled on their own.
  bool low_parallax = false;
};

struct RigCalibration {
  Mat3 R_B_C = Mat3::Identity();
  double time_offset_s = 0.0;  // t_d: image stamp = gyro-clock time + t_d
  Vec3 gyro_bias_radps = Vec3::Zero();
  double coarse_offset_s = 0.0;  // from the correlation search
  double correlation = 0.0;      // of the angular speeds at the coarse offset
  Mat3 R_B_C_closed_form = Mat3::Identity();
  double residual_rms_deg = 0.0;  // of the refined rotation residuals
  int pairs_used = 0;
  double median_rate_dps = 0.0;      // median camera rotation rate over the pairs
  double rotation_change_deg = 0.0;  // angle between R_B_C and the prior
  std::vector<std::string> notes;
};

/// From camera rotations (e.g. a frontend's) and gyro samples (body frame, sorted). Throws
/// ovo::Error when the motion cannot determine the answer (too few rotating pairs, rotation
/// about a single axis, no correlation peak inside the search range).
RigCalibration calibrateRigFromRotations(const std::vector<CameraRotation>& rotations,
                                         const std::vector<ImuSample>& gyro,
                                         const RigCalibrationOptions& options,
                                         const Mat3& R_B_C_prior = Mat3::Identity());

/// What calibrateRig needs of a dataset (calib/ reads no files: the caller provides images).
struct RigInput {
  const camera::Camera* camera = nullptr;
  frontend::FrontendOptions frontend;
  std::size_t frame_count = 0;
  std::function<Timestamp(std::size_t)> frame_stamp;
  std::function<cv::Mat(std::size_t)> frame_image;
  std::vector<ImuSample> gyro;
  Mat3 R_B_C_prior = Mat3::Identity();
};

/// Runs the frontend over the frames (no rotation prior) and calibrates from its rotations.
RigCalibration calibrateRig(const RigInput& input, const RigCalibrationOptions& options);

/// The frame-to-frame camera rotations the frontend finds (pairs whose relative pose failed are
/// left out).
std::vector<CameraRotation> frontendRotations(const RigInput& input);

}  // namespace ovo::calib
