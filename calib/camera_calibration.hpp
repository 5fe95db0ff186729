// Camera calibration from checkerboard corners: Scaramuzza's linear initialisation
// (ocam_linear_init), then a Ceres refinement of all intrinsics and board poses with a robust
// loss, boards whose corners do not fit rejected, for the OCamCalib, Kannala-Brandt and pinhole
// radial-tangential models. The Kannala-Brandt and pinhole models start from the refined OCam
// model (their radial curve fitted to it, the same board poses).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "calib/board.hpp"
#include "calib/ocam_linear_init.hpp"
#include "camera/camera.hpp"

namespace ovo::calib {

enum class CameraModelKind { kOcam, kKannalaBrandt, kPinhole };
/// "ocam", "kb" or "pinhole" (throws ovo::Error naming `option` otherwise).
CameraModelKind parseCameraModel(const std::string& name, const std::string& option = "--model");
std::string modelKindName(CameraModelKind kind);

/// How the board's own geometry is modelled. A printed board is rarely exact: its grid may be
/// sheared or stretched along one axis by the printer (a shear of a fraction of a degree can be a
/// good part of the RMS). p_B = S (X, Y) with S = [1 shear; 0 1 + stretch] on the board plane.
enum class BoardShape {
  kRigid,     // S = identity: the board is exactly as specified
  kShared,    // one S for all views (2 parameters): the printed board's own distortion
  kPerBoard,  // one S per view (8 parameters a view, like py-OCamCalib's free 3x4 extrinsics):
              // not physical, only for comparing with that tool
};
/// "rigid", "shared" or "per-board" (throws ovo::Error naming `option` otherwise).
BoardShape parseBoardShape(const std::string& name, const std::string& option = "--board-shape");
/// "rigid", "shared" or "per-board".
std::string boardShapeName(BoardShape shape);

struct CalibrationOptions {
  CameraModelKind model = CameraModelKind::kOcam;
  int ocam_degree = 4;         // ss polynomial degree (the toolbox's default is 4)
  double huber_px = 1.0;       // robust loss scale on the reprojection error (pixels)
  int min_boards = 3;          // fewer usable boards: an error
  double reject_rms_px = 1.0;  // a board is rejected above max(this, reject_factor x median)
  double reject_factor = 3.0;
  int max_iterations = 200;  // Ceres iterations per solve
  BoardShape board_shape = BoardShape::kShared;
  int threads = 2;
};

/// The result: the model, the boards used with their poses and residuals, and what was left out.
struct CalibrationResult {
  CameraModelKind model = CameraModelKind::kOcam;
  std::optional<camera::Camera> camera;  // OCam (invpol fitted), Kannala-Brandt or pinhole
  int width = 0, height = 0;
  std::vector<BoardObservation> boards;         // used
  std::vector<BoardPose> poses;                 // of the used boards
  std::vector<std::vector<Vec2>> residuals_px;  // predicted - detected, per corner
  std::vector<double> per_image_rms_px;
  std::vector<double> per_image_mean_px;  // mean corner error norm per image
  double rms_px = 0.0;                    // sqrt(mean of squared corner errors)
  double mean_error_px = 0.0;             // mean corner error norm
  double mean_of_image_means_px = 0.0;    // py-OCamCalib's "rms_overall"
  double init_rms_px = 0.0;               // of the linear initialisation
  std::vector<RejectedImage> rejected;    // boards left out by the calibration
  int corners_used = 0;
  std::vector<std::string> notes;                 // what a user should know (dropped corners)
  double board_shear = 0.0, board_stretch = 0.0;  // the shared board shape (BoardShape::kShared)
};

/// Calibrates `options.model` from the boards (all of one image size). Throws ovo::Error when the
/// boards differ in size, or when fewer than options.min_boards remain usable (the message lists
/// every rejected board and why).
CalibrationResult calibrateCamera(const std::vector<BoardObservation>& boards,
                                  const CalibrationOptions& options);

/// The reprojection error of a calibration on boards it was not fitted to (k-fold cross-
/// validation over images): board j goes to fold j % folds; each fold's boards are left out of a
/// calibration with `options` (its own rejections included), then each of them gets its pose
/// fitted with that calibration's intrinsics and shared board shape fixed (no robust loss), and
/// its corners' errors are its held-out error. folds = the number of boards is leave-one-image-out.
struct HeldOutError {
  int folds = 0;
  std::vector<double> per_image_rms_px;  // per input board; NaN where it could not be fitted
  double rms_px = 0.0;                   // over every held-out corner
  int corners = 0;
  int failed = 0;  // boards without a held-out error (their fold's calibration failed, their
                   // pose could not be found, or none of their corners projects)
};
HeldOutError crossValidate(const std::vector<BoardObservation>& boards,
                           const CalibrationOptions& options, int folds);

/// Reprojection RMS (pixels) of a fixed calibrated model on other boards, poses fitted per board
/// (e.g. the peer tool's intrinsics on its own corners). nullopt when a pose does not converge.
struct FixedModelFit {
  std::vector<double> per_image_rms_px, per_image_mean_px;
  double rms_px = 0.0, mean_of_image_means_px = 0.0;
};
FixedModelFit fitPosesWithFixedOcam(const std::vector<BoardObservation>& boards,
                                    const camera::OcamParams& params);

}  // namespace ovo::calib
