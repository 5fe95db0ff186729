// Simulator rendering speed: frames per second of the ray-cast vineyard (image noise and exposure
// included), for the default fisheye scenario, its pinhole twin, vineyard_real (uneven ground,
// wind, rolling shutter, auto-exposure) and vineyard_block (the same over a whole block).
#include <benchmark/benchmark.h>

#include <memory>

#include "common/config.hpp"
#include "sim/scenario.hpp"
#include "sim/simulation.hpp"

namespace {

void BM_Render(benchmark::State& state, const char* scenario_file) {
  const ovo::sim::Scenario scenario = ovo::sim::readScenario(
      ovo::Config::load(std::string(OVO_SOURCE_DIR) + "/configs/sim/" + scenario_file));
  const ovo::sim::Simulation sim(scenario);
  int k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(sim.renderFrame(k).data);
    k = (k + 37) % sim.frameCount();  // walk through the sequence: rows, headland, turn
  }
  state.counters["fps"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

}  // namespace

BENCHMARK_CAPTURE(BM_Render, ocam640x480, "vineyard_row.yaml")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_Render, pinhole640x480, "vineyard_row_pinhole.yaml")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_Render, ocam640x480_real, "vineyard_real.yaml")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_Render, ocam640x480_block, "vineyard_block.yaml")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
