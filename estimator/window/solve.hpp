// Solving the window's factors with Ceres (states restored when the solve diverges), the bearing
// errors after a solve (for the outlier test) and the gyro preintegrations' re-propagation.
#pragma once

#include <string>
#include <unordered_map>
#include <vector>

#include "estimator/window/factors.hpp"
#include "estimator/window/options.hpp"

namespace ovo::estimator {

/// One scalar state of the whole run (WindowMap::time_offset_s, camera_height_offset_m) when the
/// factors hold it: bounded to +- max_abs, or held at its value, and restored with the rest on
/// failure.
struct ScalarState {
  double* block = nullptr;
  double max_abs = 0.1;
  bool hold = false;
};

struct SolveOptions {
  LinearSolver linear_solver = LinearSolver::kDenseSchur;
  int max_iterations = 8;
  double max_time_s = 0.0;  // 0: unlimited
  int num_threads = 1;
  ScalarState time_offset;           // s
  ScalarState camera_height_offset;  // m
};

struct SolveSummary {
  bool usable = false;  // the solver ran and every state is finite
  int iterations = 0;
  int residual_blocks = 0;
  double initial_cost = 0.0, final_cost = 0.0;
  std::string message;
};

/// Solves the window in place. On failure (non-finite states) the states are restored.
SolveSummary solveFactors(std::vector<FactorSpec> factors, const std::vector<Keyframe*>& keyframes,
                          std::unordered_map<TrackId, Landmark>& landmarks,
                          const WindowModel& model, const SolveOptions& options);

/// Angular error (rad) of every bearing observation at the current states, by (kf id, track).
struct ObservationError {
  int kf_id;
  TrackId track;
  double angle_rad;  // between the sighting and the landmark's predicted bearing
  double sigmas;     // the same in the sighting's own sigmas against its anchor (inf: behind)
};
std::vector<ObservationError> observationErrors(const std::vector<Keyframe*>& keyframes,
                                                const std::unordered_map<TrackId, Landmark>& lms,
                                                const WindowModel& model);

/// Re-propagates the gyro preintegrations (keyframes in time order) whose bias linearisation is
/// now more than 0.002 rad/s from the previous keyframe's estimate.
void repropagateGyro(const std::vector<Keyframe*>& keyframes);

}  // namespace ovo::estimator
