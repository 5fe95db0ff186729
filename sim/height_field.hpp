// Uneven ground for the simulated vineyard: a smooth random height field h(x, y) added vertically
// to the terrain plane (undulations, wheel ruts). A sum of random-phase plane waves whose height
// has a given standard deviation and whose wavelengths spread around a given one; analytic
// derivatives up to the third order (the robot's body follows the local normal, and its gyro and
// accelerometer read the derivatives of that motion), deterministic for a seed. A smooth window
// fades the field out beyond the vineyard and its headlands, so distant ground is the plane.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <limits>
#include <cstdint>
#include <vector>

#include "common/types.hpp"

namespace ovo::sim {

/// sin and cos of x together, within a few ulp of libm's for |x| up to ~1e5 (a wave's phase
/// over a vineyard is at most a few thousand radians; NaN for a non-finite x): x reduced by the
/// nearest multiple of pi/2 (pi/2 in two parts, Cody and Waite), then the minimax polynomials of fdlibm's kernels on
/// [-pi/4, pi/4]. Inline and branch-light: libm's general sincos (for any argument) dominated the
/// render of rough ground, whose rays meet a sum of waves.
inline void sinCos(double x, double* s, double* c) {
  constexpr double kTwoOverPi = 6.36619772367581382433e-01;
  constexpr double kPio2a = 1.57079632673412561417e+00;  // the first 33 bits of pi/2
  constexpr double kPio2b = 6.07710050650619224932e-11;  // pi/2 - kPio2a (to 3.5e-27)
  if (!std::isfinite(x)) {
    *s = *c = std::numeric_limits<double>::quiet_NaN();
    return;
  }
  const double k = std::nearbyint(x * kTwoOverPi);
  const double r = (x - k * kPio2a) - k * kPio2b;
  const double z = r * r;
  const double sin_r =
      r + r * z *
              (-1.66666666666666324348e-01 +
               z * (8.33333333332248946124e-03 +
                    z * (-1.98412698298579493134e-04 +
                         z * (2.75573137070700676789e-06 +
                              z * (-2.50507602534068634195e-08 + z * 1.58969099521155010221e-10)))));
  const double cos_r =
      1.0 - 0.5 * z +
      z * z *
          (4.16666666666666019037e-02 +
           z * (-1.38888888888741095749e-03 +
                z * (2.48015872894767294178e-05 +
                     z * (-2.75573143513906633035e-07 +
                          z * (2.08757232129817482790e-09 + z * -1.13596475577881948265e-11)))));
  const long q = static_cast<long>(k) & 3;
  const double sv = (q & 1) ? cos_r : sin_r;
  const double cv = (q & 1) ? sin_r : cos_r;
  *s = (q & 2) ? -sv : sv;
  *c = ((q + 1) & 2) ? -cv : cv;
}

/// Height, gradient, Hessian and third derivatives of a height field at one point (metres; the
/// coordinates are world x and y).
struct HeightSample {
  double h = 0.0;
  Vec2 grad = Vec2::Zero();
  Eigen::Matrix2d hess = Eigen::Matrix2d::Zero();
  /// Third derivatives applied twice to `along` (see HeightField::sample): sum_jk h_ijk u_j u_k.
  Vec2 third_uu = Vec2::Zero();
};

/// Axis-aligned rectangle in world x, y (metres).
struct Rect2 {
  double x0 = 0.0, x1 = 0.0, y0 = 0.0, y1 = 0.0;
};

class HeightField {
 public:
  /// `plateau`: where the field has its full amplitude (the vineyard and its headlands); it fades
  /// to zero over `fade_m` around it. The field's height has standard deviation `roughness_m`
  /// (over its random phases), its waves' wavelengths are spread log-uniformly over
  /// [wavelength / 1.6, wavelength * 1.6] in random directions.
  HeightField(double roughness_m, double wavelength_m, std::uint64_t seed, const Rect2& plateau,
              double fade_m = 10.0);

  /// Height and gradient (the window included).
  double height(double x, double y, Vec2* grad = nullptr) const;
  /// Height and its derivatives up to the third order at (x, y); third_uu is taken along `along`.
  /// The window's own derivatives are left out: exact on the plateau (where the robot drives).
  HeightSample sample(double x, double y, const Vec2& along) const;

  /// No height exceeds this in magnitude (m).
  double bound() const { return bound_; }
  /// No slope (gradient norm) exceeds this, the window's fade included.
  double maxSlope() const { return max_slope_; }
  /// The shortest wavelength of the field's waves (m).
  double minWavelength() const { return min_wavelength_; }
  const Rect2& plateau() const { return plateau_; }
  /// The rectangle outside which the field is zero.
  Rect2 support() const;
  /// Ray parameters [t0, t1] where o + t d (x, y only) is inside support(); false when never.
  bool supportInterval(const Vec3& o, const Vec3& d, double* t0, double* t1) const;

 private:
  struct Wave {
    double kx, ky;  // wave vector (rad/m)
    double amplitude, phase;
  };
  double window(double x, double y, Vec2* grad) const;

  std::vector<Wave> waves_;
  Rect2 plateau_;
  double fade_m_ = 10.0;
  double bound_ = 0.0;
  double max_slope_ = 0.0;
  double min_wavelength_ = 1.0;

  friend class HeightMarch;
};

/// Heights of a field along a ray at t0, t0 + dt, t0 + 2 dt, ...: each wave's phase advances by
/// a fixed angle a step, so a step costs a 2-D rotation per wave instead of a cosine.
class HeightMarch {
 public:
  HeightMarch(const HeightField& field, const Vec3& o, const Vec3& d, double t0, double dt);
  double t() const { return t_; }
  /// Height of the field below the ray at t().
  double height() const;
  void step();

 private:
  const HeightField& field_;
  Vec3 o_, d_;
  double t_, dt_;
  std::vector<double> c_, s_, cr_, sr_;  // a cos(theta), a sin(theta); cos, sin of the step
};

}  // namespace ovo::sim
