// The window's own Levenberg-Marquardt minimiser (window.linear_solver: landmark_schur, the
// default): the same steps as Ceres' trust-region LM with DENSE_SCHUR on the same factors (its
// Jacobi scaling, its LM diagonal and radius updates, its tolerances and its Triggs correction of
// the robust losses), with the one-dimensional inverse-depth landmarks eliminated by hand. A
// landmark's part of J^T J is one number, so its Schur complement is a rank-one update of the
// keyframe blocks it touches; Ceres' generic eliminator (dynamic block sizes, no specialisation for
// one-dimensional e-blocks) and its per-solve preprocessing cost more than the rest of the
// linear algebra together. Ceres stays the solver of record for the offline refinement and for
// the checks (tests/estimator/window/landmark_schur_test.cpp compares the two).
//
// Differences from Ceres, none of which changes a step: the candidate point is evaluated without
// Jacobians, which are computed only where another iteration follows (Ceres also evaluates them
// after the last accepted step); the gradient tolerance (1e-10 on the projected gradient) is not
// checked.
#pragma once

#include <ceres/cost_function.h>
#include <ceres/loss_function.h>

#include <limits>
#include <string>
#include <unordered_map>
#include <vector>

namespace ovo::estimator {

/// How the minimiser treats one parameter block; a block without an entry is Euclidean and free.
struct LmBlockInfo {
  bool quaternion = false;  // ceres::EigenQuaternionManifold (4 ambient, 3 tangent)
  bool constant = false;    // held at its value
  bool eliminate = false;   // a one-dimensional block eliminated per landmark (at most one in a
                            // residual block); others of size 1 stay in the reduced system
  double lower = -std::numeric_limits<double>::infinity();  // every coordinate, after Plus
  double upper = std::numeric_limits<double>::infinity();
};

struct LmResidual {
  const ceres::CostFunction* cost = nullptr;
  const ceres::LossFunction* loss = nullptr;  // may be null
  const std::vector<double*>* blocks = nullptr;  // not owned; must outlive the solve
};

struct LmOptions {
  int max_iterations = 4;              // steps, accepted or not (Ceres' max_num_iterations)
  double stop_decrease = 0.0;          // stop after an accepted step that lowered the cost by
                                       // less than this fraction (0: off, as Ceres)
  double max_time_s = 0.0;             // 0: no limit
  double function_tolerance = 1e-6;    // Ceres' defaults from here on
  double parameter_tolerance = 1e-8;
  double initial_radius = 1e4;
  double max_radius = 1e16;
  double min_radius = 1e-32;
  double min_relative_decrease = 1e-3;
  double min_lm_diagonal = 1e-6;
  double max_lm_diagonal = 1e32;
  int max_consecutive_invalid_steps = 5;
};

struct LmSummary {
  bool failed = false;   // the start or an accepted state could not be evaluated, or the steps
                         // kept failing (Ceres' FAILURE): the blocks hold the last accepted
                         // state, which the caller should not trust
  int iterations = 0;    // as Ceres' summary.iterations.size(): the start and every step
  int accepted = 0;
  double initial_cost = 0.0, final_cost = 0.0;
  std::string message;
};

/// Minimises 1/2 sum rho(|r|^2) over the blocks of `residuals`, in place. `info` names the
/// quaternion, constant, eliminated and bounded blocks.
LmSummary solveLandmarkSchur(const std::vector<LmResidual>& residuals,
                             const std::unordered_map<const double*, LmBlockInfo>& info,
                             const LmOptions& options);

}  // namespace ovo::estimator
