// Sub-pixel refinement of a track's step from one image to the next (DESIGN section 4): a
// translation-only Lucas-Kanade alignment of a small Gaussian-weighted patch of the raw images
// around the track's own sub-pixel position, started from the descriptor match's flow. On by
// default (frontend.track_refine), with a 9x9 patch of Gaussian weight sigma 2 px.
//
// Why on, and why that patch (the step went in off by default, before the window estimator
// modelled the tracks' creep): with the creep modelled, the step lowers the window's error on the
// simulated runs and on KITTI 07; of the patches, 11x11 does a little better than 9x9 on the
// simulated runs and 9x9 is the better of the two on the real data. Its cost is one small
// alignment per continued track, with loops that vectorise in track_refine_simd.cpp (whole patch
// rows of zero-padded weights, one accumulator per column). Tried, not kept: a right-hand side
// without the patch's mean saved no time; fewer iterations saved a little and cost accuracy.
//
// On a rendered row (ground tracks against the simulator's geometry, TrackDrift tests) the step
// lowers the tracks' error one and ten frames after their start, and the steps under half a pixel
// no longer lock to whole pixels. Points next to a depth edge keep their bias along the flow with
// or without it, for any patch size: their patches move partly with the nearer surface, and this
// does not fix them. Nor is the ten-frame drift the steps' noise adding up: aligning each track's
// patch from its first frame instead of the previous one (tried, not kept) hardly lowered it.
//
// Two gates on the step, off by default: a step that does not align ends its track (otherwise the
// descriptor match's flow is kept), and a step aligned back from where it landed must return
// within track_refine_forward_backward_px of its start. Together they end most tracks that
// wander off their point, but not the bias of those next to depth edges (docs/tracks.md).
//
// The measurements behind these choices: docs/code-notes.md.
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "common/types.hpp"

namespace ovo::frontend {

struct TrackRefineOptions {
  bool enabled = true;        // frontend.track_refine
  int half_window_px = 4;     // frontend.track_refine_half_window_px: patch (2r+1)^2 pixels
  double sigma_px = 2.0;      // frontend.track_refine_sigma_px: Gaussian weight of the patch
  int max_iterations = 5;     // frontend.track_refine_max_iterations: Gauss-Newton steps at most
  double max_shift_px = 1.0;  // frontend.track_refine_max_shift_px: further from the start = fail
  double min_gradient = 2.0;  // frontend.track_refine_min_gradient: weighted RMS gradient
                              // (grey levels / px) along the weakest axis
  double forward_backward_px = 0.0;  // frontend.track_refine_forward_backward_px: > 0 ends
                                     // tracks whose step aligned back misses by more (0 = off)
  bool required = false;  // frontend.track_refine_required: end tracks whose step fails to align
  bool operator==(const TrackRefineOptions&) const = default;
};

/// Translation-only Lucas-Kanade of one track step (the loops: kernels::alignPatchTranslation, in
/// track_refine_simd.cpp). The Gaussian weights of the patch are computed once here (they were 49
/// exp() calls per step, most of its cost); refine() is const and safe to call from several
/// threads.
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
  std::vector<float> weight_;  // 2 half + 1 rows of kernels::kLkStride, zero past the patch
  float weight_sum_ = 0.f;
};

}  // namespace ovo::frontend
