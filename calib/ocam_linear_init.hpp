// Scaramuzza's linear initialisation of the OCamCalib model from checkerboard views (Scaramuzza,
// Martinelli, Siegwart, "A Toolbox for Easily Calibrating Omnidirectional Cameras", IROS 2006,
// section IV): per board the extrinsics up to the depth from the equation that does not involve
// the polynomial, then the polynomial and the depths of all boards in one linear least squares,
// for each centre of a search grid; the centre with the smallest reprojection error wins.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "calib/board.hpp"
#include "common/types.hpp"

namespace ovo::calib {

struct OcamInitOptions {
  int degree = 4;                // ss polynomial degree N (a0, a2..aN; a1 = 0)
  int grid = 5;                  // centre search: grid x grid centres per level
  int levels = 3;                // levels, each around the previous best at a third of the span
  double search_fraction = 0.1;  // first level spans +- this fraction of the image size
};

/// A board's pose in ovo's camera frame C: p_C = R_C_B p_B + t_C_B.
struct BoardPose {
  Mat3 R_C_B = Mat3::Identity();
  Vec3 t_C_B = Vec3::Zero();
};

struct OcamInit {
  std::vector<double> ss;  // a0..aN (pixels), toolbox convention (a0 < 0)
  double center_row = 0, center_col = 0;
  std::vector<BoardPose> poses;  // one per board of the input
  double rms_px = 0.0;           // reprojection RMS of this initial model
};

/// Board poses and polynomial for a given centre (c = 1, d = e = 0); nullopt when the linear
/// systems are degenerate.
std::optional<OcamInit> ocamLinearEstimate(const std::vector<BoardObservation>& boards,
                                           double center_row, double center_col, int degree);

/// The full initialisation: ocamLinearEstimate over a grid of centres around the image centre.
/// nullopt (with *why set) when no centre gives a usable model.
std::optional<OcamInit> ocamLinearInit(const std::vector<BoardObservation>& boards,
                                       const OcamInitOptions& options, std::string* why = nullptr);

/// Reprojection RMS (pixels) of boards under an OCam model with c = 1, d = e = 0 (corners that do
/// not project count as 100 px).
double ocamInitRms(const std::vector<BoardObservation>& boards, const OcamInit& init);

}  // namespace ovo::calib
