#include "camera/ocam_camera.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "common/error.hpp"

namespace ovo::camera {
namespace {

constexpr double kHalfPi = 0.5 * std::numbers::pi;
// The toolbox fits invpol on theta in [-pi/2, 1.2] (theta = atan(z' / rho)): the calibrated
// field of view ends there at the latest.
constexpr double kToolboxThetaMax = 1.2;
constexpr double kRadiusStepPx = 0.05;
// Radial sampling bounds: the inverse polynomial's fit every 0.25 px and its round trip every
// kRadiusStepPx up to a 2000 px and a 5000 px radius; a larger radius (only a broken affine
// gives one, as a fuzzed calib_results.txt did, and the fine sampling of it took far too long)
// is sampled more coarsely.
constexpr int kMaxFitSamples = 8000;
constexpr double kMaxRoundTripSteps = 100000.0;

double polyval(const std::vector<double>& coeffs, double x) {
  double y = 0.0;
  for (auto it = coeffs.rbegin(); it != coeffs.rend(); ++it) y = y * x + *it;
  return y;
}

// Toolbox theta of the ray at normalised radius rho: atan(z' / rho) with z' = ss(rho).
double thetaOfRadius(const std::vector<double>& ss, double rho) {
  return std::atan2(polyval(ss, rho), rho);
}

// Coefficients of q(x) = p(scale x).
std::vector<double> scalePolynomial(std::vector<double> p, double scale) {
  double power = 1.0;
  for (double& c : p) {
    c *= power;
    power *= scale;
  }
  return p;
}

// Coefficients of q(x) = p(x + shift) (Taylor shift by repeated synthetic division).
std::vector<double> shiftPolynomial(std::vector<double> p, double shift) {
  const std::size_t n = p.size();
  for (std::size_t i = 0; i + 1 < n; ++i)
    for (std::size_t j = n - 1; j-- > i;) p[j] += shift * p[j + 1];
  return p;
}

// rho(phi) is held as a Chebyshev series in x = 2 phi / phi_scale - 1 (phi = theta + pi/2 the
// off-axis angle): well conditioned at high degree, unlike the toolbox's powers of theta.
struct Chebyshev {
  std::vector<double> c;   // rho = sum c_k T_k(x)
  std::vector<double> dc;  // d rho / d x = sum dc_k T_k(x)
  double phi_scale = 1.0;

  static double clenshaw(const std::vector<double>& coeffs, double x) {
    double b1 = 0.0, b2 = 0.0;
    for (std::size_t k = coeffs.size(); k-- > 1;) {
      const double b0 = 2.0 * x * b1 - b2 + coeffs[k];
      b2 = b1;
      b1 = b0;
    }
    return x * b1 - b2 + (coeffs.empty() ? 0.0 : coeffs[0]);
  }
  void differentiate() {
    const std::size_t n = c.size();
    dc.assign(n, 0.0);
    for (std::size_t k = n; k-- > 1;)
      dc[k - 1] = (k + 1 < n ? dc[k + 1] : 0.0) + 2.0 * static_cast<double>(k) * c[k];
    if (!dc.empty()) dc[0] *= 0.5;
  }
  double x(double phi) const { return 2.0 * phi / phi_scale - 1.0; }
  double rho(double phi) const { return clenshaw(c, x(phi)); }
  double dRhoDPhi(double phi) const { return clenshaw(dc, x(phi)) * 2.0 / phi_scale; }

  /// Interpolates the toolbox polynomial invpol(theta) (exact up to rounding).
  static Chebyshev fromInvpol(const std::vector<double>& invpol, double phi_scale) {
    Chebyshev out;
    out.phi_scale = phi_scale;
    const std::size_t n = invpol.size() + 2;
    std::vector<double> f(n);
    for (std::size_t j = 0; j < n; ++j) {
      const double xj = std::cos(std::numbers::pi * (j + 0.5) / n);
      f[j] = polyval(invpol, (xj + 1.0) * 0.5 * phi_scale - kHalfPi);
    }
    out.c.assign(n, 0.0);
    for (std::size_t k = 0; k < n; ++k) {
      for (std::size_t j = 0; j < n; ++j)
        out.c[k] += f[j] * std::cos(std::numbers::pi * k * (j + 0.5) / n);
      out.c[k] *= (k == 0 ? 1.0 : 2.0) / n;
    }
    out.differentiate();
    return out;
  }

