#include "calib/model_selection.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/error.hpp"

namespace ovo::calib {
namespace {

double medianOf(std::vector<double> v) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }),
          v.end());
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(v.begin(), v.end());
  const std::size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

}  // namespace

std::string candidateName(const ModelCandidate& c) {
  const std::string board = boardShapeName(c.board_shape) + " board";
  if (c.model == CameraModelKind::kOcam)
    return fmt::format("ocam degree {}, {}", c.degree, board);
  return modelKindName(c.model) + ", " + board;
}

int parameterCount(const ModelCandidate& c) {
  int n = 0;
  switch (c.model) {
    case CameraModelKind::kOcam:
      n = c.degree + 2 + 2;  // a0, a2..aN; the centre; the affine's c and d (= e)
      break;
    case CameraModelKind::kKannalaBrandt:
    case CameraModelKind::kPinhole:
      n = 8;  // fx, fy, cx, cy and four distortion coefficients
      break;
  }
  return n + (c.board_shape == BoardShape::kShared ? 2 : 0);
}

std::vector<ModelCandidate> modelCandidates(CameraModelKind model, int degree,
                                            std::optional<BoardShape> shape) {
  std::vector<int> degrees = {degree > 0 ? degree : 4};
  if (degree <= 0 && model == CameraModelKind::kOcam) degrees = {4, 3, 5, 6};
  std::vector<BoardShape> shapes = {BoardShape::kShared, BoardShape::kRigid};
  if (shape) shapes = {*shape};
  std::vector<ModelCandidate> out;
  for (const BoardShape s : shapes)
    for (const int d : degrees) out.push_back({model, d, s});
  return out;
}

ModelSelection selectModel(const std::vector<BoardObservation>& boards,
                           const std::vector<ModelCandidate>& candidates,
                           const CalibrationOptions& base, const SelectionOptions& options) {
  if (candidates.empty()) fail("model selection: no candidate model");
  const auto optionsFor = [&](const ModelCandidate& c) {
    CalibrationOptions o = base;
    o.model = c.model;
    o.ocam_degree = c.degree;
    o.board_shape = c.board_shape;
    return o;
  };
  // The common set: what the first candidate keeps (misdetected boards out for everyone).
  const CalibrationResult first = calibrateCamera(boards, optionsFor(candidates.front()));
  std::vector<BoardObservation> common = first.boards;
  ModelSelection sel;
  for (const auto& b : common) sel.images.push_back(b.image);
  sel.folds = std::min(static_cast<int>(common.size()), options.max_folds);
  // Too few boards to leave any out and still calibrate: no held-out error; the first
  // candidate (the default) is taken, and said so.
  const int n = static_cast<int>(common.size());
  if (n - (n + sel.folds - 1) / sel.folds < base.min_boards) {
    for (std::size_t k = 0; k < candidates.size(); ++k) {
      CandidateScore score;
      score.candidate = candidates[k];
      score.parameters = parameterCount(candidates[k]);
      score.heldout_rms_px = std::numeric_limits<double>::quiet_NaN();
      // Only the first candidate was calibrated (it made the common set).
      score.train_rms_px = k == 0 ? first.rms_px : std::numeric_limits<double>::quiet_NaN();
      sel.scores.push_back(std::move(score));
    }
    sel.folds = 0;
    sel.chosen = 0;
    sel.reason = fmt::format(
        "the default: {} boards are too few to leave any out and still calibrate from {} "
        "(no held-out error)",
        n, base.min_boards);
    return sel;
  }

  for (const ModelCandidate& c : candidates) {
    CandidateScore score;
    score.candidate = c;
    score.parameters = parameterCount(c);
    score.train_rms_px = std::numeric_limits<double>::quiet_NaN();
    score.heldout_rms_px = std::numeric_limits<double>::quiet_NaN();
    try {
      const CalibrationResult r = calibrateCamera(common, optionsFor(c));
      score.train_rms_px = r.rms_px;
      score.rejected = r.rejected;
      const HeldOutError h = crossValidate(common, optionsFor(c), sel.folds);
      score.heldout_rms_px = h.rms_px;
      score.heldout_per_image_rms_px = h.per_image_rms_px;
      score.heldout_failed = h.failed;
    } catch (const Error& e) {
      score.rejected.push_back({"(all)", e.what()});
    }
    sel.scores.push_back(std::move(score));
  }

  // The lowest held-out error among the candidates that every board could be scored with.
  std::size_t best = sel.scores.size();
  for (std::size_t k = 0; k < sel.scores.size(); ++k) {
    const CandidateScore& s = sel.scores[k];
    if (!std::isfinite(s.heldout_rms_px) || s.heldout_failed > 0) continue;
    if (best == sel.scores.size() || s.heldout_rms_px < sel.scores[best].heldout_rms_px) best = k;
  }
  if (best == sel.scores.size()) {
    for (std::size_t k = 0; k < sel.scores.size(); ++k)  // any held-out error at all
      if (std::isfinite(sel.scores[k].heldout_rms_px) &&
          (best == sel.scores.size() ||
           sel.scores[k].heldout_rms_px < sel.scores[best].heldout_rms_px))
        best = k;
  }
  if (best == sel.scores.size())
    fail("model selection: no candidate model could be cross-validated on {} boards",
         common.size());
  // The simplest candidate within `simpler_within` of the lowest.
  std::size_t chosen = best;
  const double limit = sel.scores[best].heldout_rms_px * (1.0 + options.simpler_within);
  for (std::size_t k = 0; k < sel.scores.size(); ++k) {
    const CandidateScore& s = sel.scores[k];
    if (!std::isfinite(s.heldout_rms_px) || s.heldout_failed > 0 || s.heldout_rms_px > limit)
      continue;
    const CandidateScore& c = sel.scores[chosen];
    if (s.parameters < c.parameters ||
        (s.parameters == c.parameters && s.heldout_rms_px < c.heldout_rms_px))
      chosen = k;
  }
  sel.chosen = chosen;
  const CandidateScore& c = sel.scores[chosen];
  const std::string how = sel.folds == static_cast<int>(common.size())
                              ? "leave-one-image-out"
                              : fmt::format("{}-fold over images", sel.folds);
  sel.reason =
      chosen == best
          ? fmt::format("the lowest held-out reprojection error ({:.4f} px, {}) of {} candidates",
                        c.heldout_rms_px, how, sel.scores.size())
          : fmt::format(
                "the fewest parameters ({}) within {:.0f} % of the lowest held-out error "
                "({:.4f} px against {:.4f} px of {}, {})",
                c.parameters, 100.0 * options.simpler_within, c.heldout_rms_px,
                sel.scores[best].heldout_rms_px, candidateName(sel.scores[best].candidate), how);

  // Boards the chosen model predicts clearly worse than the others, when unseen.
  const double med = medianOf(c.heldout_per_image_rms_px);
  for (std::size_t j = 0; j < c.heldout_per_image_rms_px.size(); ++j) {
    const double e = c.heldout_per_image_rms_px[j];
    if (std::isfinite(med) && std::isfinite(e) && e > options.outlier_factor * med) {
      sel.outliers.push_back(sel.images[j]);
      sel.outlier_rms_px.push_back(e);
    }
  }
  return sel;
}

}  // namespace ovo::calib
