// Scaramuzza's OCamCalib omnidirectional model (DESIGN.md section 3; Scaramuzza, Martinelli,
// Siegwart, "A Toolbox for Easily Calibrating Omnidirectional Cameras", IROS 2006), in ovo's camera
// frame (x right, y down, z forward). Pixels are Vec2(u, v) = (column, row).
#pragma once

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "common/types.hpp"

namespace ovo::camera {

/// The numbers of an OCamCalib `calib_results.txt`, in the toolbox's own conventions.
struct OcamParams {
  std::vector<double> ss;      // a0..aN of z'(rho) (pixels), a0 < 0, a1 = 0
  std::vector<double> invpol;  // rho(theta) = sum p_i theta^i (pixels), theta = atan(z' / |(x',
                               // y')|); empty: fitted from ss
  double center_row = 0.0;     // xc (pixels, from 0)
  double center_col = 0.0;     // yc (pixels, from 0)
  double c = 1.0, d = 0.0, e = 0.0;  // affine: [row; col] = [c d; e 1] [x'; y'] + [xc; yc]
  int height = 0;                    // pixels
  int width = 0;                     // pixels
};

/// How the model treats the file's approximate inverse polynomial.
struct OcamOptions {
  bool refit_invpol = true;         // refit when the round trip reaches max_round_trip_px
  double max_round_trip_px = 0.01;  // |project(unproject(px)) - px| bound over the valid area
};

/// Round-trip error of project(unproject(px)) over the valid radius range (pixels).
struct OcamRoundTrip {
  double max_px = 0.0;
  double mean_px = 0.0;
};

/// OCamCalib camera. Valid area: inside the image, at a normalised radius rho where the ss
/// polynomial's off-axis angle still increases with rho, up to the image's farthest corner and
/// up to theta = 1.2 rad (159 deg off-axis), the range the toolbox fits invpol on.
class OcamCamera {
 public:
  /// Throws ovo::Error when the parameters are unusable (a0 >= 0, empty ss, c - d e = 0, size <=
  /// 0).
  explicit OcamCamera(OcamParams params, const OcamOptions& options = {});

  std::optional<Vec3> unproject(const Vec2& px) const;
  std::optional<Vec2> project(const Vec3& p_C,
                              Eigen::Matrix<double, 2, 3>* d_px_d_p = nullptr) const;
  bool isValid(const Vec2& px) const;
  int width() const { return params_.width; }
  int height() const { return params_.height; }
  double focalPx() const { return -params_.ss.front(); }

  /// The parameters as read (the file's own invpol).
  const OcamParams& params() const { return params_; }
  /// The inverse polynomial project() uses: the file's, or the refit one.
  const std::vector<double>& projectionInvpol() const { return invpol_; }
  bool invpolRefit() const { return refit_; }
  /// Round trip of the file's invpol and of the one in use, sampled every 0.05 px of radius.
  OcamRoundTrip fileRoundTrip() const { return file_round_trip_; }
  OcamRoundTrip roundTrip() const { return round_trip_; }
  /// Largest valid normalised radius (pixels) and off-axis angle (radians).
  double maxRadiusPx() const { return rho_max_px_; }
  double maxOffAxisRad() const { return phi_max_rad_; }

 private:
  Vec2 normalised(const Vec2& px) const;  // (x', y') of DESIGN section 3
  double offAxisAngle(double rho) const;  // angle between the ray and the optical axis

  OcamParams params_;
  std::vector<double> invpol_;  // toolbox form: powers of theta
  // The same rho(phi) as a Chebyshev series in x = 2 phi / phi_max - 1 (phi the off-axis angle),
  // and its derivative d rho / d x.
  std::vector<double> rho_cheb_, drho_cheb_;
  bool refit_ = false;
  OcamRoundTrip file_round_trip_, round_trip_;
  double rho_max_px_ = 0.0;
  double phi_max_rad_ = 0.0;
};

/// Least-squares fit of rho(theta) as a polynomial in theta (toolbox convention) of `degree`,
/// over rho in [0, rho_max_px], constrained to rho(-pi/2) = 0 so the optical axis maps to the
/// centre. Returns invpol coefficients p_0..p_degree.
std::vector<double> fitInvpol(const std::vector<double>& ss, double rho_max_px, int degree);

}  // namespace ovo::camera
