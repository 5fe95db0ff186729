// The three camera models' projections written once as templates, so that the calibration's
// Ceres refinement differentiates them automatically (Jets) and the rest of calib/ evaluates them
// in double. Points are in ovo's camera frame C (x right, y down, z forward); pixels are
// (u, v) = (column, row). The parameter layouts are the ones calib/camera_calibration.cpp
// optimises; camera/ holds the models used at run time.
#pragma once

#include <ceres/jet.h>

#include <algorithm>
#include <cmath>

namespace ovo::calib {

/// Coefficients a0..a7 of OCamCalib's ss polynomial are held, unused ones at zero.
constexpr int kOcamMaxCoeffs = 8;

inline double scalarPart(double x) { return x; }
template <typename T, int N>
double scalarPart(const ceres::Jet<T, N>& x) {
  return x.a;
}

/// OCamCalib's world2cam (Scaramuzza, Martinelli, Siegwart, IROS 2006) on a point in C.
/// ss(rho) = sum_k ss_scale * b_k (rho / ss_scale)^k is the toolbox's a_k = b_k ss_scale^(1-k)
/// (the scale keeps the optimised coefficients of order one). centre = (row, col); affine =
/// (c, d, e) with [row; col] = [c d; e 1] [x'; y'] + centre, where (x', y') = rho * (y_C, x_C) /
/// |(x_C, y_C)| in the toolbox's axes (row, column, backwards: z' = -z_C).
/// rho solves ss(rho) r + rho z = 0 (the ray (rho, ss(rho)) along (r, -z), r = |(x, y)|): the
/// first root in (0, rho_max_px] is found in double, then one Newton step in T carries the
/// derivatives (implicit function theorem). False when there is no root (outside the model).
template <typename T>
bool projectOcam(const T* b, double ss_scale, const T* centre, const T* affine, const T* p_C,
                 double rho_max_px, T* uv) {
  using std::sqrt;
  const T& x = p_C[0];
  const T& y = p_C[1];
  const T& z = p_C[2];
  const T r = sqrt(x * x + y * y + T(1e-300));
  const double rs = scalarPart(r), zs = scalarPart(z);
  double bs[kOcamMaxCoeffs];
  for (int k = 0; k < kOcamMaxCoeffs; ++k) bs[k] = scalarPart(b[k]);
  // g(rho) = ss(rho) r + rho z in double, with its derivative.
  const auto g = [&](double rho, double* dg) {
    const double t = rho / ss_scale;
    double s = 0.0, ds = 0.0;
    for (int k = kOcamMaxCoeffs - 1; k >= 0; --k) {
      ds = ds * t + s;
      s = s * t + bs[k];
    }
    if (dg) *dg = ds * rs + zs;
    return ss_scale * s * rs + rho * zs;
  };
  if (!(g(0.0, nullptr) < 0.0)) return false;  // a0 must be negative
  constexpr int kSteps = 256;
  const double h = rho_max_px / kSteps;
  double lo = 0.0, hi = -1.0;
  for (int i = 1; i <= kSteps; ++i) {
    if (g(i * h, nullptr) >= 0.0) {
      lo = (i - 1) * h;
      hi = i * h;
      break;
    }
  }
  if (hi < 0.0) return false;
  double rho = 0.5 * (lo + hi);
  for (int it = 0; it < 60 && hi - lo > 1e-12 * (1.0 + hi); ++it) {
    double dg = 0.0;
    const double gv = g(rho, &dg);
    if (gv < 0.0)
      lo = rho;
    else
      hi = rho;
    double next = dg > 0.0 ? rho - gv / dg : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::abs(next - rho) < 1e-13 * (1.0 + rho)) {
      rho = next;
      break;
    }
    rho = next;
  }
  // One Newton step in T from the converged root: value unchanged, derivatives implicit.
  const T t = T(rho / ss_scale);
  T s = T(0.0), ds = T(0.0);
  for (int k = kOcamMaxCoeffs - 1; k >= 0; --k) {
    ds = ds * t + s;
    s = s * t + b[k];
  }
  const T gT = ss_scale * s * r + T(rho) * z;
  const T dgT = ds * r + z;
  if (!(scalarPart(dgT) > 0.0)) return false;
  const T rho_T = T(rho) - gT / dgT;
  const T xr = rho_T * y / r;  // toolbox x' (row direction)
  const T yr = rho_T * x / r;  // toolbox y' (column direction)
  const T row = affine[0] * xr + affine[1] * yr + centre[0];
  const T col = affine[2] * xr + yr + centre[1];
  uv[0] = col;
  uv[1] = row;
  return true;
}

/// Kannala-Brandt: intrinsics (fx, fy, cx, cy), distortion (k1..k4),
/// theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8).
template <typename T>
bool projectKannalaBrandt(const T* k, const T* d, const T* p_C, T* uv) {
  using std::atan2;
  using std::sqrt;
  const T r = sqrt(p_C[0] * p_C[0] + p_C[1] * p_C[1] + T(1e-300));
  const T theta = atan2(r, p_C[2]);
  const T t2 = theta * theta;
  const T theta_d = theta * (T(1.0) + t2 * (d[0] + t2 * (d[1] + t2 * (d[2] + t2 * d[3]))));
  uv[0] = k[0] * theta_d * p_C[0] / r + k[2];
  uv[1] = k[1] * theta_d * p_C[1] / r + k[3];
  return true;
}

/// Pinhole radial-tangential: intrinsics (fx, fy, cx, cy), distortion (k1, k2, p1, p2). False for
/// points less than ~1 degree in front of the image plane.
template <typename T>
bool projectPinholeRadtan(const T* k, const T* d, const T* p_C, T* uv) {
  if (!(scalarPart(p_C[2]) > 0.02 * std::hypot(scalarPart(p_C[0]), scalarPart(p_C[1]))))
    return false;
  const T x = p_C[0] / p_C[2], y = p_C[1] / p_C[2];
  const T r2 = x * x + y * y;
  const T radial = T(1.0) + r2 * (d[0] + r2 * d[1]);
  const T xd = x * radial + T(2.0) * d[2] * x * y + d[3] * (r2 + T(2.0) * x * x);
  const T yd = y * radial + d[2] * (r2 + T(2.0) * y * y) + T(2.0) * d[3] * x * y;
  uv[0] = k[0] * xd + k[2];
  uv[1] = k[1] * yd + k[3];
  return true;
}

}  // namespace ovo::calib
