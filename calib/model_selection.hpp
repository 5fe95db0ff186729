// Which camera model the boards support: each candidate (OCam polynomial degree, board shape,
// or Kannala-Brandt) is calibrated on all boards and cross-validated over images
// (crossValidate), and the one with the lowest held-out reprojection error is chosen, not the
// one with the lowest training error (a higher degree always fits the boards it saw better).
// Boards whose corners are clearly worse than the others' are named.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "calib/camera_calibration.hpp"

namespace ovo::calib {

struct ModelCandidate {
  CameraModelKind model = CameraModelKind::kOcam;
  int degree = 4;  // OCam only
  BoardShape board_shape = BoardShape::kShared;
};
/// "ocam degree 4, shared board", "kb, rigid board".
std::string candidateName(const ModelCandidate& c);
/// Intrinsic and board-shape parameters of a candidate (board poses not counted).
int parameterCount(const ModelCandidate& c);

/// The candidates for `model` with what the user fixed: OCam degrees 4, 3, 5 and 6 unless
/// `degree` > 0; the shared and the rigid board unless `shape` is given (the per-board shape is
/// not a property of the camera and is only tried when asked). The first is the default.
std::vector<ModelCandidate> modelCandidates(CameraModelKind model, int degree = 0,
                                            std::optional<BoardShape> shape = std::nullopt);

struct CandidateScore {
  ModelCandidate candidate;
  int parameters = 0;
  double train_rms_px = 0.0;        // on all boards it used (its own rejections applied)
  double heldout_rms_px = 0.0;      // cross-validated (NaN when no fold could be fitted)
  std::vector<double> heldout_per_image_rms_px;  // per board of the common set
  int heldout_failed = 0;           // boards of the common set without a held-out error
  std::vector<RejectedImage> rejected;
};

struct SelectionOptions {
  /// Folds of the cross-validation: leave-one-image-out up to this many boards, k-fold beyond.
  int max_folds = 10;
  /// A candidate with fewer parameters is preferred while its held-out error is within this
  /// fraction of the lowest (differences below the folds' noise do not buy parameters).
  double simpler_within = 0.01;
  /// A board is named as an outlier when its held-out error exceeds this factor times the median.
  double outlier_factor = 2.5;
};

struct ModelSelection {
  std::vector<CandidateScore> scores;
  std::size_t chosen = 0;
  std::string reason;                 // why the chosen one, in a sentence
  std::vector<std::string> images;    // the common set of boards the candidates were scored on
  std::vector<std::string> outliers;  // boards of that set clearly worse than the others
  std::vector<double> outlier_rms_px;
  int folds = 0;  // 0: not cross-validated (too few boards)
};

/// Scores every candidate (at least one) on `boards` with `base` for everything but the
/// candidate's own choices. The common set is the boards the first candidate's calibration
/// used; with too few boards to leave some out and still have base.min_boards, nothing is
/// cross-validated (folds 0, held-out errors NaN) and the first candidate is chosen. Throws
/// ovo::Error when the first candidate cannot be calibrated or no candidate can be
/// cross-validated.
ModelSelection selectModel(const std::vector<BoardObservation>& boards,
                           const std::vector<ModelCandidate>& candidates,
                           const CalibrationOptions& base, const SelectionOptions& options = {});

}  // namespace ovo::calib
