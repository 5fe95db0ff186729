#include "frontend/track_refine.hpp"

#include <algorithm>
#include <cmath>

#include "frontend/kernels.hpp"

namespace ovo::frontend {

namespace {

kernels::GreyImage greyImage(const cv::Mat& img) {
  return {img.ptr<std::uint8_t>(), img.cols, img.rows, static_cast<int>(img.step[0])};
}

}  // namespace

TrackStepRefiner::TrackStepRefiner(const TrackRefineOptions& options)
    : options_(options), half_(std::clamp(options.half_window_px, 1, kernels::kLkMaxHalf)) {
  const int side = 2 * half_ + 1;
  const double inv2s2 = 0.5 / (options_.sigma_px * options_.sigma_px);
  weight_.assign(static_cast<std::size_t>(side * kernels::kLkStride), 0.f);
  double sum = 0.0;
  for (int r = 0; r < side; ++r) {
    for (int c = 0; c < side; ++c) {
      const double dx = c - half_, dy = r - half_;
      const auto w = static_cast<float>(std::exp(-(dx * dx + dy * dy) * inv2s2));
      weight_[static_cast<std::size_t>(r * kernels::kLkStride + c)] = w;
      sum += w;
    }
  }
  weight_sum_ = static_cast<float>(sum);
}

std::optional<Vec2> TrackStepRefiner::refine(const cv::Mat& prev, const Vec2& x_prev,
                                             const cv::Mat& cur, const Vec2& x_cur) const {
  CV_DbgAssert(prev.type() == CV_8UC1 && cur.type() == CV_8UC1);
  double x = x_cur.x(), y = x_cur.y();
  if (!kernels::alignPatchTranslation(greyImage(prev), x_prev.x(), x_prev.y(), greyImage(cur),
                                      weight_.data(), weight_sum_, half_, options_.max_iterations,
                                      options_.max_shift_px, options_.min_gradient, &x, &y))
    return std::nullopt;
  return Vec2(x, y);
}

}  // namespace ovo::frontend
