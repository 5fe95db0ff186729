#include "sim/height_field.hpp"

#include <algorithm>
#include <cmath>

#include "sim/random.hpp"

namespace ovo::sim {
namespace {

constexpr int kWaves = 12;
constexpr double kSpread = 1.6;  // wavelengths in [wavelength / kSpread, wavelength * kSpread]

// 1 on [lo, hi], falling to 0 over `fade` beyond either end with a quintic (C2) smoothstep;
// *d: the derivative.
double fadeOut(double v, double lo, double hi, double fade, double* d) {
  double e = 0.0, sign = 0.0;
  if (v < lo) {
    e = lo - v;
    sign = -1.0;
  } else if (v > hi) {
    e = v - hi;
    sign = 1.0;
  }
  *d = 0.0;
  if (e <= 0.0) return 1.0;
  if (e >= fade) return 0.0;
  const double s = e / fade;
  const double q = s * s * s * (s * (s * 6.0 - 15.0) + 10.0);
  const double dq = 30.0 * s * s * (s - 1.0) * (s - 1.0);
  *d = -dq / fade * sign;
  return 1.0 - q;
}

}  // namespace

HeightField::HeightField(double roughness_m, double wavelength_m, std::uint64_t seed,
                         const Rect2& plateau, double fade_m)
    : plateau_(plateau), fade_m_(fade_m) {
  Rng rng(seed);
  // Equal amplitudes a: each wave's height has variance a^2 / 2, so a = sigma sqrt(2 / n).
  const double a = roughness_m * std::sqrt(2.0 / kWaves);
  min_wavelength_ = wavelength_m / kSpread;
  for (int i = 0; i < kWaves; ++i) {
    const double lambda = wavelength_m * std::pow(kSpread, rng.uniform(-1.0, 1.0));
    const double dir = rng.uniform(0.0, 2.0 * M_PI);
    const double k = 2.0 * M_PI / lambda;
    waves_.push_back({k * std::cos(dir), k * std::sin(dir), a, rng.uniform(0.0, 2.0 * M_PI)});
    bound_ += a;
    max_slope_ += a * k;
  }
  // The window's fade: |d(w h)| <= |dw| |h| + w |dh|, |dw| <= 1.875 / fade (quintic smoothstep's
  // steepest slope) along each axis.
  max_slope_ += bound_ * 1.875 * std::sqrt(2.0) / fade_m_;
}

HeightMarch::HeightMarch(const HeightField& field, const Vec3& o, const Vec3& d, double t0,
                         double dt)
    : field_(field), o_(o), d_(d), t_(t0), dt_(dt) {
  const std::size_t n = field.waves_.size();
  c_.resize(n);
  s_.resize(n);
  cr_.resize(n);
  sr_.resize(n);
  const double x = o.x() + t0 * d.x(), y = o.y() + t0 * d.y();
  for (std::size_t i = 0; i < n; ++i) {
    const auto& w = field.waves_[i];
    double sin_theta, cos_theta;
    sinCos(w.kx * x + w.ky * y + w.phase, &sin_theta, &cos_theta);
    c_[i] = w.amplitude * cos_theta;
    s_[i] = w.amplitude * sin_theta;
    sinCos((w.kx * d.x() + w.ky * d.y()) * dt, &sr_[i], &cr_[i]);
  }
}

double HeightMarch::height() const {
  const double w = field_.window(o_.x() + t_ * d_.x(), o_.y() + t_ * d_.y(), nullptr);
  if (w == 0.0) return 0.0;
  double h = 0.0;
  for (double c : c_) h += c;
  return w * h;
}

void HeightMarch::step() {
  for (std::size_t i = 0; i < c_.size(); ++i) {
    const double c = c_[i] * cr_[i] - s_[i] * sr_[i];
    s_[i] = s_[i] * cr_[i] + c_[i] * sr_[i];
    c_[i] = c;
  }
  t_ += dt_;
}

Rect2 HeightField::support() const {
  return {plateau_.x0 - fade_m_, plateau_.x1 + fade_m_, plateau_.y0 - fade_m_,
          plateau_.y1 + fade_m_};
}

bool HeightField::supportInterval(const Vec3& o, const Vec3& d, double* t0, double* t1) const {
  const Rect2 r = support();
  double lo = 0.0, hi = 1e30;
  const double lim[2][2] = {{r.x0, r.x1}, {r.y0, r.y1}};
  for (int a = 0; a < 2; ++a) {
    const double oa = o[a], da = d[a];
    if (std::abs(da) < 1e-15) {
      if (oa < lim[a][0] || oa > lim[a][1]) return false;
      continue;
    }
    double ta = (lim[a][0] - oa) / da, tb = (lim[a][1] - oa) / da;
    if (ta > tb) std::swap(ta, tb);
    lo = std::max(lo, ta);
    hi = std::min(hi, tb);
  }
  *t0 = lo;
  *t1 = hi;
  return lo <= hi;
}

double HeightField::window(double x, double y, Vec2* grad) const {
  double dx = 0.0, dy = 0.0;
  const double wx = fadeOut(x, plateau_.x0, plateau_.x1, fade_m_, &dx);
  const double wy = fadeOut(y, plateau_.y0, plateau_.y1, fade_m_, &dy);
  if (grad) *grad = Vec2(dx * wy, wx * dy);
  return wx * wy;
}

double HeightField::height(double x, double y, Vec2* grad) const {
  Vec2 grad_w;
  const double w = window(x, y, grad ? &grad_w : nullptr);
  if (w == 0.0) {
    if (grad) grad->setZero();
    return 0.0;
  }
  double h = 0.0, gx = 0.0, gy = 0.0;
  for (const Wave& wave : waves_) {
    double sin_theta, cos_theta;
    sinCos(wave.kx * x + wave.ky * y + wave.phase, &sin_theta, &cos_theta);
    h += wave.amplitude * cos_theta;
    if (grad) {
      const double s = wave.amplitude * sin_theta;
      gx -= s * wave.kx;
      gy -= s * wave.ky;
    }
  }
  if (grad) *grad = w * Vec2(gx, gy) + h * grad_w;
  return w * h;
}

HeightSample HeightField::sample(double x, double y, const Vec2& along) const {
  HeightSample out;
  const double w = window(x, y, nullptr);
  if (w == 0.0) return out;
  for (const Wave& wave : waves_) {
    // libm here: the body's motion (and so the gyro and the ground truth) stays bit for bit
    // what it was before the renderer's faster sinCos.
    const double theta = wave.kx * x + wave.ky * y + wave.phase;
    const double c = wave.amplitude * std::cos(theta), s = wave.amplitude * std::sin(theta);
    const Vec2 k(wave.kx, wave.ky);
    const double ku = k.dot(along);
    out.h += c;
    out.grad -= s * k;
    out.hess -= c * k * k.transpose();
    out.third_uu += s * ku * ku * k;
  }
  out.h *= w;
  out.grad *= w;
  out.hess *= w;
  out.third_uu *= w;
  return out;
}

}  // namespace ovo::sim
