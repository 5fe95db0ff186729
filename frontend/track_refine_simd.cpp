// The Lucas-Kanade step of kernels.hpp (alignPatchTranslation; what it does and what it is worth:
// track_refine.hpp). This file gets OVO_KERNEL_FLAGS. Patches are rows of kLkStride floats with
// zero weight past the patch, and every sum keeps one accumulator per column, so that the
// compiler vectorises the loops for the native ISA: a float sum into a single accumulator does not
// vectorise without reassociation, and the scalar loops are markedly slower (BM_TrackRefine).
#include <algorithm>
#include <cmath>
#include <cstddef>

#include "frontend/kernels.hpp"

namespace ovo::frontend::kernels {
namespace {

constexpr int S = kLkStride;
constexpr int kTemplateStride = 2 * S;  // the template keeps a one-pixel ring for its gradients

// Bilinear sampling of the grid whose top-left sample is at (x0, y0).
struct Sampler {
  const std::uint8_t* top = nullptr;  // pixel (floor x0, floor y0)
  int stride = 0;
  float w00 = 0.f, w01 = 0.f, w10 = 0.f, w11 = 0.f;
  int readable = 0;  // pixels readable from each row's start
};

// False if the side x side grid at (x0, y0) is not inside the image (its last sample's
// neighbours included).
inline bool makeSampler(const GreyImage& img, double x0, double y0, int side, Sampler* s) {
  if (!(x0 >= 0.0) || !(y0 >= 0.0) || !(x0 + side < img.width) || !(y0 + side < img.height))
    return false;
  const int ix = static_cast<int>(x0), iy = static_cast<int>(y0);  // x0, y0 >= 0: the floor
  const float ax = static_cast<float>(x0 - ix), ay = static_cast<float>(y0 - iy);
  s->top = img.data + static_cast<std::ptrdiff_t>(iy) * img.stride + ix;
  s->stride = img.stride;
  s->w00 = (1.f - ax) * (1.f - ay);
  s->w01 = ax * (1.f - ay);
  s->w10 = (1.f - ax) * ay;
  s->w11 = ax * ay;
  s->readable = img.width - ix;
  return true;
}

inline float sampleAt(const Sampler& s, const std::uint8_t* a, const std::uint8_t* b, int c) {
  return s.w00 * a[c] + s.w01 * a[c + 1] + s.w10 * b[c] + s.w11 * b[c + 1];
}

// Calls f(c, sample) for the columns c of row r of the grid in [0, width): samples in columns
// below `side`; past it, samples too where the image has them (their weights are zero), else 0.
// Whole rows where the image allows (always but at its right edge), so that the loop vectorises.
// f takes each sample as it comes, so the iterations' sums keep it in registers (a row stored as
// narrow vectors and loaded again as one wide vector stalled on the store forwarding).
template <int width, typename F>
inline void forEachSample(const Sampler& s, int r, int side, F&& f) {
  const std::uint8_t* a = s.top + static_cast<std::ptrdiff_t>(r) * s.stride;
  const std::uint8_t* b = a + s.stride;
  if (width < s.readable) {
    for (int c = 0; c < width; ++c) f(c, sampleAt(s, a, b, c));
  } else {
    for (int c = 0; c < width; ++c) f(c, c < side ? sampleAt(s, a, b, c) : 0.f);
  }
}

inline float laneSum(const float* lanes) {
  float sum = 0.f;
  for (int c = 0; c < S; ++c) sum += lanes[c];
  return sum;
}

}  // namespace

bool alignPatchTranslation(const GreyImage& prev, double x_prev, double y_prev,
                           const GreyImage& cur, const float* weight, float weight_sum, int half,
                           int max_iterations, double max_shift, double min_gradient, double* x,
                           double* y) {
  const int n = 2 * half + 1;
  if (half < 1 || half > kLkMaxHalf) return false;
  const float* w = weight;

  // The template with its ring: n + 2 rows of n + 2 samples, zero past them.
  alignas(64) float tpl[(S + 1) * kTemplateStride];
  Sampler ts;
  if (!makeSampler(prev, x_prev - half - 1, y_prev - half - 1, n + 2, &ts)) return false;
  for (int r = 0; r < n + 2; ++r) {
    float* row = tpl + r * kTemplateStride;
    forEachSample<kTemplateStride>(ts, r, n + 2, [row](int c, float v) { row[c] = v; });
  }

  // Its central-difference gradients on the inner grid, and their weighted means.
  alignas(64) float t0[S * S], gx[S * S], gy[S * S];
  alignas(64) float at[S] = {}, agx[S] = {}, agy[S] = {};
  for (int r = 0; r < n; ++r) {
    const float* up = tpl + r * kTemplateStride + 1;
    const float* mid = up + kTemplateStride;
    const float* down = mid + kTemplateStride;
    for (int c = 0; c < S; ++c) {
      const int k = r * S + c;
      t0[k] = mid[c];
      gx[k] = 0.5f * (mid[c + 1] - mid[c - 1]);
      gy[k] = 0.5f * (down[c] - up[c]);
      at[c] += w[k] * t0[k];
      agx[c] += w[k] * gx[k];
      agy[c] += w[k] * gy[k];
    }
  }
  const float t_mean = laneSum(at) / weight_sum, mgx = laneSum(agx) / weight_sum,
              mgy = laneSum(agy) / weight_sum;

  // Brightness offset compensation: gradients and template enter with their means removed.
  // wgx, wgy are the weighted mean-free gradients; the Hessian and the template's part of the
  // right-hand side are fixed for the step.
  alignas(64) float wgx[S * S], wgy[S * S];
  alignas(64) float axx[S] = {}, axy[S] = {}, ayy[S] = {}, asx[S] = {}, asy[S] = {}, acx[S] = {},
                    acy[S] = {};
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < S; ++c) {
      const int k = r * S + c;
      const float dx = gx[k] - mgx, dy = gy[k] - mgy, t = t0[k] - t_mean;
      wgx[k] = w[k] * dx;
      wgy[k] = w[k] * dy;
      axx[c] += wgx[k] * dx;
      axy[c] += wgx[k] * dy;
      ayy[c] += wgy[k] * dy;
      asx[c] += wgx[k];
      asy[c] += wgy[k];
      acx[c] += wgx[k] * t;
      acy[c] += wgy[k] * t;
    }
  }
  const double hxx = laneSum(axx), hxy = laneSum(axy), hyy = laneSum(ayy);
  const double tr = hxx + hyy, det = hxx * hyy - hxy * hxy;
  const double lambda_min = 0.5 * (tr - std::sqrt(std::max(0.0, tr * tr - 4.0 * det)));
  if (!(lambda_min >= min_gradient * min_gradient * weight_sum)) return false;
  // sum wgx is zero up to rounding; kept so that a brightness offset cancels exactly.
  const double sgx = laneSum(asx), sgy = laneSum(asy), cx = laneSum(acx), cy = laneSum(acy);

  const double x_start = *x, y_start = *y;
  double px = x_start, py = y_start;
  for (int it = 0; it < max_iterations; ++it) {
    Sampler s;
    if (!makeSampler(cur, px - half, py - half, n, &s)) return false;
    // Right-hand side sum wgx ((patch - patch mean) - (template - its mean)), expanded so that
    // one pass over the patch gives it.
    alignas(64) float ap[S] = {}, apx[S] = {}, apy[S] = {};
    for (int r = 0; r < n; ++r) {
      const float* wr = w + r * S;
      const float* gxr = wgx + r * S;
      const float* gyr = wgy + r * S;
      forEachSample<S>(s, r, n, [&](int c, float v) {
        ap[c] += wr[c] * v;
        apx[c] += gxr[c] * v;
        apy[c] += gyr[c] * v;
      });
    }
    const double p_mean = laneSum(ap) / weight_sum;
    const double bx = laneSum(apx) - p_mean * sgx - cx, by = laneSum(apy) - p_mean * sgy - cy;
    // Inverse compositional step: the template moved by d matches, so the point moves by -d.
    const double dx = (hyy * bx - hxy * by) / det, dy = (hxx * by - hxy * bx) / det;
    px -= dx;
    py -= dy;
    const double ex = px - x_start, ey = py - y_start;
    if (!(ex * ex + ey * ey <= max_shift * max_shift)) return false;  // NaN too
    if (dx * dx + dy * dy < 9e-4) {  // 0.03 px: bilinear sampling is good to ~0.04 px
      *x = px;
      *y = py;
      return true;
    }
  }
  return false;
}

}  // namespace ovo::frontend::kernels
