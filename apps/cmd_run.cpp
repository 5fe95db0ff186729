// `ovo run`: runs an estimator over a dataset and writes trajectory.txt, keyframes.txt,
// metrics.json and report.html into --out, all through a staging folder (io::StagedFolder): a
// failed run leaves nothing half-written, and --out replaces only an earlier run's output.
// --realtime replays the dataset at sensor rate through the threaded online pipeline (frames
// dropped when behind, latency measured); --viewer shows the live window.
#include <spdlog/spdlog.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <opencv2/core/utility.hpp>
#include <optional>
#include <set>

#include "apps/command.hpp"
#include "apps/offline_runner.hpp"
#include "apps/online_replay.hpp"
#include "apps/progress.hpp"
#include "apps/report.hpp"
#include "apps/run_budget.hpp"
#include "apps/run_metrics.hpp"
#include "apps/run_summary.hpp"
#include "apps/viewer.hpp"
#include "common/error.hpp"
#include "common/process_usage.hpp"
#include "io/dataset.hpp"
#include "io/staged_folder.hpp"
#include "io/text_reader.hpp"
#include "io/trajectory_io.hpp"

namespace ovo::app {
namespace {

struct RunArgs {
  std::string dataset;
  std::string rig, topics;  // bags only
  std::string config;
  std::string estimator = "window";
  std::string refine;  // --refine none|full (window only)
  std::string out;
  std::string gt;
  std::vector<std::string> sets;
  bool quiet = false;
  bool json = false;
  bool realtime = false;
  bool serial = false;
  int threads = 0;              // at most this many threads (0: every core)
  std::string budget = "full";  // compute preset (apps/run_budget.hpp)
  bool strict = false;          // a bad record in a stream is an error (else skipped and counted)
  double rate = 1.0;
  int queue_depth = 2;
  bool viewer = false;
  std::string viewer_snapshot;
};

// What `ovo run --out` writes: an existing folder holding only these is an earlier run's output
// and may be replaced; anything else there is refused.
const std::set<std::string> kRunOutputNames = {
    "trajectory.txt", "trajectory_online.txt", "keyframes.txt", "gyro_bias.csv",
    "metrics.json",   "config.yaml",           "report.html"};

// The scan nearest in time to t_ns (null when there is none).
const LidarScan* nearestScan(const std::vector<LidarScan>& scans, Timestamp t_ns) {
  const auto it = std::lower_bound(scans.begin(), scans.end(), t_ns,
                                   [](const LidarScan& s, Timestamp t) { return s.t_ns < t; });
  const LidarScan* best = it != scans.end() ? &*it : nullptr;
  if (it != scans.begin() && (!best || t_ns - std::prev(it)->t_ns < best->t_ns - t_ns))
    best = &*std::prev(it);
  return best;
}

// Checked to the end, the close included (a full disk shows at the last flush).
void writeText(const std::filesystem::path& file, const std::string& text) {
  io::writeFileAtomically(file, text);
}

int runRun(const RunArgs& args) {
  const ProcessUsage usage_at_start = processUsage();
  // Offline stages in sequence: --serial, or one thread (--threads 1).
  const bool serial = args.serial || (args.threads == 1 && !args.realtime);
  // --threads: before anything starts a thread pool (PoCL reads its variable when the OpenCL
  // platform loads, with the frontend's RANSAC).
  std::optional<tbb::global_control> thread_limit;
  if (args.threads > 0) {
    thread_limit.emplace(tbb::global_control::max_allowed_parallelism,
                         static_cast<std::size_t>(args.threads));
    cv::setNumThreads(args.threads);
    ::setenv("POCL_MAX_PTHREAD_COUNT", std::to_string(args.threads).c_str(), 0);
  }
  Config config;
  if (!args.config.empty()) config = Config::load(args.config);
  config.applyOverrides(args.sets);
  applyBudget(config, args.budget, args.estimator);
  if (args.realtime) applyOnlineSolveBudget(config, args.estimator);
  if (!args.refine.empty()) {
    if (args.estimator != "window")
      fail("--refine {}: only the window estimator refines (got --estimator {})", args.refine,
           args.estimator);
    config.applyOverride("window.refine=" + args.refine);
  }

  const io::RecordPolicy records{.strict = args.strict};
  io::Dataset data = io::loadDataset(
      args.dataset, {.rig = args.rig, .topics = args.topics, .strict = args.strict});
  const double time_offset_s = data.rig.camera_time_offset_s;
  const std::optional<std::string> clock_note = imagesOntoGyroClock(data);
  if (data.images.empty()) fail("{}: the dataset has no images", args.dataset);
  for (const auto& kind : data.skipped.kinds()) warnSkipped(kind);
  io::SkippedRecords skipped = data.skipped;
  Trajectory groundtruth = data.groundtruth;
  if (!args.gt.empty()) groundtruth = io::readGroundtruthFor(data, args.gt);

  estimator::SensorSetup setup = sensorSetupFrom(data);
  std::vector<std::string> setup_notes = estimator::applyNoiseFloors(setup);
  if (clock_note) setup_notes.push_back(*clock_note);
  for (auto& note : io::lidarTimingNotes(data)) setup_notes.push_back(std::move(note));
  // An estimator that uses the LiDAR may take the camera height from it when the rig gives none
  // (vo, the plain camera chain, stays without).
  if (estimator::estimatorUsesLidar(args.estimator, config))
    if (auto note = cameraHeightFromScans(data, &setup)) setup_notes.push_back(*note);
  auto est = estimator::makeEstimator(args.estimator, setup, config);
  config.checkAllUsed();  // unknown keys are errors, before any work is done
  // The output folder is checked (and its staging folder made) before any work is done too.
  std::optional<io::StagedFolder> out;
  if (!args.out.empty())
    out.emplace(args.out, "--out", io::StagedFolder::Replace::kIfOwnOutput, kRunOutputNames);
  spdlog::info("ovo run: {} on {} ({} frames, {} gyro samples, {} scans, camera {})", est->name(),
               args.dataset, data.images.size(), data.imu.size(), data.scans.size(),
               camera::modelName(setup.camera));
  setup_notes.insert(setup_notes.begin(), data.notes.begin(), data.notes.end());
  for (const auto& note : setup_notes) spdlog::info("{}", note);
  for (auto& note : io::clockOverlapNotes(data, groundtruth)) {
    spdlog::warn("{}", note);
    setup_notes.push_back(std::move(note));
  }

  std::unique_ptr<Viewer> viewer;
  if (args.viewer || !args.viewer_snapshot.empty()) {
    if (args.viewer) Viewer::checkDisplay();
    ViewerOptions options;
    options.show_window = args.viewer;
    options.window_title = "ovo run: " + est->name();
    viewer = std::make_unique<Viewer>(setup, est->name(), options);
    // The run's time span only (a ground-truth file may cover a whole sequence).
    Trajectory gt_span;
    for (const auto& p : groundtruth)
      if (p.t_ns >= data.images.front().t_ns - 100'000'000 &&
          p.t_ns <= data.images.back().t_ns + 100'000'000)
        gt_span.push_back(p);
    viewer->setGroundTruth(gt_span);
  }

  ProgressBar bar(est->name() + (args.realtime ? " (realtime)" : ""), !args.quiet);
  std::vector<estimator::FrameEstimate> frames;
  RunTiming timing;
  // CPU and memory about once a second (the progress callback comes from one thread).
  const auto run_start = std::chrono::steady_clock::now();
  double next_sample_s = 0.0;
  const ProgressFn progress = [&](int done, int total) {
    bar.update(done, total);
    const double wall_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - run_start).count();
    if (wall_s < next_sample_s && done < total) return;
    timing.resources.push_back(
        {wall_s, done, processUsage().cpu_s - usage_at_start.cpu_s, currentRssMb()});
    next_sample_s = wall_s + 1.0;
  };
  double replay_lag_ms_max = 0.0;
  auto work = [&] {
    if (args.realtime) {
      RealtimeOptions options;
      options.rate = args.rate;
      options.pipeline.image_queue_depth = args.queue_depth;
      options.records = records;
      OnlinePipeline::OutputCallback on_output;
      if (viewer)
        on_output = [&](const OnlineOutput& o) {
          if (o.last_scan) viewer->addScan(*o.last_scan);
          viewer->addFrame(o.estimate, o.grey, {o.frames_dropped, o.latency_ms});
        };
      RealtimeRunResult r = runRealtime(data, *est, options, on_output, progress);
      frames = std::move(r.frames);
      timing.wall_s = r.wall_s;
      timing.frames_in = r.stats.frames_in;
      timing.frames_dropped = r.stats.frames_dropped;
      timing.latency_ms = r.stats.latency_ms;
      replay_lag_ms_max = r.replay_lag_ms_max;
      skipped.merge(r.skipped);
    } else {
      FrameFn on_frame;
      if (viewer)
        on_frame = [&](const estimator::FrameEstimate& f, const cv::Mat& grey) {
          if (const LidarScan* scan = nearestScan(data.scans, f.t_ns)) viewer->addScan(*scan);
          viewer->addFrame(f, grey);
        };
      OfflineRunResult r =
          runOffline(data, *est, progress, on_frame, {.pipelined = !serial, .records = records});
      frames = std::move(r.frames);
      skipped.merge(r.skipped);
      timing.wall_s = r.wall_s;
    }
  };
  if (args.viewer)
    runWithViewer(*viewer, work);
  else
    work();
  bar.finish();
  if (viewer && !args.viewer_snapshot.empty()) {
    viewer->saveSnapshot(args.viewer_snapshot);
    spdlog::info("viewer snapshot: {}", args.viewer_snapshot);
  }
  if (args.realtime)
    spdlog::info(
        "realtime: {} of {} frames processed, {} dropped, latency median {:.1f} ms, p99 {:.1f} ms",
        frames.size(), timing.frames_in, timing.frames_dropped.value_or(0),
        percentile(timing.latency_ms, 50), percentile(timing.latency_ms, 99));
  const Trajectory trajectory = est->trajectory();

