#include "frontend/track_refine.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace ovo::frontend {

namespace {

constexpr int kMaxHalf = 7;
constexpr int kMaxSide = 2 * kMaxHalf + 3;  // the template keeps a one-pixel ring for gradients

// Bilinear samples of img on the (2h+1)^2 grid centred at (x, y); false if any leaves the image.
bool samplePatch(const cv::Mat& img, double x, double y, int h, float* out) {
  const double x0 = x - h, y0 = y - h;
  const int side = 2 * h + 1;
  if (!(x0 >= 0.0) || !(y0 >= 0.0) || !(x0 + side < img.cols) || !(y0 + side < img.rows))
    return false;
  const int ix = static_cast<int>(std::floor(x0)), iy = static_cast<int>(std::floor(y0));
  const float ax = static_cast<float>(x0 - ix), ay = static_cast<float>(y0 - iy);
  const float w00 = (1.f - ax) * (1.f - ay), w01 = ax * (1.f - ay), w10 = (1.f - ax) * ay,
              w11 = ax * ay;
  for (int r = 0; r < side; ++r) {
    const std::uint8_t* a = img.ptr<std::uint8_t>(iy + r) + ix;
    const std::uint8_t* b = img.ptr<std::uint8_t>(iy + r + 1) + ix;
    for (int c = 0; c < side; ++c)
      out[r * side + c] = w00 * a[c] + w01 * a[c + 1] + w10 * b[c] + w11 * b[c + 1];
  }
  return true;
}

}  // namespace

std::optional<Vec2> refineTrackStep(const cv::Mat& prev, const Vec2& x_prev, const cv::Mat& cur,
                                    const Vec2& x_cur, const TrackRefineOptions& o) {
  const int h = std::clamp(o.half_window_px, 1, kMaxHalf);
  const int side = 2 * h + 1, tside = side + 2;
  std::array<float, kMaxSide * kMaxSide> tpl;
  std::array<float, (2 * kMaxHalf + 1) * (2 * kMaxHalf + 1)> gx, gy, w, patch;
  if (!samplePatch(prev, x_prev.x(), x_prev.y(), h + 1, tpl.data())) return std::nullopt;

  // Template, its central-difference gradients and the Gaussian weights on the inner grid.
  const double inv2s2 = 0.5 / (o.sigma_px * o.sigma_px);
  double sw = 0.0, t_mean = 0.0;
  double hxx = 0.0, hxy = 0.0, hyy = 0.0;
  for (int r = 0; r < side; ++r) {
    for (int c = 0; c < side; ++c) {
      const int k = r * side + c, t = (r + 1) * tside + (c + 1);
      gx[k] = 0.5f * (tpl[t + 1] - tpl[t - 1]);
      gy[k] = 0.5f * (tpl[t + tside] - tpl[t - tside]);
      const double dx = c - h, dy = r - h;
      w[k] = static_cast<float>(std::exp(-(dx * dx + dy * dy) * inv2s2));
      sw += w[k];
      t_mean += w[k] * tpl[t];
      hxx += w[k] * gx[k] * gx[k];
      hxy += w[k] * gx[k] * gy[k];
      hyy += w[k] * gy[k] * gy[k];
    }
  }
  t_mean /= sw;
  // Brightness offset compensation removes the mean gradient's part of H.
  double mgx = 0.0, mgy = 0.0;
  for (int k = 0; k < side * side; ++k) mgx += w[k] * gx[k], mgy += w[k] * gy[k];
  mgx /= sw;
  mgy /= sw;
  hxx -= sw * mgx * mgx;
  hxy -= sw * mgx * mgy;
  hyy -= sw * mgy * mgy;
  const double tr = hxx + hyy, det = hxx * hyy - hxy * hxy;
  const double lambda_min = 0.5 * (tr - std::sqrt(std::max(0.0, tr * tr - 4.0 * det)));
  if (!(lambda_min >= o.min_gradient * o.min_gradient * sw)) return std::nullopt;

  Vec2 x = x_cur;
  for (int it = 0; it < o.max_iterations; ++it) {
    if (!samplePatch(cur, x.x(), x.y(), h, patch.data())) return std::nullopt;
    double p_mean = 0.0;
    for (int k = 0; k < side * side; ++k) p_mean += w[k] * patch[k];
    p_mean /= sw;
    double bx = 0.0, by = 0.0;
    for (int r = 0; r < side; ++r) {
      for (int c = 0; c < side; ++c) {
        const int k = r * side + c;
        const double e = (patch[k] - p_mean) - (tpl[(r + 1) * tside + c + 1] - t_mean);
        bx += w[k] * (gx[k] - mgx) * e;
        by += w[k] * (gy[k] - mgy) * e;
      }
    }
    // Inverse compositional step: the template moved by d matches, so the point moves by -d.
    const Vec2 d((hyy * bx - hxy * by) / det, (hxx * by - hxy * bx) / det);
    x -= d;
    if (!x.allFinite() || (x - x_cur).norm() > o.max_shift_px) return std::nullopt;
    if (d.squaredNorm() < 1e-4) return x;  // 0.01 px
  }
  return std::nullopt;
}

}  // namespace ovo::frontend
