// Frontend speed (target: detection + matching + serial RANSAC <= 10 ms median per 640x480
// frame on one core). Frame pairs: KITTI 07 frames 0/1 from the shared data, and a 640x480 fisheye
// pair rendered by the simulator (vineyard_row, RoMoVi OCamCalib camera). Stage counters are thread
// CPU ms; OVO_BENCH_SET="frontend.key=value;..." overrides frontend options for experiments.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <random>
#include <sstream>
#include <string>

#include "camera/calib_io.hpp"
#include "common/config.hpp"
#include "frontend/delaunay.hpp"
#include "frontend/features.hpp"
#include "frontend/frontend.hpp"
#include "frontend/matcher.hpp"
#include "frontend/track_refine.hpp"
#include "sim/simulation.hpp"

namespace {

using namespace ovo;

struct FramePair {
  camera::Camera camera;
  cv::Mat a, b;
};

std::optional<FramePair> kittiPair() {
  const std::filesystem::path dir =
      std::filesystem::path(OVO_SHARED_DATA_DIR) / "kitti07-first160/image_0";
  if (!std::filesystem::exists(dir / "000001.png")) return std::nullopt;
  FramePair p{camera::PinholeRadtanCamera(707.0912, 707.0912, 601.8873, 183.1104, 1226, 370),
              cv::imread((dir / "000000.png").string(), cv::IMREAD_GRAYSCALE),
              cv::imread((dir / "000001.png").string(), cv::IMREAD_GRAYSCALE)};
  if (p.a.empty() || p.b.empty()) return std::nullopt;
  return p;
}

std::optional<FramePair> ocamPair() {
  static std::optional<FramePair> cached;
  if (cached) return cached;
  const std::filesystem::path root(OVO_SOURCE_DIR);
  Config cfg = Config::load(root / "configs/sim/vineyard_row.yaml");
  cfg.applyOverride("camera.calibration=" + (root / "configs/cameras/romovi_ocam.txt").string());
  const sim::Simulation simulation(sim::readScenario(cfg));
  cached = FramePair{simulation.camera(), simulation.renderFrame(40), simulation.renderFrame(41)};
  return cached;
}

// Defaults, or the frontend keys of OVO_BENCH_SET ("frontend.key=value;...") for experiments.
frontend::FrontendOptions benchOptions(bool half = false, const std::string& backend = "serial") {
  Config cfg;
  if (const char* set = std::getenv("OVO_BENCH_SET")) {
    std::stringstream list(set);
    for (std::string item; std::getline(list, item, ';');) {
      if (!item.empty()) cfg.applyOverride(item);
    }
  }
  frontend::FrontendOptions options = frontend::readFrontendOptions(cfg);
  options.relative_pose.backend = backend;
  options.detector.half_resolution = half;
  return options;
}

// One iteration = one frame: the two images alternate, so every frame is matched with the other.
// Tracks matched here never end; the default history cap (TrackerOptions::max_history) bounds
// their storage as in a real sequence (uncapped, the benchmark measured growing buffers).
// backend: the RANSAC backend (the frontend's end-to-end time with each one is wanted); the
// stage counters are CPU time of this thread, so compare the threads/opencl variants by wall time.
void runFrontend(benchmark::State& state, const std::optional<FramePair>& pair, bool half = false,
                 const std::string& backend = "serial") {
  if (!pair) {
    state.SkipWithError("frame pair not available (../shared/data or sim/)");
    return;
  }
  std::optional<frontend::Frontend> made;
  try {
    made.emplace(pair->camera, benchOptions(half, backend));
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());  // e.g. opencl without a device
    return;
  }
  frontend::Frontend& frontend = *made;
  frontend.process(0, pair->a);
  frontend::FrontendTimings sum;  // thread CPU time
  double features = 0, queries = 0, matches = 0, bucketed = 0, inliers = 0;
  std::int64_t k = 1;
  for (auto _ : state) {
    const auto r = frontend.process(k * 50'000'000, (k % 2) ? pair->b : pair->a);
    ++k;
    sum.filter_ms += r.cpu_timings.filter_ms;
    sum.nms_ms += r.cpu_timings.nms_ms;
    sum.match_ms += r.cpu_timings.match_ms;
    sum.ransac_ms += r.cpu_timings.ransac_ms;
    sum.track_ms += r.cpu_timings.track_ms;
    features += r.num_features;
    queries += r.match_stats.queries;
    matches += r.num_matches_before_bucketing;
    bucketed += static_cast<double>(r.matches.size());
    inliers += r.relative_pose ? r.relative_pose->num_inliers : 0;
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["filter_ms"] = sum.filter_ms / n;
  state.counters["nms_ms"] = sum.nms_ms / n;
  state.counters["match_ms"] = sum.match_ms / n;
  state.counters["ransac_ms"] = sum.ransac_ms / n;
  state.counters["track_ms"] = sum.track_ms / n;
  state.counters["features"] = features / n;
  state.counters["queries"] = queries / n;
  state.counters["matches"] = matches / n;
  state.counters["bucketed"] = bucketed / n;
  state.counters["inliers"] = inliers / n;
}

void runFilters(benchmark::State& state, const std::optional<FramePair>& pair) {
  if (!pair) {
    state.SkipWithError("frame pair not available");
    return;
  }
  frontend::FilterImages filters;
  for (auto _ : state) {
    frontend::computeFilters(pair->a, &filters);
    benchmark::DoNotOptimize(filters.blob.data());
  }
}

void runDetect(benchmark::State& state, const std::optional<FramePair>& pair, bool half) {
  if (!pair) {
    state.SkipWithError("frame pair not available");
    return;
  }
  frontend::DetectorOptions options;
  options.half_resolution = half;
  frontend::FeatureFrame frame;
  for (auto _ : state) {
    frontend::extractFeatures(pair->a, options, cv::Mat(), &frame);
    benchmark::DoNotOptimize(frame.features.data());
  }
  state.counters["features"] = frame.size();
}

void runMatch(benchmark::State& state, const std::optional<FramePair>& pair, bool half) {
  if (!pair) {
    state.SkipWithError("frame pair not available");
    return;
  }
  const frontend::DetectorOptions options = benchOptions(half).detector;
  frontend::FeatureFrame a, b;
  frontend::extractFeatures(pair->a, options, cv::Mat(), &a);
  frontend::extractFeatures(pair->b, options, cv::Mat(), &b);
  frontend::Matcher matcher(benchOptions(half).matcher);
  std::size_t n = 0;
  double sparse_ms = 0, dense_ms = 0, delaunay_ms = 0, refine_ms = 0, sparse_matches = 0;
  for (auto _ : state) {
    frontend::MatchStats stats;
    const auto matches = matcher.match(a, b, nullptr, &stats);
    n = matches.size();
    sparse_ms += stats.sparse_ms;
    dense_ms += stats.dense_ms;
    delaunay_ms += stats.delaunay_ms;
    refine_ms += stats.refine_ms;
    sparse_matches += stats.sparse_matches;
    benchmark::DoNotOptimize(matches.data());
  }
  const double iters = static_cast<double>(state.iterations());
  state.counters["matches"] = static_cast<double>(n);
  state.counters["sparse_matches"] = sparse_matches / iters;
  state.counters["sparse_ms"] = sparse_ms / iters;
  state.counters["dense_ms"] = dense_ms / iters;
  state.counters["delaunay_ms"] = delaunay_ms / iters;
  state.counters["refine_ms"] = refine_ms / iters;
}

// The Lucas-Kanade step (frontend/track_refine) of every match of a pair on one thread, from the
// match's own pixels: time_per_step is the cost of one track step (s), refined the share it moves.
void runTrackRefine(benchmark::State& state, const std::optional<FramePair>& pair) {
  if (!pair) {
    state.SkipWithError("frame pair not available");
    return;
  }
  const frontend::FrontendOptions options = benchOptions();
  frontend::FeatureFrame a, b;
  frontend::extractFeatures(pair->a, options.detector, cv::Mat(), &a);
  frontend::extractFeatures(pair->b, options.detector, cv::Mat(), &b);
  const auto matches = frontend::Matcher(options.matcher).match(a, b, nullptr, nullptr);
  const frontend::TrackStepRefiner refiner(options.track_refine);
  std::size_t refined = 0;
  for (auto _ : state) {
    refined = 0;
    for (const frontend::Match& m : matches)
      refined += refiner.refine(pair->a, m.px_prev, pair->b, m.px_cur).has_value();
  }
  const double steps = static_cast<double>(matches.size());
  state.counters["steps"] = steps;
  state.counters["refined"] = static_cast<double>(refined) / steps;
  state.counters["time_per_step"] =
      benchmark::Counter(steps * static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

// Delaunay flow filter on n uniformly random points of a 640x480 image, 5 % planted outliers.
void runDelaunay(benchmark::State& state) {
  const auto n = static_cast<std::size_t>(state.range(0));
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 640.0), v(0.0, 480.0);
  std::vector<Vec2> px(n), flow(n, Vec2(2.0, -1.0));
  for (std::size_t k = 0; k < n; ++k) {
    const double pv = v(rng),
                 pu = u(rng);  // one draw a statement: a call's arguments have no fixed order
    px[k] = Vec2(pu, pv);
    if (k % 20 == 0) flow[k] = Vec2(20.0, 5.0);
  }
  for (auto _ : state) {
    const auto keep = frontend::delaunaySupportFilter(px, flow, 5.0, 4);
    benchmark::DoNotOptimize(keep.data());
  }
}

const bool registered = [] {
  const auto unit = [](benchmark::internal::Benchmark* b) { b->Unit(benchmark::kMillisecond); };
  unit(benchmark::RegisterBenchmark("BM_Frontend/ocam640x480",
                                    [](benchmark::State& s) { runFrontend(s, ocamPair()); }));
  unit(benchmark::RegisterBenchmark("BM_Frontend/kitti1226x370",
                                    [](benchmark::State& s) { runFrontend(s, kittiPair()); }));
  for (const char* backend : {"serial", "threads", "opencl"})
    benchmark::RegisterBenchmark(
        (std::string("BM_Frontend/") + backend + "/ocam640x480").c_str(),
        [backend](benchmark::State& s) { runFrontend(s, ocamPair(), false, backend); })
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
  unit(benchmark::RegisterBenchmark("BM_Frontend/half/ocam640x480",
                                    [](benchmark::State& s) { runFrontend(s, ocamPair(), true); }));
  unit(benchmark::RegisterBenchmark("BM_Frontend/half/kitti1226x370", [](benchmark::State& s) {
    runFrontend(s, kittiPair(), true);
  }));
  unit(benchmark::RegisterBenchmark("BM_Filters/full/ocam640x480",
                                    [](benchmark::State& s) { runFilters(s, ocamPair()); }));
  unit(benchmark::RegisterBenchmark("BM_Filters/full/kitti1226x370",
                                    [](benchmark::State& s) { runFilters(s, kittiPair()); }));
  unit(benchmark::RegisterBenchmark("BM_Detect/full/ocam640x480",
                                    [](benchmark::State& s) { runDetect(s, ocamPair(), false); }));
  unit(benchmark::RegisterBenchmark("BM_Detect/half/ocam640x480",
                                    [](benchmark::State& s) { runDetect(s, ocamPair(), true); }));
  unit(benchmark::RegisterBenchmark("BM_Match/full/ocam640x480",
                                    [](benchmark::State& s) { runMatch(s, ocamPair(), false); }));
  unit(benchmark::RegisterBenchmark("BM_Match/half/ocam640x480",
                                    [](benchmark::State& s) { runMatch(s, ocamPair(), true); }));
  unit(benchmark::RegisterBenchmark("BM_Match/full/kitti1226x370",
                                    [](benchmark::State& s) { runMatch(s, kittiPair(), false); }));
  unit(benchmark::RegisterBenchmark("BM_TrackRefine/ocam640x480",
                                    [](benchmark::State& s) { runTrackRefine(s, ocamPair()); }));
  unit(benchmark::RegisterBenchmark("BM_TrackRefine/kitti1226x370",
                                    [](benchmark::State& s) { runTrackRefine(s, kittiPair()); }));
  benchmark::RegisterBenchmark("BM_Delaunay/support", runDelaunay)
      ->Arg(1000)
      ->Arg(5000)
      ->Unit(benchmark::kMillisecond);
  return true;
}();

}  // namespace