  for (const auto& f : frames) {
    if (f.is_keyframe) {
      timing.keyframe_ms.push_back(f.estimator_ms);
      timing.keyframe_frame.push_back(timing.total_ms.size());
    }
    timing.frontend_ms.push_back(f.frontend_ms);
    timing.estimator_ms.push_back(f.estimator_ms);
    timing.total_ms.push_back(f.frontend_ms + f.estimator_ms);
  }
  const ProcessUsage usage = processUsage();
  timing.cpu_s = usage.cpu_s - usage_at_start.cpu_s;
  timing.peak_rss_mb = usage.peak_rss_mb;
  timing.sequence_s = toSeconds(data.images.back().t_ns - data.images.front().t_ns) +
                      1.0 / std::max(1.0, setup.camera_rate_hz);
  for (const auto& p : trajectory)
    if (!allFinite(p.T_W_B))
      fail("internal error: the estimator produced a non-finite pose at t = {} ns", p.t_ns);

  estimator::EstimatorStats stats = est->stats();
  stats.notes.insert(stats.notes.begin(), setup_notes.begin(), setup_notes.end());
  nlohmann::json metrics = computeRunMetrics(trajectory, groundtruth, stats, timing);
  metrics["skipped"] = skipped.toJson();
  metrics["timing"]["threads"] = args.threads;
  // The rig's (the image stamps were moved by it), plus what the window estimated on top.
  metrics["time_offset_s"] = time_offset_s + stats.time_offset_s.value_or(0.0);
  metrics["time_offset_rig_s"] = time_offset_s;
  metrics["time_offset_estimated"] = stats.time_offset_s.has_value();
  if (stats.camera_height_offset_m)
    metrics["camera_height_offset_m"] = *stats.camera_height_offset_m;
  if (!stats.camera_height_path_m.empty()) {
    std::vector<double> h = stats.camera_height_path_m;
    std::sort(h.begin(), h.end());
    metrics["camera_height_path_m"] = {{"min", h.front()},
                                       {"median", h[h.size() / 2]},
                                       {"max", h.back()},
                                       {"keyframes", h.size()}};
    if (stats.camera_height_path_sigma_m)
      metrics["camera_height_path_m"]["sigma"] = *stats.camera_height_path_sigma_m;
  }
  if (args.realtime) {
    metrics["realtime_rate"] = args.rate;
    metrics["timing"]["replay_lag_ms_max"] = replay_lag_ms_max;
  }

