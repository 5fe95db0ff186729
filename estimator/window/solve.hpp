// Solving the window's factors with its own minimiser (landmark_schur.hpp) or with Ceres: the
// problem made from the factor list, the scalar states bounded or held, and every state restored
// when the solve fails or diverges.
#pragma once

#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include <ceres/problem.h>

#include "estimator/window/factors.hpp"
#include "estimator/window/options.hpp"

namespace ovo::estimator {

/// One scalar state (WindowMap::time_offset_s, camera_height_offset_m, a keyframe's
/// height_offset_m) when the factors hold it: bounded to +- max_abs, or held at its value, and
/// restored with the rest on failure.
struct ScalarState {
  double* block = nullptr;
  double max_abs = 0.1;
  bool hold = false;
};

struct SolveOptions {
  LinearSolver linear_solver = LinearSolver::kLandmarkSchur;
  int max_iterations = 8;
  double stop_decrease = 0.0;  // landmark_schur's (LmOptions::stop_decrease)
  double max_time_s = 0.0;  // 0: unlimited
  int num_threads = 1;
  ScalarState time_offset;           // s
  ScalarState camera_height_offset;  // m
  double height_offset_max_abs = 0.0;  // > 0: each keyframe's height_offset_m within +- this, m
  double* gravity = nullptr;  // WindowMap::gravity (restored with the rest on failure)
};

struct SolveSummary {
  bool usable = false;  // the solver ran and every state is finite
  bool failed = false;  // the solver failed or a state came out non-finite: states restored
  int iterations = 0;
  int residual_blocks = 0;
  double initial_cost = 0.0, final_cost = 0.0;
  std::string message;
};

/// A Ceres problem holding the factors (their cost and loss handed over): the keyframes'
/// orientations that a factor holds on the quaternion manifold (one without any, e.g. no landmark
/// yet, is left out rather than left floating; asking Ceres afterwards scans every residual block
/// per keyframe), then the residual blocks. `used`: every block the factors hold.
void addFactorsToProblem(std::vector<FactorSpec>& factors, const std::vector<Keyframe*>& keyframes,
                         const WindowModel& model, const std::unordered_set<const double*>& used,
                         ceres::Problem& problem);

/// Solves the window in place. On failure (non-finite states) the states are restored.
SolveSummary solveFactors(std::vector<FactorSpec> factors, const std::vector<Keyframe*>& keyframes,
                          std::unordered_map<TrackId, Landmark>& landmarks,
                          const WindowModel& model, const SolveOptions& options);

}  // namespace ovo::estimator
