// `ovo tracks`: how true the frontend's tracks are on a simulated scenario. Renders the scenario
// in memory, runs the frontend over it (the true rotation between frames as its prior, as a gyro
// would give it) and compares every track with the point it started on (sim/track_truth.hpp):
// its error after 1, 5, 10 and 20 frames along and across the point's rotation-compensated flow,
// by what the track started on (next to a depth edge, far, ground, other surfaces), and the
// camera rotation per frame that each kind's steps imply. Prints a table; --json writes it too.
#include <spdlog/spdlog.h>
#include <tbb/parallel_for.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>

#include "apps/command.hpp"
#include "common/config.hpp"
#include "common/error.hpp"
#include "frontend/frontend.hpp"
#include "sim/scenario.hpp"
#include "sim/simulation.hpp"
#include "sim/track_truth.hpp"

namespace ovo::app {
namespace {

struct TracksArgs {
  std::string config = "configs/sim/vineyard_row.yaml";
  std::optional<std::int64_t> seed;
  std::optional<int> frames;
  std::vector<std::string> sim_sets;  // the scenario's keys
  std::vector<std::string> sets;      // frontend.* keys
  std::string json;
};

nlohmann::json trackTruthJson(const sim::TrackTruthReport& r) {
  nlohmann::json kinds = nlohmann::json::array();
  for (int k = 0; k <= sim::kTrackKinds; ++k) {
    nlohmann::json ages = nlohmann::json::array();
    for (std::size_t a = 0; a < sim::kTrackErrorAges.size(); ++a) {
      const sim::TrackErrorCell& c = r.cells[k][a];
      ages.push_back({{"age", sim::kTrackErrorAges[a]},
                      {"tracks", c.n},
                      {"jumped", c.jumped},
                      {"no_flow", c.no_flow},
                      {"median_abs_along_px", c.median_abs_along},
                      {"mean_along_px", c.mean_along},
                      {"median_abs_across_px", c.median_abs_across},
                      {"mean_across_px", c.mean_across},
                      {"median_px", c.median_norm},
                      {"p90_px", c.p90_norm}});
    }
    const Vec3& w = r.rotation_per_frame[k];
    kinds.push_back(
        {{"kind",
          k == sim::kTrackKinds ? "all" : sim::trackKindName(static_cast<sim::TrackKind>(k))},
         {"tracks_started", k == sim::kTrackKinds ? 0 : r.tracks_by_kind[k]},
         {"ages", ages},
         {"rotation_per_frame_urad", {1e6 * w.x(), 1e6 * w.y(), 1e6 * w.z()}},
         {"steps_per_frame", r.steps_per_frame[k]},
         {"rotation_frames", r.rotation_frames[k]}});
  }
  return {{"frames", r.frames}, {"tracks_unclassified", r.tracks_unclassified}, {"kinds", kinds}};
}

int runTracks(const TracksArgs& args) {
  Config scenario_cfg = Config::load(args.config);
  scenario_cfg.applyOverrides(args.sim_sets);
  if (args.seed) scenario_cfg.applyOverride(fmt::format("seed={}", *args.seed));
  if (args.frames) scenario_cfg.applyOverride(fmt::format("frames={}", *args.frames));
  const sim::Simulation simulation(sim::readScenario(scenario_cfg));
  Config frontend_cfg;
  frontend_cfg.applyOverrides(args.sets);
  const frontend::FrontendOptions options = frontend::readFrontendOptions(frontend_cfg);
  frontend_cfg.checkAllUsed();  // a misspelt --set key is an error, not the default
  frontend::Frontend frontend(simulation.camera(), options);
  sim::TrackTruth truth(simulation);
  const int frames = simulation.frameCount();
  spdlog::info("tracks: scenario '{}', seed {}, {} frames", simulation.scenario().name,
               simulation.scenario().seed, frames);
  constexpr int kBatch = 32;  // frames rendered in parallel, then tracked in order
  std::vector<cv::Mat> batch(kBatch);
  std::optional<SE3> prev_T_W_C;
  for (int first = 0; first < frames; first += kBatch) {
    const int n = std::min(kBatch, frames - first);
    tbb::parallel_for(0, n, [&](int i) {
      batch[i] = simulation.frameDropped(first + i) ? cv::Mat() : simulation.renderFrame(first + i);
    });
    for (int i = 0; i < n; ++i) {
      if (batch[i].empty()) continue;
      const int k = first + i;
      const SE3 T_W_C = simulation.trajectory().T_W_B(simulation.frameTime(k)) * simulation.T_B_C();
      std::optional<Mat3> prior;
      if (prev_T_W_C) prior = T_W_C.linear().transpose() * prev_T_W_C->linear();
      prev_T_W_C = T_W_C;
      const frontend::FrontendResult r =
          frontend.process(simulation.frameStamp(k), batch[i], prior);
      std::vector<sim::TrackSighting> sightings;
      sightings.reserve(r.observations.size());
      for (const frontend::FeatureObservation& o : r.observations)
        sightings.push_back({o.track_id, o.px});
      truth.addFrame(k, sightings);
    }
    spdlog::debug("tracks: {}/{} frames", first + n, frames);
  }
  const sim::TrackTruthReport report = truth.report();
  fmt::print("{}", sim::formatTrackTruth(report));
  if (!args.json.empty()) {
    std::ofstream out(args.json);
    if (!out) throw Error(fmt::format("{}: cannot write", args.json));
    out << trackTruthJson(report).dump(2) << '\n';
    if (!out) throw Error(fmt::format("{}: write failed", args.json));
  }
  return 0;
}

}  // namespace

OVO_REGISTER_COMMAND(tracks, "Measure the frontend's tracks against a simulated scenario's truth",
                     [](CLI::App& sub) -> CommandRunner {
                       auto args = std::make_shared<TracksArgs>();
                       sub.add_option("--config", args->config, "Scenario file")
                           ->capture_default_str()
                           ->check(CLI::ExistingFile);
                       sub.add_option("--seed", args->seed, "Scenario seed");
                       sub.add_option("--frames", args->frames, "Frames to render (default: all)")
                           ->check(CLI::PositiveNumber);
                       sub.add_option("--sim-set", args->sim_sets,
                                      "Scenario key=value (repeatable)");
                       sub.add_option("--set", args->sets,
                                      "Frontend key=value, e.g. "
                                      "frontend.track_refine=false (repeatable)");
                       sub.add_option("--json", args->json, "Also write the table as JSON");
                       return [args] { return runTracks(*args); };
                     });

}  // namespace ovo::app
