// RANSAC benchmarks: whole relative-pose RANSAC per backend, its hot loop (generation
// and scoring) and the scoring alone per backend, a plain Eigen scoring loop as the reference, the
// hypothesis generation, and OpenGV's 8-point RANSAC as the peer when libopengv-dev is installed.
// Problem: wide-angle two-view bearings (up to 100 degrees off axis), 30 % outliers, 0.5 px noise
// at 305 px/rad, 2000 fixed hypotheses. Run: build/ovo_bench --benchmark_filter='BM_Ransac'
#include <benchmark/benchmark.h>

#include <map>
#include <memory>
#include <string>

#include "common/so3.hpp"
#include "frontend/essential.hpp"
#include "frontend/ransac.hpp"
#include "frontend/relative_pose.hpp"
#include "gpu/hypotheses.hpp"
#include "gpu/opencl_context.hpp"
#include "gpu/scoring.hpp"
#include "tests/gpu/two_view_scene.hpp"

#if OVO_HAVE_OPENGV
#include <opengv/relative_pose/CentralRelativeAdapter.hpp>
#include <opengv/sac/Ransac.hpp>
#include <opengv/sac_problems/relative_pose/CentralRelativePoseSacProblem.hpp>
#endif

namespace {

using namespace ovo;

constexpr int kHypotheses = 2000;
constexpr double kThresholdRad = 4e-3;  // ~2.5 sigma of 0.5 px at 305 px/rad

const test::TwoViewScene& scene(int n) {
  static std::map<int, test::TwoViewScene> cache;
  auto it = cache.find(n);
  if (it == cache.end()) {
    test::TwoViewSceneOptions o;
    o.num_matches = n;
    o.outlier_ratio = 0.3;
    o.noise_px = 0.5;
    o.seed = 1234;
    it = cache.emplace(n, test::makeTwoViewScene(o)).first;
  }
  return it->second;
}

struct SoA {
  std::vector<float> prev, cur;
  gpu::MatchesSoA view() const {
    return {prev.data(), cur.data(), static_cast<int>(prev.size() / 3)};
  }
};

SoA toSoA(const test::TwoViewScene& s) {
  const std::size_t n = s.b_prev.size();
  SoA out{std::vector<float>(3 * n), std::vector<float>(3 * n)};
  for (std::size_t i = 0; i < n; ++i)
    for (int r = 0; r < 3; ++r) {
      out.prev[r * n + i] = static_cast<float>(s.b_prev[i](r));
      out.cur[r * n + i] = static_cast<float>(s.b_cur[i](r));
    }
  return out;
}

std::vector<float> hypotheses(const test::TwoViewScene& s) {
  std::vector<float> E(9 * kHypotheses, 0.0f);
  const test::SoAd soa = test::toSoAd(s);
  gpu::generateHypothesesCpu(soa.view(), 42, 0, kHypotheses, E.data());
  return E;
}

void setAccuracyCounters(benchmark::State& state, const test::TwoViewScene& s, const Mat3& R,
                         const Vec3& t) {
  const Vec3 t_true = s.t_cur_prev.normalized();
  state.counters["rot_err_deg"] = so3::angle(R.transpose() * s.R_cur_prev) * 180 / M_PI;
  state.counters["tdir_err_deg"] = std::atan2(t.cross(t_true).norm(), t.dot(t_true)) * 180 / M_PI;
}

void BM_Ransac(benchmark::State& state, const std::string& backend, int n) {
  const auto& s = scene(n);
  frontend::RelativePoseOptions o;
  o.backend = backend;
  o.max_iterations = kHypotheses;
  o.inlier_threshold_rad = kThresholdRad;
  frontend::RelativePoseEstimator estimator(o);
  frontend::RelativePoseResult r;
  for (auto _ : state) {
    r = estimator.estimate(s.b_prev, s.b_cur);
    benchmark::DoNotOptimize(r.num_inliers);
  }
  setAccuracyCounters(state, s, r.R_cur_prev, r.t_cur_prev);
  state.counters["inliers"] = r.num_inliers;
  state.counters["ok"] = r.status == frontend::RelativePoseResult::Status::kOk;
}

void BM_RansacScore(benchmark::State& state, const std::string& backend, int n) {
  const auto& s = scene(n);
  const SoA soa = toSoA(s);
  const auto E = hypotheses(s);
  auto scorer = gpu::makeScoringBackend(backend);
  scorer->setMatches(soa.view());
  std::vector<int> counts(kHypotheses);
  const float k = gpu::inlierConstant(kThresholdRad);
  for (auto _ : state) {
    scorer->score(E.data(), kHypotheses, k, counts.data());
    benchmark::DoNotOptimize(counts.data());
  }
  state.counters["ns_per_hyp_x_match"] = benchmark::Counter(
      static_cast<double>(kHypotheses) * s.b_prev.size(),
      benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

// The reference a scoring kernel must beat: Eigen fixed-size types, the sphere error with its
// division, one hypothesis and one match at a time.
void BM_RansacScoreEigenNaive(benchmark::State& state) {
  const auto& s = scene(1000);
  const auto Ef = hypotheses(s);
  std::vector<Eigen::Matrix3f> E(kHypotheses);
  for (int h = 0; h < kHypotheses; ++h)
    for (int j = 0; j < 9; ++j) E[h](j / 3, j % 3) = Ef[9 * h + j];
  std::vector<Eigen::Vector3f> bp, bc;
  for (std::size_t i = 0; i < s.b_prev.size(); ++i) {
    bp.push_back(s.b_prev[i].cast<float>());
    bc.push_back(s.b_cur[i].cast<float>());
  }
  const float thr2 = static_cast<float>(kThresholdRad * kThresholdRad);
  std::vector<int> counts(kHypotheses);
  for (auto _ : state) {
    for (int h = 0; h < kHypotheses; ++h) {
      int c = 0;
      for (std::size_t i = 0; i < bp.size(); ++i) {
        const Eigen::Vector3f a = E[h] * bp[i];
        const Eigen::Vector3f d = E[h].transpose() * bc[i];
        const float num = bc[i].dot(a);
        const float den = (a - bc[i] * num).squaredNorm() + (d - bp[i] * num).squaredNorm();
        c += num * num / den < thr2;
      }
      counts[h] = c;
    }
    benchmark::DoNotOptimize(counts.data());
  }
  state.counters["ns_per_hyp_x_match"] = benchmark::Counter(
      static_cast<double>(kHypotheses) * s.b_prev.size(),
      benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

// 2000 minimal 8-point solves (sampling, batched Householder null vector, Jacobi projection) as
// the backend generates them: one thread, the pool, or the OpenCL device (read back to the host).
void BM_RansacHypotheses(benchmark::State& state, const std::string& backend) {
  const auto& s = scene(1000);
  const SoA soa = toSoA(s);
  const test::SoAd soa_d = test::toSoAd(s);
  auto scorer = gpu::makeScoringBackend(backend);
  scorer->setMatches(soa.view(), soa_d.view());
  std::vector<float> E(9 * kHypotheses);
  for (auto _ : state) {
    scorer->generate(42, 0, kHypotheses, E.data());
    benchmark::DoNotOptimize(E.data());
  }
}

// RANSAC's hot loop alone: 2000 hypotheses generated and scored against n matches (the part of
// BM_Ransac that the backend runs; the rest is the refit and refinement).
void BM_RansacHot(benchmark::State& state, const std::string& backend, int n) {
  const auto& s = scene(n);
  const SoA soa = toSoA(s);
  const test::SoAd soa_d = test::toSoAd(s);
  auto scorer = gpu::makeScoringBackend(backend);
  scorer->setMatches(soa.view(), soa_d.view());
  std::vector<int> counts(kHypotheses);
  const float k = gpu::inlierConstant(kThresholdRad);
  for (auto _ : state) {
    scorer->generateAndScore(42, 0, kHypotheses, k, counts.data());
    benchmark::DoNotOptimize(counts.data());
  }
}

#if OVO_HAVE_OPENGV
// The peer: OpenGV's central relative-pose RANSAC with its 8-point solver (Kneip, Furgale,
// "OpenGV", ICRA 2014), one thread, the same 2000 hypotheses (probability 1: no early stop), the
// same angular threshold (OpenGV thresholds 1 - cos(angle) of reprojected bearings). OpenGV
// returns the best sample's model without a refit; ours is refit and refined on the inliers.
void BM_RansacOpenGv(benchmark::State& state, int n) {
  namespace sac = opengv::sac;
  using Problem = opengv::sac_problems::relative_pose::CentralRelativePoseSacProblem;
  const auto& s = scene(n);
  opengv::bearingVectors_t b1(s.b_prev.begin(), s.b_prev.end());
  opengv::bearingVectors_t b2(s.b_cur.begin(), s.b_cur.end());
  opengv::relative_pose::CentralRelativeAdapter adapter(b1, b2);
  opengv::transformation_t T_prev_cur = opengv::transformation_t::Zero();
  std::size_t inliers = 0;
  for (auto _ : state) {
    sac::Ransac<Problem> ransac;
    ransac.sac_model_ = std::make_shared<Problem>(adapter, Problem::EIGHTPT);
    ransac.threshold_ = 1.0 - std::cos(kThresholdRad);
    ransac.max_iterations_ = kHypotheses - 1;  // OpenGV stops after iterations_ > max_iterations_
    ransac.probability_ = 1.0;
    ransac.computeModel();
    T_prev_cur = ransac.model_coefficients_;
    inliers = ransac.inliers_.size();
    benchmark::DoNotOptimize(T_prev_cur.data());
  }
  // OpenGV's (R, t) maps points of the second (current) frame into the first (previous) one.
  const Mat3 R_cur_prev = T_prev_cur.leftCols<3>().transpose();
  const Vec3 t_cur_prev = -(R_cur_prev * T_prev_cur.col(3)).normalized();
  setAccuracyCounters(state, s, R_cur_prev, t_cur_prev);
  state.counters["inliers"] = static_cast<double>(inliers);
}
#endif

const bool registered = [] {
  std::vector<std::string> backends = {"serial", "threads"};
  if (gpu::OpenClContext::shared()) backends.push_back("opencl");
  for (const auto& b : backends) {
    for (int n : {250, 1000, 4000}) {
      const std::string size = "/" + b + "/" + std::to_string(n);
      benchmark::RegisterBenchmark(("BM_Ransac" + size).c_str(),
                                   [b, n](benchmark::State& st) { BM_Ransac(st, b, n); })
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime();
      benchmark::RegisterBenchmark(("BM_RansacScore" + size).c_str(),
                                   [b, n](benchmark::State& st) { BM_RansacScore(st, b, n); })
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime();
      benchmark::RegisterBenchmark(("BM_RansacHot" + size).c_str(),
                                   [b, n](benchmark::State& st) { BM_RansacHot(st, b, n); })
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime();
    }
    benchmark::RegisterBenchmark(("BM_RansacHypotheses/" + b + "/2000").c_str(),
                                 [b](benchmark::State& st) { BM_RansacHypotheses(st, b); })
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
  }
#if OVO_HAVE_OPENGV
  for (int n : {250, 1000, 4000})
    benchmark::RegisterBenchmark(("BM_Ransac/opengv8pt/" + std::to_string(n)).c_str(),
                                 [n](benchmark::State& st) { BM_RansacOpenGv(st, n); })
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
#endif
  benchmark::RegisterBenchmark("BM_RansacScore/eigen_naive/1000", BM_RansacScoreEigenNaive)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  return true;
}();

}  // namespace
