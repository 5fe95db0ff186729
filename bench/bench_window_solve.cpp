// The window's keyframe work on a real run: the simulated vineyard_row dataset (as
// `ovo simulate` writes it and `ovo run` reads it) through the window estimator, frontend and
// estimator stages in sequence. The frontend runs untimed; the benchmark's time is the estimator
// stage's on the keyframes (their solve and marginalisation: metrics.json's keyframe_ms), so one
// iteration's time is the sum over the run's keyframes, and the counters are the keyframes'
// median, p90 and max and the other frames' median.
//
// The dataset: OVO_BENCH_DATASET, else <source>/out/accuracy/data/vineyard_row (made by
// scripts/accuracy.sh); skipped with a message when absent. OVO_BENCH_SECONDS (default 20) cuts
// the run; OVO_BENCH_SET="window.key=value;..." overrides the configuration for experiments.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "apps/offline_runner.hpp"
#include "apps/run_metrics.hpp"
#include "common/config.hpp"
#include "common/stats.hpp"
#include "estimator/estimator.hpp"
#include "io/dataset.hpp"

namespace {

using namespace ovo;

struct RecordedRun {
  io::Dataset data;
  estimator::SensorSetup setup;
};

double envSeconds() {
  const char* s = std::getenv("OVO_BENCH_SECONDS");
  return s ? std::atof(s) : 20.0;
}

Config benchConfig() {
  Config cfg;
  if (const char* set = std::getenv("OVO_BENCH_SET")) {
    std::stringstream list(set);
    for (std::string item; std::getline(list, item, ';');)
      if (!item.empty()) cfg.applyOverride(item);
  }
  return cfg;
}

// The dataset cut to its first OVO_BENCH_SECONDS, or the reason there is none.
const std::optional<RecordedRun>& recordedRun(std::string* why) {
  static std::string reason;
  static const std::optional<RecordedRun> run = [&]() -> std::optional<RecordedRun> {
    const char* env = std::getenv("OVO_BENCH_DATASET");
    const std::filesystem::path dir =
        env ? std::filesystem::path(env)
            : std::filesystem::path(OVO_SOURCE_DIR) / "out/accuracy/data/vineyard_row";
    if (!std::filesystem::exists(dir)) {
      reason = dir.string() +
               " not found: make it with scripts/accuracy.sh or `build/ovo simulate --scenario "
               "configs/sim/vineyard_row.yaml --out DIR` and OVO_BENCH_DATASET=DIR";
      return std::nullopt;
    }
    io::Dataset data = io::loadDataset(dir);
    app::imagesOntoGyroClock(data);
    if (data.images.empty()) {
      reason = dir.string() + ": no images";
      return std::nullopt;
    }
    const Timestamp end = data.images.front().t_ns + static_cast<Timestamp>(envSeconds() * 1e9);
    std::erase_if(data.images, [&](const io::ImageEntry& e) { return e.t_ns > end; });
    estimator::SensorSetup setup = app::sensorSetupFrom(data);  // as ovo run makes it
    estimator::applyNoiseFloors(setup);
    if (estimator::estimatorUsesLidar("window", benchConfig()))  // as ovo run decides it
      app::cameraHeightFromScans(data, &setup);
    return RecordedRun{std::move(data), std::move(setup)};
  }();
  *why = reason;
  return run;
}

void BM_WindowSolve(benchmark::State& state) {
  std::string why;
  const auto& run = recordedRun(&why);
  if (!run) {
    state.SkipWithError(why.c_str());
    return;
  }
  try {  // a key mistyped in OVO_BENCH_SET is an error, as in ovo run
    Config config = benchConfig();
    estimator::makeEstimator("window", run->setup, config);
    config.checkAllUsed();
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return;
  }
  std::vector<double> keyframe_ms, other_ms;
  for (auto _ : state) {
    auto est = estimator::makeEstimator("window", run->setup, benchConfig());
    app::OfflineOptions serial;
    serial.pipelined = false;
    const app::OfflineRunResult result = app::runOffline(run->data, *est, {}, {}, serial);
    double keyframes_s = 0.0;
    for (const auto& e : result.frames) {
      (e.is_keyframe ? keyframe_ms : other_ms).push_back(e.estimator_ms);
      if (e.is_keyframe) keyframes_s += 1e-3 * e.estimator_ms;
    }
    state.SetIterationTime(keyframes_s);
  }
  state.counters["keyframes"] = static_cast<double>(keyframe_ms.size()) / state.iterations();
  // As metrics.json computes them.
  state.counters["keyframe_ms_median"] = percentile(keyframe_ms, 50);
  state.counters["keyframe_ms_p90"] = percentile(keyframe_ms, 90);
  state.counters["keyframe_ms_max"] = percentile(keyframe_ms, 100);
  state.counters["frame_ms_median"] = percentile(other_ms, 50);
}

}  // namespace

BENCHMARK(BM_WindowSolve)
    ->Name("BM_WindowSolve/vineyard_row")
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);
