// Sub-pixel refinement of a track's step from one image to the next (DESIGN section 4): a
// translation-only Lucas-Kanade alignment of a small Gaussian-weighted patch of the raw images
// around the track's own sub-pixel position, started from the descriptor match's flow. Off by
// default (frontend.track_refine).
//
// Measured on a rendered row (ground tracks against the simulator's geometry, 8 s): the one-frame
// flow error falls from 0.20 to 0.16 px (flows of 4-8 px) and from 0.14 to 0.10 px (over 8 px).
// Far ground points (flows of 0.5-2 px) keep a bias of +4 to +8 % along the flow with or without
// it, for any patch size: it comes from the points next to a depth edge, whose patches move partly
// with the nearer surface (TrackDrift.CleanGroundStepsAreUnbiasedAlongTheFlow); this does not
// fix them. Nor is the ten-frame drift the steps' noise adding up: aligning each track's patch
// from its first frame instead of the previous one (tried, not kept) left the median error after
// ten frames at 0.40 px against 0.42 px with these steps (0.78 px without either).
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "common/types.hpp"

namespace ovo::frontend {

struct TrackRefineOptions {
  bool enabled = false;       // frontend.track_refine
  int half_window_px = 3;     // frontend.track_refine_half_window_px: patch (2r+1)^2 pixels
  double sigma_px = 1.5;      // frontend.track_refine_sigma_px: Gaussian weight of the patch
  int max_iterations = 5;     // frontend.track_refine_max_iterations: Gauss-Newton steps at most
  double max_shift_px = 1.0;  // frontend.track_refine_max_shift_px: further from the start = fail
  double min_gradient = 2.0;  // frontend.track_refine_min_gradient: weighted RMS gradient
                              // (grey levels / px) along the weakest axis
  bool operator==(const TrackRefineOptions&) const = default;
};

/// Translation-only Lucas-Kanade of one track step. The Gaussian weights of the patch are
/// computed once here (they were 49 exp() calls per step, most of its cost); refine() is const and
/// safe to call from several threads.
class TrackStepRefiner {
 public:
  explicit TrackStepRefiner(const TrackRefineOptions& options = {});
  /// Where the patch of `prev` (CV_8UC1) around the sub-pixel point x_prev is found in `cur`
  /// (CV_8UC1, same size), starting at x_cur: brightness offset compensated, bilinear sampling.
  /// nullopt when the patch leaves either image, has too little texture along some axis, does not
  /// converge, or moves more than max_shift_px from x_cur (the caller keeps x_cur).
  std::optional<Vec2> refine(const cv::Mat& prev, const Vec2& x_prev, const cv::Mat& cur,
                             const Vec2& x_cur) const;

 private:
  TrackRefineOptions options_;
  int half_ = 3;
  std::vector<float> weight_;  // (2 half + 1)^2, row-major
  float weight_sum_ = 0.f;
};

}  // namespace ovo::frontend
