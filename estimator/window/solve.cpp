// The window's solve (its own minimiser, landmark_schur.hpp, or Ceres), with the scalar states
// bounded and every state restored on failure.
#include "estimator/window/solve.hpp"

#include <ceres/ceres.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <unordered_set>
#include <vector>

#include "estimator/window/landmark_schur.hpp"
#include "factors/accel_factor.hpp"
#include "factors/bearing_factor.hpp"
#include "factors/parameterization.hpp"

namespace ovo::estimator {

void addFactorsToProblem(std::vector<FactorSpec>& factors, const std::vector<Keyframe*>& keyframes,
                         const WindowModel& model, const std::unordered_set<const double*>& used,
                         ceres::Problem& problem) {
  for (Keyframe* kf : keyframes) {
    if (used.count(kf->q_W_B))
      problem.AddParameterBlock(kf->q_W_B, 4, factors::newQuaternionManifold());
    if (tiedRotations(model) && used.count(kf->q_W_G))
      problem.AddParameterBlock(kf->q_W_G, 4, factors::newQuaternionManifold());
  }
  for (FactorSpec& f : factors)
    problem.AddResidualBlock(f.cost.release(), f.loss.release(), f.blocks);
}

namespace {

// The scalar states that the factors may hold: the run's (time offset, camera height) and each
// keyframe's camera-height correction along the path, bounded or held and restored alike.
using Scalars = std::vector<ScalarState>;

ceres::Solver::Summary solveWithCeres(std::vector<FactorSpec>& factors,
                                      const std::vector<Keyframe*>& keyframes,
                                      std::unordered_map<TrackId, Landmark>& landmarks,
                                      const WindowModel& model, const Scalars& scalars,
                                      const SolveOptions& options) {
  std::unordered_set<const double*> used;
  for (const FactorSpec& f : factors) used.insert(f.blocks.begin(), f.blocks.end());
  ceres::Problem problem;
  addFactorsToProblem(factors, keyframes, model, used, problem);
  for (auto& [id, lm] : landmarks) {
    if (!used.count(lm.rho)) continue;
    problem.SetParameterLowerBound(lm.rho, 0, model.min_rho);
    problem.SetParameterUpperBound(lm.rho, 0, model.max_rho);
    lm.rho[0] = std::clamp(lm.rho[0], model.min_rho, model.max_rho);
  }
  for (const ScalarState& x : scalars) {
    if (!x.block || !problem.HasParameterBlock(x.block)) continue;
    if (x.hold) {
      problem.SetParameterBlockConstant(x.block);
    } else {
      // Within its bounds first (they may have narrowed since: an estimated sigma): Ceres refuses
      // a start outside them.
      x.block[0] = std::clamp(x.block[0], -x.max_abs, x.max_abs);
      problem.SetParameterLowerBound(x.block, 0, -x.max_abs);
      problem.SetParameterUpperBound(x.block, 0, x.max_abs);
    }
  }
  ceres::Solver::Options so;
  so.linear_solver_type = options.linear_solver == LinearSolver::kSparseSchur ? ceres::SPARSE_SCHUR
                                                                              : ceres::DENSE_SCHUR;
  so.max_num_iterations = options.max_iterations;
  if (options.max_time_s > 0.0) so.max_solver_time_in_seconds = options.max_time_s;
  so.num_threads = options.num_threads;
  // No explicit ordering: Ceres' own keeps the program's order (a ParameterBlockOrdering orders
  // each group by address, which differs between runs and changes the answers in the last bits).
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary s;
  ceres::Solve(so, &problem, &s);
  return s;
}

// The same problem for the window's own minimiser (landmark_schur.hpp).
LmSummary solveOwn(std::vector<FactorSpec>& factors, const std::vector<Keyframe*>& keyframes,
                   std::unordered_map<TrackId, Landmark>& landmarks, const WindowModel& model,
                   const Scalars& scalars, const SolveOptions& options) {
  std::vector<LmResidual> residuals;
  residuals.reserve(factors.size());
  for (const FactorSpec& f : factors) residuals.push_back({f.cost.get(), f.loss.get(), &f.blocks});
  std::unordered_map<const double*, LmBlockInfo> info;
  info.reserve(landmarks.size() + 2 * keyframes.size() + scalars.size());
  for (const Keyframe* kf : keyframes) {
    info[kf->q_W_B].quaternion = true;
    if (tiedRotations(model)) info[kf->q_W_G].quaternion = true;
  }
  for (const auto& [id, lm] : landmarks) {
    LmBlockInfo& b = info[lm.rho];
    b.eliminate = true;
    b.lower = model.min_rho;
    b.upper = model.max_rho;
  }
  for (const ScalarState& x : scalars) {
    if (!x.block) continue;
    LmBlockInfo& b = info[x.block];
    b.constant = x.hold;
    b.lower = -x.max_abs;
    b.upper = x.max_abs;
  }
  LmOptions lo;
  lo.max_iterations = options.max_iterations;
  lo.stop_decrease = options.stop_decrease;
  lo.max_time_s = options.max_time_s;
  return solveLandmarkSchur(residuals, info, lo);
}

}  // namespace

SolveSummary solveFactors(std::vector<FactorSpec> factors, const std::vector<Keyframe*>& keyframes,
                          std::unordered_map<TrackId, Landmark>& landmarks,
                          const WindowModel& model, const SolveOptions& options) {
  SolveSummary summary;
  if (factors.empty()) return summary;

  // Backup for a diverged solve.
  struct KfBackup {
    double q[4], g[4], p[3], b[3], terrain[3];
  };
  std::vector<KfBackup> kf_backup(keyframes.size());
  for (std::size_t k = 0; k < keyframes.size(); ++k) {
    std::copy_n(keyframes[k]->q_W_B, 4, kf_backup[k].q);
    std::copy_n(keyframes[k]->q_W_G, 4, kf_backup[k].g);
    std::copy_n(keyframes[k]->p_W_B, 3, kf_backup[k].p);
    std::copy_n(keyframes[k]->b_g, 3, kf_backup[k].b);
    std::copy_n(keyframes[k]->terrain, 3, kf_backup[k].terrain);
  }
  std::unordered_map<TrackId, double> rho_backup;
  for (const auto& [id, lm] : landmarks) rho_backup[id] = lm.rho[0];
  Scalars scalars = {options.time_offset, options.camera_height_offset};
  if (options.height_offset_max_abs > 0.0)
    for (Keyframe* kf : keyframes)
      scalars.push_back({kf->height_offset_m, options.height_offset_max_abs});
  std::vector<double> scalar_backup(scalars.size(), 0.0);
  for (std::size_t i = 0; i < scalars.size(); ++i)
    if (scalars[i].block) scalar_backup[i] = scalars[i].block[0];

  std::array<double, factors::kGravityStateSize> gravity_backup{};
  if (options.gravity) std::copy_n(options.gravity, gravity_backup.size(), gravity_backup.begin());

  summary.residual_blocks = static_cast<int>(factors.size());
  bool solver_failed = false;
  if (options.linear_solver == LinearSolver::kLandmarkSchur) {
    const LmSummary s = solveOwn(factors, keyframes, landmarks, model, scalars, options);
    summary.iterations = s.iterations;
    summary.initial_cost = s.initial_cost;
    summary.final_cost = s.final_cost;
    summary.message = s.message;
    solver_failed = s.failed;
  } else {
    const ceres::Solver::Summary s = solveWithCeres(factors, keyframes, landmarks, model, scalars,
                                                    options);
    summary.iterations = static_cast<int>(s.iterations.size());
    summary.initial_cost = s.initial_cost;
    summary.final_cost = s.final_cost;
    summary.message = s.message;
    solver_failed = s.termination_type == ceres::FAILURE;
  }
  bool finite = !solver_failed;
  for (const Keyframe* kf : keyframes)
    finite = finite &&
             std::isfinite(kf->q_W_B[0] + kf->q_W_B[1] + kf->q_W_B[2] + kf->q_W_B[3] +
                           kf->p_W_B[0] + kf->p_W_B[1] + kf->p_W_B[2] + kf->b_g[0] + kf->b_g[1] +
                           kf->b_g[2] + kf->terrain[0] + kf->terrain[1] + kf->terrain[2] +
                           kf->q_W_G[0] + kf->q_W_G[1] + kf->q_W_G[2] + kf->q_W_G[3]);
  for (const auto& [id, lm] : landmarks) finite = finite && std::isfinite(lm.rho[0]);
  for (const ScalarState& x : scalars) finite = finite && (!x.block || std::isfinite(x.block[0]));
  if (options.gravity)
    for (int i = 0; i < factors::kGravityStateSize; ++i)
      finite = finite && std::isfinite(options.gravity[i]);
  if (!finite) {
    summary.failed = true;
    for (std::size_t i = 0; i < scalars.size(); ++i)
      if (scalars[i].block) scalars[i].block[0] = scalar_backup[i];
    if (options.gravity) std::copy(gravity_backup.begin(), gravity_backup.end(), options.gravity);
    for (std::size_t k = 0; k < keyframes.size(); ++k) {
      std::copy_n(kf_backup[k].q, 4, keyframes[k]->q_W_B);
      std::copy_n(kf_backup[k].g, 4, keyframes[k]->q_W_G);
      std::copy_n(kf_backup[k].p, 3, keyframes[k]->p_W_B);
      std::copy_n(kf_backup[k].b, 3, keyframes[k]->b_g);
      std::copy_n(kf_backup[k].terrain, 3, keyframes[k]->terrain);
    }
    for (auto& [id, lm] : landmarks) lm.rho[0] = rho_backup[id];
    return summary;
  }
  for (Keyframe* kf : keyframes) {  // keep the quaternions exactly unit
    factors::quatToBlock(factors::quatFromBlock(kf->q_W_B), kf->q_W_B);
    if (tiedRotations(model))
      factors::quatToBlock(factors::quatFromBlock(kf->q_W_G), kf->q_W_G);
    else  // one orientation for both
      std::copy_n(kf->q_W_B, 4, kf->q_W_G);
  }
  summary.usable = true;
  return summary;
}

}  // namespace ovo::estimator
