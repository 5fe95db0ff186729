// The sliding-window estimator on the synthetic vineyard of the window tests (tracked bearings,
// gyro, LiDAR; no images): whole-sequence time per linear solver, with the per-keyframe window
// solve and the per-frame time as counters. BM_WindowEstimator/synthetic6s/<solver>.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <vector>

#include "estimator/window/core.hpp"
#include "tests/estimator/window/synthetic.hpp"

namespace {

const ovo::test::SyntheticSequence& sequence() {
  static const ovo::test::SyntheticSequence seq = ovo::test::makeSyntheticSequence(
      {}, std::filesystem::path(OVO_SOURCE_DIR) / "configs/cameras/romovi_ocam.txt");
  return seq;
}

void BM_WindowEstimator(benchmark::State& state, ovo::estimator::LinearSolver solver) {
  const auto& seq = sequence();
  ovo::estimator::WindowOptions options;
  options.linear_solver = solver;
  std::vector<double> solve_ms, frame_ms;
  for (auto _ : state) {
    ovo::estimator::WindowCore core(seq.setup, options);
    ovo::test::feedSequence(seq, core, [&](std::size_t, const ovo::estimator::FrameEstimate& e) {
      frame_ms.push_back(e.estimator_ms);
      if (e.is_keyframe) solve_ms.push_back(core.lastSolve().solve_ms);
    });
  }
  auto median = [](std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  state.counters["keyframe_solve_ms_median"] = median(solve_ms);
  state.counters["frame_ms_median"] = median(frame_ms);
  state.counters["frames"] = static_cast<double>(seq.frames.size());
}

}  // namespace

BENCHMARK_CAPTURE(BM_WindowEstimator, landmark_schur,
                  ovo::estimator::LinearSolver::kLandmarkSchur)
    ->Name("BM_WindowEstimator/synthetic6s/landmark_schur")
    ->Unit(benchmark::kMillisecond)
    ->Iterations(2);
BENCHMARK_CAPTURE(BM_WindowEstimator, dense_schur, ovo::estimator::LinearSolver::kDenseSchur)
    ->Name("BM_WindowEstimator/synthetic6s/dense_schur")
    ->Unit(benchmark::kMillisecond)
    ->Iterations(2);
BENCHMARK_CAPTURE(BM_WindowEstimator, sparse_schur, ovo::estimator::LinearSolver::kSparseSchur)
    ->Name("BM_WindowEstimator/synthetic6s/sparse_schur")
    ->Unit(benchmark::kMillisecond)
    ->Iterations(2);
