// Deterministic, platform-independent random numbers for the simulator: SplitMix64 streams (one per
// purpose, derived from the scenario seed) and stateless integer hashes for procedural textures.
// std::normal_distribution is implementation-defined, so the simulator never uses it.
// One draw a statement: the arguments of a call (and the operands of + or *) are evaluated in an
// unspecified order, and GCC takes a call's arguments last to first on x86-64 but first to last on
// aarch64, so `Vec3(rng.normal(), rng.normal(), rng.normal())` gave other data on ARM. Where a
// vector is drawn, its components are drawn in the order that x86-64 gave (z, y, x), so that the
// datasets made before are the same.
#pragma once

#include <cmath>
#include <cstdint>

namespace ovo::sim {

/// SplitMix64 finaliser (Steele, Lea, Flood, "Fast splittable pseudorandom number generators",
/// OOPSLA 2014): a bijective 64-bit mix.
inline std::uint64_t mix64(std::uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

/// Seed of an independent stream `purpose` (a small constant per use) of the scenario seed.
inline std::uint64_t subSeed(std::uint64_t seed, std::uint64_t purpose) {
  return mix64(seed ^ mix64(purpose + 0x9e3779b97f4a7c15ULL));
}

/// A SplitMix64 random stream with uniform and normal draws (Box-Muller).
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    state_ += 0x9e3779b97f4a7c15ULL;
    return mix64(state_);
  }
  /// Uniform in [0, 1).
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Standard normal.
  double normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u1 = uniform();
    while (u1 <= 1e-300) u1 = uniform();
    const double u2 = uniform();
    const double r = std::sqrt(-2.0 * std::log(u1));
    spare_ = r * std::sin(2.0 * M_PI * u2);
    has_spare_ = true;
    return r * std::cos(2.0 * M_PI * u2);
  }
  /// Approximately standard normal (Irwin-Hall sum of four uniforms; tails cut at 3.5 sigma): a
  /// cheap draw for per-pixel image noise.
  double approxNormal() {
    const std::uint64_t r = next();
    const double sum =
        static_cast<double>((r & 0xffff) + ((r >> 16) & 0xffff) + ((r >> 32) & 0xffff) + (r >> 48));
    return (sum * (1.0 / 65536.0) - 2.0) * 1.7320508075688772;
  }

 private:
  std::uint64_t state_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

/// Stateless 32-bit hash of a 2-D lattice point and a seed (texture lattices, per-object draws).
inline std::uint32_t hash2(std::int32_t x, std::int32_t y, std::uint32_t seed) {
  std::uint32_t h = seed ^ 0x27d4eb2dU;
  h ^= static_cast<std::uint32_t>(x) * 0x85ebca6bU;
  h = (h ^ (h >> 15)) * 0x2c1b3c6dU;
  h ^= static_cast<std::uint32_t>(y) * 0xc2b2ae35U;
  h = (h ^ (h >> 13)) * 0x297a2d39U;
  return h ^ (h >> 16);
}

/// Uniform float in [0, 1) from a hash.
inline float hashUnit(std::uint32_t h) { return static_cast<float>(h >> 8) * (1.0f / 16777216.0f); }

}  // namespace ovo::sim
