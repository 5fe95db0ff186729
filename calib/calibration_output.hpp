// What `ovo calibrate camera` writes into its output folder: the calibration in the formats ovo
// and other tools read (OCamCalib calib_results.txt; Kalibr camchain.yaml, EuRoC sensor.yaml and
// Basalt calibration.json for the Kannala-Brandt and pinhole models), the corners used (the
// corner-file format readCornersFile reads), report.json and report.html.
#pragma once

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "calib/board.hpp"
#include "calib/camera_calibration.hpp"
#include "calib/model_comparison.hpp"
#include "calib/model_selection.hpp"

namespace ovo::calib {

/// Everything the report shows about one calibration run.
struct CalibrationRun {
  CalibrationResult result;
  BoardSpec board;
  CalibrationOptions options;
  std::string source;                              // "detector" or the corner file
  std::vector<std::string> images;                 // every input image (or board), in order
  std::vector<BoardObservation> detected;          // every board found (used or rejected)
  std::map<std::string, std::string> detected_by;  // image -> detection method
  std::vector<RejectedImage> not_detected;         // images without a usable board
  std::optional<BearingComparison> reference;      // against --reference, when given
  std::string reference_file;
  std::optional<ModelSelection> selection;  // the candidates scored and the one chosen
  std::vector<std::string> excluded;        // boards left out by the user (--exclude)
};

/// The files of the calibration itself, by model (names relative to the output folder).
std::vector<std::string> calibrationFileNames(CameraModelKind model);

/// Writes the calibration files, corners.txt, report.json and report.html into `folder` (an
/// existing, empty staging folder). Throws ovo::Error naming a file that cannot be written.
void writeCalibrationOutputs(const std::filesystem::path& folder, const CalibrationRun& run);

/// report.json's content.
nlohmann::json reportJson(const CalibrationRun& run);

/// report.html: self-contained (inline SVG): corner coverage of the image, residuals over the
/// image, per-image errors, rejected images and the model's parameters.
std::string reportHtml(const CalibrationRun& run);

}  // namespace ovo::calib
