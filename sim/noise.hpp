// Band-limited procedural textures for the ray caster: value noise, fractal sums whose octaves fade
// out once their wavelength nears the ray's footprint (analytic anti-aliasing: a texture never
// holds detail finer than about two pixels, so features stay put from frame to frame), and disc
// layers (pebbles, grapes) with box-filtered edges.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "sim/random.hpp"

namespace ovo::sim {

inline float clamp01(float v) { return std::min(1.0f, std::max(0.0f, v)); }
inline float smoothstep(float e0, float e1, float x) {
  const float t = clamp01((x - e0) / (e1 - e0));
  return t * t * (3.0f - 2.0f * t);
}
inline float lerp(float a, float b, float t) { return a + (b - a) * t; }

/// Coverage of the interval [-r, r] by a box filter of width `width` centred at `dist`
/// (the exact area fraction of a thin bar or a cylinder's silhouette seen through a pixel).
inline float boxCoverage(double dist, double r, double width) {
  const double w = std::max(width, 1e-9);
  const double lo = std::max(dist - 0.5 * w, -r);
  const double hi = std::min(dist + 0.5 * w, r);
  return static_cast<float>(std::min(1.0, std::max(0.0, (hi - lo) / w)));
}

/// floor() for |x| < 2^31 without a libm call (the default x86-64 ISA has no rounding instruction).
inline std::int32_t fastFloor(double x) {
  const auto i = static_cast<std::int32_t>(x);
  return x < i ? i - 1 : i;
}

/// Hash of the lattice point whose pre-multiplied coordinates are hx, hy.
inline std::uint32_t latticeHash(std::uint32_t hx, std::uint32_t hy, std::uint32_t seed) {
  std::uint32_t h = hx + hy + seed;
  h ^= h >> 15;
  h *= 0x2c1b3c6dU;
  h ^= h >> 12;
  h *= 0x297a2d39U;
  h ^= h >> 15;
  return h;
}

/// Gradient noise (Perlin, "Improving noise", SIGGRAPH 2002; quintic fade, 8 gradient directions)
/// shifted to mean 0.5, std ~0.17: no plateaus or grid squares, unlike value noise.
inline float valueNoise(double x, double y, std::uint32_t seed) {
  constexpr std::uint32_t kPx = 0x8da6b343U, kPy = 0xd8163841U;
  static constexpr float kGx[8] = {1.0f,        -1.0f,        0.0f,        0.0f,
                                   0.70710678f, -0.70710678f, 0.70710678f, -0.70710678f};
  static constexpr float kGy[8] = {0.0f,        0.0f,        1.0f,         -1.0f,
                                   0.70710678f, 0.70710678f, -0.70710678f, -0.70710678f};
  const std::int32_t ix = fastFloor(x), iy = fastFloor(y);
  const std::uint32_t hx0 = static_cast<std::uint32_t>(ix) * kPx;
  const std::uint32_t hy0 = static_cast<std::uint32_t>(iy) * kPy;
  const std::uint32_t hx1 = hx0 + kPx, hy1 = hy0 + kPy;
  const float tx = static_cast<float>(x - ix), ty = static_cast<float>(y - iy);
  const auto grad = [seed](std::uint32_t hx, std::uint32_t hy, float dx, float dy) {
    const std::uint32_t g = latticeHash(hx, hy, seed) >> 29;
    return kGx[g] * dx + kGy[g] * dy;
  };
  const float ux = tx * tx * tx * (tx * (tx * 6.0f - 15.0f) + 10.0f);
  const float uy = ty * ty * ty * (ty * (ty * 6.0f - 15.0f) + 10.0f);
  const float n00 = grad(hx0, hy0, tx, ty), n10 = grad(hx1, hy0, tx - 1.0f, ty);
  const float n01 = grad(hx0, hy1, tx, ty - 1.0f), n11 = grad(hx1, hy1, tx - 1.0f, ty - 1.0f);
  return 0.5f + 0.9f * lerp(lerp(n00, n10, ux), lerp(n01, n11, ux), uy);
}

/// Fractal sum of `octaves` value-noise octaves starting at wavelength `wavelength_m`, each half
/// the previous one with amplitude x `gain`, each on a lattice turned by another multiple of the
/// golden angle (no grid-aligned artefacts); normalised to mean 0.5. Octaves whose wavelength is
/// below 4 footprints fade to their mean and those below 2 footprints are skipped (band limit).
inline float fbm(double x, double y, double wavelength_m, int octaves, float gain,
                 double footprint_m, std::uint32_t seed) {
  // cos / sin of k * 2.39996 rad (golden angle), k = 0..9.
  static constexpr double kCos[10] = {1.0,      -0.737369, 0.087426,  0.608439, -0.984713,
                                      0.843755, -0.259604, -0.460907, 0.939321, -0.924346};
  static constexpr double kSin[10] = {0.0,       0.675490, -0.996171, 0.793601, -0.174182,
                                      -0.536728, 0.965715, -0.887448, 0.343039, 0.381556};
  double freq = 1.0 / wavelength_m;
  double ratio = wavelength_m / std::max(footprint_m, 1e-9);  // wavelength / footprint
  float amp = 1.0f, sum = 0.0f, norm = 0.0f;
  for (int o = 0; o < octaves; ++o, ratio *= 0.5) {
    if (ratio <= 2.0) {
      for (int r = o; r < octaves; ++r, amp *= gain) norm += amp;  // the rest contribute their mean
      break;
    }
    const float w = clamp01(static_cast<float>((ratio - 2.0) * 0.5));
    const int k = o % 10;
    const double u = (kCos[k] * x - kSin[k] * y) * freq, v = (kSin[k] * x + kCos[k] * y) * freq;
    const float n = valueNoise(u + 17.31 * o, v - 9.17 * o, seed + 7919u * o);
    sum += amp * (w * (n - 0.5f));
    norm += amp;
    freq *= 2.0;
    amp *= gain;
  }
  // Each octave's deviation has std ~0.17; normalising by the amplitude sum keeps the range [0, 1].
  return 0.5f + sum / std::max(norm, 1e-6f);
}

/// One disc (pebble, grape, leaf spot) per lattice cell of size `cell_m`, present with probability
/// `prob`, radius in [r_min, r_max] (kept inside its cell); returns the disc's box-filtered
/// coverage at (x, y), faded towards the mean coverage when the footprint reaches the radius, and
/// its hash in *id (for its tone).
inline float discLayer(double x, double y, double cell_m, float prob, double r_min, double r_max,
                       double footprint_m, std::uint32_t seed, std::uint32_t* id) {
  const std::int32_t ix = fastFloor(x / cell_m), iy = fastFloor(y / cell_m);
  const double cx = ix, cy = iy;
  const std::uint32_t h = hash2(ix, iy, seed);
  *id = mix64(h) & 0xffffffffu;
  const float mean_r = static_cast<float>(0.5 * (r_min + r_max));
  const float mean_cov = prob * 3.14159265f * mean_r * mean_r / static_cast<float>(cell_m * cell_m);
  const float fade = clamp01(static_cast<float>((footprint_m / mean_r - 0.5) / 1.5));
  if (fade >= 1.0f) return mean_cov;
  float cov = 0.0f;
  if (hashUnit(h) < prob) {
    const double r = r_min + (r_max - r_min) * hashUnit(h * 0x9e3779b1u);
    const double px = (cx * cell_m) + r + (cell_m - 2.0 * r) * hashUnit(h ^ 0x5bd1e995u);
    const double py =
        (cy * cell_m) + r + (cell_m - 2.0 * r) * hashUnit((h ^ 0x68e31da4u) * 0x85ebca6bu);
    const double d = std::sqrt((x - px) * (x - px) + (y - py) * (y - py));
    cov = clamp01(static_cast<float>((r - d) / std::max(footprint_m, 1e-9) + 0.5));
  }
  return lerp(cov, mean_cov, fade);
}

}  // namespace ovo::sim