  if (out) {
    const std::filesystem::path& tmp = out->staging();
    io::writeTum(tmp / "trajectory.txt", trajectory);
    // Each frame's pose as it went out (what a live robot had then; trajectory.txt is the final
    // estimate, which the window and --refine move after the frame).
    Trajectory online;
    online.reserve(frames.size());
    for (const auto& f : frames) online.push_back({f.t_ns, f.T_W_B});
    io::writeTum(tmp / "trajectory_online.txt", online);
    io::writeTum(tmp / "keyframes.txt", est->keyframes());
    const auto bias_history = est->biasHistory();
    if (!bias_history.empty()) io::writeGyroBiasCsv(tmp / "gyro_bias.csv", bias_history);
    writeText(tmp / "metrics.json", metrics.dump(2) + "\n");
    writeText(tmp / "config.yaml", config.dump() + "\n");
    ReportInputs report;
    report.estimator = est->name();
    report.dataset = args.dataset;
    report.mode = args.realtime ? fmt::format("realtime replay at {}x", args.rate)
                  : serial      ? "offline, stages in sequence"
                                : "offline, two-stage pipeline";
    report.estimate = trajectory;
    report.groundtruth = groundtruth;
    report.bias_estimate = bias_history;
    report.bias_truth = data.true_gyro_bias;
    for (std::size_t i = 0; i < frames.size(); ++i)
      report.timing.push_back({frames[i].t_ns, frames[i].frontend_ms, frames[i].estimator_ms,
                               i < timing.latency_ms.size() ? timing.latency_ms[i] : -1.0,
                               frames[i].is_keyframe});
    report.resources = timing.resources;
    report.metrics = metrics;
    report.config_yaml = config.dump();
    writeReport(tmp / "report.html", report);
    out->commit();
    spdlog::info("wrote {}", out->target().string());
  }
  if (args.json)
    std::cout << metrics.dump(2) << std::endl;
  else if (!args.quiet)
    std::cout << runSummary(metrics, est->name(), args.dataset,
                            out ? out->target() : std::filesystem::path())
              << std::flush;
  return 0;
}

CommandRunner setupRun(CLI::App& sub) {
  auto args = std::make_shared<RunArgs>();
  sub.add_option("--dataset", args->dataset,
                 "Dataset folder (ovo/EuRoC layout or KITTI odometry) or a bag (ROS 1 .bag, "
                 "rosbag2 .db3 or folder, .mcap)")
      ->required();
  sub.add_option("--rig", args->rig,
                 "Bags: the rig file (default: rig.yaml beside the bag); its camera.calibration "
                 "names the camera calibration (default: calib_results.txt or sensor.yaml beside "
                 "it or in cam0/)");
  sub.add_option("--topics", args->topics,
                 "Bags: camera=NAME,imu=NAME,lidar=NAME (default: the one topic of each type; "
                 "none leaves a sensor out)");
  sub.add_option("--config", args->config, "Estimator configuration (YAML)");
  sub.add_option("--estimator", args->estimator, "window (default), kf or vo")
      ->check(CLI::IsMember({"window", "kf", "vo"}));
  sub.add_option(
      "--out", args->out,
      "Output folder (trajectory.txt, keyframes.txt, gyro_bias.csv, metrics.json, config.yaml, "
      "report.html): new, empty, or an earlier run's output, which it replaces");
  sub.add_option(
      "--gt", args->gt,
      "Ground truth trajectory (TUM, KITTI with or without time, EuRoC csv); on a KITTI folder "
      "KITTI poses are camera poses, as the folder's own");
  sub.add_option("--set", args->sets, "Override a configuration key: key.path=value (repeatable)");
  sub.add_flag("--quiet", args->quiet, "Do not print the summary");
  sub.add_flag("--json", args->json, "Print metrics.json instead of the summary");
  sub.add_option("--refine", args->refine,
                 "full: re-optimise all keyframes at the end (offline accuracy; window only)")
      ->check(CLI::IsMember({"none", "full"}));
  CLI::Option* serial = sub.add_flag(
      "--serial", args->serial,
      "Offline: frontend and estimator in sequence on one thread (the same poses as the "
      "default two-stage pipeline, slower)");
  CLI::Option* realtime =
      sub.add_flag("--realtime", args->realtime,
                   "Replay at sensor rate through the threaded online pipeline (drops frames "
                   "when behind; metrics gain latency_ms_median/_p99 and frames_dropped)")
          ->excludes(serial);
  sub.add_option("--threads", args->threads,
                 "At most this many threads (TBB, OpenCV, PoCL's OpenCL CPU device); 1 also runs "
                 "the offline stages in sequence, as --serial: a small robot computer's one "
                 "core. 0: every core")
      ->check(CLI::Range(0, 1024))
      ->capture_default_str();
  sub.add_option("--budget", args->budget,
                 "Compute preset: full (the configuration as given) or low (a small robot "
                 "computer: half-resolution frontend, 2 solver iterations; the README gives its "
                 "cost in accuracy); keys set by --config or --set win")
      ->check(CLI::IsMember(budgetNames()))
      ->capture_default_str();
  sub.add_option("--rate", args->rate, "Replay speed factor for --realtime (2 = twice as fast)")
      ->check(CLI::Range(kMinReplayRate, kMaxReplayRate))
      ->needs(realtime)
      ->capture_default_str();
  sub.add_option("--queue-depth", args->queue_depth,
                 "Camera frames that may wait for the frontend in --realtime (oldest dropped)")
      ->check(CLI::Range(1, 1000))
      ->needs(realtime)
      ->capture_default_str();
  sub.add_flag("--strict", args->strict,
               "A bad record in a stream (an image that does not decode, a gyro or LiDAR row that "
               "does not parse, a stamp out of order) is an error naming the file and line; by "
               "default it is skipped, warned about once per kind and counted in metrics.json's "
               "skipped");
  sub.add_flag("--viewer", args->viewer,
               "Live window: image with tracks and LiDAR points, top view (needs a display)");
  sub.add_option("--viewer-snapshot", args->viewer_snapshot,
                 "Write the viewer's final canvas to this PNG (no display needed)");
  return [args] { return runRun(*args); };
}

}  // namespace

OVO_REGISTER_COMMAND(run, "Run an estimator over a dataset", setupRun);

}  // namespace ovo::app