  /// The toolbox form: powers of theta = phi - pi/2.
  std::vector<double> toInvpol() const {
    // Monomials in x from T_{k+1} = 2 x T_k - T_{k-1}.
    const std::size_t n = c.size();
    std::vector<double> mono(n, 0.0), t_prev(n, 0.0), t_cur(n, 0.0);
    t_prev[0] = 1.0;
    if (n > 1) t_cur[1] = 1.0;
    for (std::size_t k = 0; k < n; ++k) {
      const std::vector<double>& tk = k == 0 ? t_prev : t_cur;
      for (std::size_t i = 0; i < n; ++i) mono[i] += c[k] * tk[i];
      if (k >= 1 && k + 1 < n) {
        std::vector<double> t_next(n, 0.0);
        for (std::size_t i = 0; i + 1 < n; ++i) t_next[i + 1] += 2.0 * t_cur[i];
        for (std::size_t i = 0; i < n; ++i) t_next[i] -= t_prev[i];
        t_prev = std::move(t_cur);
        t_cur = std::move(t_next);
      }
    }
    // x = a theta + b with a = 2 / phi_scale, b = 2 (pi/2) / phi_scale - 1.
    const double a = 2.0 / phi_scale, b = 2.0 * kHalfPi / phi_scale - 1.0;
    return scalePolynomial(shiftPolynomial(std::move(mono), b), a);
  }
};

// Round trip rho -> phi (ss) -> rho (the projection polynomial) over [0, rho_max].
OcamRoundTrip radialRoundTrip(const std::vector<double>& ss, const Chebyshev& rho_of_phi,
                              double rho_max, double affine_gain) {
  OcamRoundTrip stats;
  double sum = 0.0;
  int n = 0;
  const double step = std::max(kRadiusStepPx, rho_max / kMaxRoundTripSteps);
  for (double rho = 0.0; rho <= rho_max; rho += step, ++n) {
    const double phi = thetaOfRadius(ss, rho) + kHalfPi;
    const double err = affine_gain * std::abs(rho_of_phi.rho(phi) - rho);
    stats.max_px = std::max(stats.max_px, err);
    sum += err;
  }
  stats.mean_px = n > 0 ? sum / n : 0.0;
  return stats;
}

// Least squares rho = t q(t), t = phi / phi_scale, q a Chebyshev series of `degree` terms in x:
// rho(0) = 0, so the optical axis maps to the centre.
Chebyshev fitRadiusOfAngle(const std::vector<double>& ss, double rho_max_px, double phi_scale,
                           int degree) {
  const int samples =
      static_cast<int>(std::clamp(rho_max_px / 0.25, 400.0, double{kMaxFitSamples}));
  Eigen::MatrixXd A(samples + 1, degree);
  Eigen::VectorXd b(samples + 1);
  for (int i = 0; i <= samples; ++i) {
    const double rho = rho_max_px * i / samples;
    const double t = (thetaOfRadius(ss, rho) + kHalfPi) / phi_scale;
    const double x = 2.0 * t - 1.0;
    double t_prev = 1.0, t_cur = x;
    for (int k = 0; k < degree; ++k) {
      const double tk = k == 0 ? 1.0 : t_cur;
      A(i, k) = t * tk;
      if (k >= 1) {
        const double t_next = 2.0 * x * t_cur - t_prev;
        t_prev = t_cur;
        t_cur = t_next;
      }
    }
    b(i) = rho;
  }
  const Eigen::VectorXd q = A.colPivHouseholderQr().solve(b);
  // t q = (x + 1) / 2 * sum q_k T_k, with x T_0 = T_1 and x T_k = (T_{k+1} + T_{k-1}) / 2.
  Chebyshev out;
  out.phi_scale = phi_scale;
  out.c.assign(degree + 1, 0.0);
  for (int k = 0; k < degree; ++k) {
    out.c[k] += 0.5 * q(k);
    if (k == 0) {
      out.c[1] += 0.5 * q(0);
    } else {
      out.c[k + 1] += 0.25 * q(k);
      out.c[k - 1] += 0.25 * q(k);
    }
  }
  out.differentiate();
  return out;
}

}  // namespace

std::vector<double> fitInvpol(const std::vector<double>& ss, double rho_max_px, int degree) {
  const double phi_scale = std::max(thetaOfRadius(ss, rho_max_px) + kHalfPi, 1e-3);
  return fitRadiusOfAngle(ss, rho_max_px, phi_scale, degree).toInvpol();
}

OcamCamera::OcamCamera(OcamParams params, const OcamOptions& options) : params_(std::move(params)) {
  const auto& p = params_;
  if (p.ss.empty() || !(p.ss.front() < 0.0))
    fail("OCamCalib model: ss[0] (a0) must be negative, got {}", p.ss.empty() ? 0.0 : p.ss.front());
  if (p.width <= 0 || p.height <= 0)
    fail("OCamCalib model: image size must be positive, got {}x{}", p.width, p.height);
  if (std::abs(p.c - p.d * p.e) < 1e-9) fail("OCamCalib model: affine c - d e is zero");
  for (double v : p.ss)
    if (!std::isfinite(v)) fail("OCamCalib model: ss has a non-finite value");
  for (double v : p.invpol)
    if (!std::isfinite(v)) fail("OCamCalib model: invpol has a non-finite value");

  // Valid radius: up to the farthest image corner, while the off-axis angle still increases and
  // stays within the toolbox's fitted range.
  double rho_corner = 0.0;
  for (const Vec2& corner :
       {Vec2(0, 0), Vec2(p.width - 1, 0), Vec2(0, p.height - 1), Vec2(p.width - 1, p.height - 1)})
    rho_corner = std::max(rho_corner, normalised(corner).norm());
  const double phi_cap = kHalfPi + kToolboxThetaMax;
  double rho_ok = 0.0, phi_prev = 0.0;
  for (double rho = kRadiusStepPx; rho <= rho_corner + 1.0; rho += kRadiusStepPx) {
    const double phi = offAxisAngle(rho);
    if (!(phi > phi_prev) || phi > phi_cap) break;
    rho_ok = rho;
    phi_prev = phi;
  }
  if (rho_ok <= 0.0) fail("OCamCalib model: the ss polynomial has no valid radius");
  rho_max_px_ = rho_ok;
  phi_max_rad_ = offAxisAngle(rho_max_px_);

  // Largest stretch of the affine [c d; e 1] turns a radial error into a pixel error.
  Eigen::Matrix2d A;
  A << p.c, p.d, p.e, 1.0;
  const double gain = Eigen::JacobiSVD<Eigen::Matrix2d>(A).singularValues()(0);
  invpol_ = p.invpol;
  Chebyshev rho_of_phi;
  if (p.invpol.empty()) {  // no inverse polynomial given: always fit one
    file_round_trip_.max_px = file_round_trip_.mean_px = std::numeric_limits<double>::infinity();
  } else {
    rho_of_phi = Chebyshev::fromInvpol(p.invpol, phi_max_rad_);
    file_round_trip_ = radialRoundTrip(p.ss, rho_of_phi, rho_max_px_, gain);
  }
  round_trip_ = file_round_trip_;
  if ((options.refit_invpol || p.invpol.empty()) &&
      file_round_trip_.max_px >= options.max_round_trip_px) {
    // Keep a margin below the bound: the radial samples stand for every pixel.
    const double target = 0.5 * options.max_round_trip_px;
    for (int degree = std::max(4, static_cast<int>(p.invpol.size()) - 1); degree <= 24; ++degree) {
      Chebyshev candidate = fitRadiusOfAngle(p.ss, rho_max_px_, phi_max_rad_, degree);
      const OcamRoundTrip stats = radialRoundTrip(p.ss, candidate, rho_max_px_, gain);
      if (stats.max_px < round_trip_.max_px) {
        invpol_ = candidate.toInvpol();
        rho_of_phi = std::move(candidate);
        round_trip_ = stats;
        refit_ = true;
      }
      if (round_trip_.max_px < target) break;
    }
  }
  rho_cheb_ = std::move(rho_of_phi.c);
  drho_cheb_ = std::move(rho_of_phi.dc);
}

Vec2 OcamCamera::normalised(const Vec2& px) const {
  const auto& p = params_;
  const double dr = px.y() - p.center_row, dc = px.x() - p.center_col;
  const double inv_det = 1.0 / (p.c - p.d * p.e);
  return Vec2((dr - p.d * dc) * inv_det, (-p.e * dr + p.c * dc) * inv_det);
}

double OcamCamera::offAxisAngle(double rho) const {
  return std::atan2(rho, -polyval(params_.ss, rho));
}

std::optional<Vec3> OcamCamera::unproject(const Vec2& px) const {
  const Vec2 m = normalised(px);  // (x', y') in OCamCalib axes (row, col)
  const double rho = m.norm();
  if (!(rho <= rho_max_px_)) return std::nullopt;
  // OCamCalib axes (row, col, backwards) -> ovo (x = col, y = row, z = forward).
  return Vec3(m.y(), m.x(), -polyval(params_.ss, rho)).normalized();
}

std::optional<Vec2> OcamCamera::project(const Vec3& p_C,
                                        Eigen::Matrix<double, 2, 3>* d_px_d_p) const {
  const auto& p = params_;
  const double x = p_C.x(), y = p_C.y(), z = p_C.z();
  const double r = std::hypot(x, y);
  const double n2 = r * r + z * z;
  if (!(n2 > 0.0)) return std::nullopt;
  const double phi = std::atan2(r, z);  // off-axis angle
  if (phi > phi_max_rad_ + 1e-9) return std::nullopt;
  // rho(phi) is the toolbox's invpol(theta) with theta = atan(z' / r) = phi - pi/2 (z' = -z),
  // held as a Chebyshev series in x = 2 phi / phi_max - 1.
  const double xc = 2.0 * phi / phi_max_rad_ - 1.0;
  const double rho = Chebyshev::clenshaw(rho_cheb_, xc);
  // d rho / d phi only for the Jacobian (a second series: most calls project without one).
  const auto dRho = [&] { return Chebyshev::clenshaw(drho_cheb_, xc) * 2.0 / phi_max_rad_; };
  // [u; v] = [col; row] = B (rho / r) (x, y) + (yc, xc), B = [1 e; d c] on ovo (x, y).
  Eigen::Matrix2d B;
  B << 1.0, p.e, p.d, p.c;
  const Vec2 centre(p.center_col, p.center_row);
  if (r < 1e-12 * std::sqrt(n2)) {
    if (d_px_d_p) {
      d_px_d_p->setZero();
      d_px_d_p->leftCols<2>() = B * (dRho() / z);
    }
    return centre;
  }
  const double g = rho / r;
  const Vec2 w(g * x, g * y);
  if (d_px_d_p) {
    const Eigen::RowVector3d d_r(x / r, y / r, 0.0);
    const Eigen::RowVector3d d_phi = Eigen::RowVector3d(z * x / r, z * y / r, -r) / n2;
    const Eigen::RowVector3d d_g = dRho() * d_phi / r - rho / (r * r) * d_r;
    Eigen::Matrix<double, 2, 3> d_w = Vec2(x, y) * d_g;
    d_w(0, 0) += g;
    d_w(1, 1) += g;
    *d_px_d_p = B * d_w;
  }
  return Vec2(B * w + centre);
}

bool OcamCamera::isValid(const Vec2& px) const {
  if (!(px.x() >= 0.0 && px.y() >= 0.0 && px.x() <= params_.width - 1 &&
        px.y() <= params_.height - 1))
    return false;
  return normalised(px).norm() <= rho_max_px_;
}

}  // namespace ovo::camera
