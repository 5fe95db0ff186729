// ovo_soak: a long run of the online pipeline (apps/online_pipeline.hpp) for a robot's working
// day. A recorded or simulated sequence is fed again and again with continuing stamps: by default
// forwards, then backwards in time (ping-pong: the robot drives the path back, so the trajectory
// stays continuous; the gyro is time-reversed about its true bias when the dataset has
// sim/truth_bias.csv), or always forwards (--mode restart: the images jump back to the start at
// every pass). It paces the feed at --rate times real time (0: as fast as the pipeline takes
// frames without dropping one) and writes, every --sample-s seconds of driving, a CSV row with
// the resident memory, the heap in use and the per-frame time, and at the end an SVG plot of both.
//
//   ovo_soak --dataset out/soak/data --hours 8 --rate 0 --out out/soak
#include <malloc.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <fstream>
#include <mutex>
#include <thread>

#include "apps/offline_runner.hpp"
#include "apps/online_pipeline.hpp"
#include "apps/run_budget.hpp"
#include "apps/run_metrics.hpp"
#include "apps/svg_plot.hpp"
#include "common/error.hpp"
#include "io/dataset.hpp"

namespace ovo::app {
namespace {

using Clock = std::chrono::steady_clock;

struct SoakArgs {
  std::string dataset;
  std::string out = "soak";
  std::string estimator = "window";
  std::string mode = "pingpong";
  std::string budget = "full";  // compute preset (apps/run_budget.hpp)
  double hours = 1.0;           // of driving (sensor time)
  double rate = 0.0;            // replay speed; 0: as fast as frames are taken without dropping
  double sample_s = 60.0;       // driving seconds per CSV row
  bool keep_history = false;    // the estimator keeps every frame's pose (ovo run's trajectory)
  std::vector<std::string> sets;
};

double residentMb() {
  std::ifstream statm("/proc/self/statm");
  long size = 0, resident = 0;
  statm >> size >> resident;
  return static_cast<double>(resident) * static_cast<double>(::sysconf(_SC_PAGESIZE)) / 1048576.0;
}

// malloc's own figures (every arena): the bytes in use (small chunks and mmapped blocks), and
// the bytes malloc holds free (within its arenas; resident only where touched and not trimmed).
struct MallocFigures {
  double in_use_mb, free_mb;
};
MallocFigures mallocFigures() {
  const struct mallinfo2 m = mallinfo2();
  return {static_cast<double>(m.uordblks + m.hblkhd) / 1048576.0,
          static_cast<double>(m.fordblks) / 1048576.0};
}

// One measurement of the fed stream, at its time within a pass.
struct Event {
  enum Kind { kGyro = 0, kScan = 1, kImage = 2 } kind;  // order at equal times
  std::size_t index;
  Timestamp t_ns;  // since the pass's start
};

// The events of one pass in time order: forwards, or backwards (stamps mirrored in the span);
// a pass lasts from its first frame to one frame interval (dt) after its last.
std::vector<Event> passEvents(const io::Dataset& d, bool backwards, Timestamp t0, Timestamp t1,
                              Timestamp dt) {
  std::vector<Event> ev;
  auto at = [&](Timestamp t) { return backwards ? t1 - t : t - t0; };
  auto inPass = [&](Timestamp t) {
    return backwards ? t > t0 - dt && t <= t1 : t >= t0 && t < t1 + dt;
  };
  for (std::size_t i = 0; i < d.imu.size(); ++i)
    if (inPass(d.imu[i].t_ns)) ev.push_back({Event::kGyro, i, at(d.imu[i].t_ns)});
  for (std::size_t i = 0; i < d.scans.size(); ++i)
    if (inPass(d.scans[i].t_ns)) ev.push_back({Event::kScan, i, at(d.scans[i].t_ns)});
  for (std::size_t i = 0; i < d.images.size(); ++i)
    ev.push_back({Event::kImage, i, at(d.images[i].t_ns)});
  std::stable_sort(ev.begin(), ev.end(), [](const Event& a, const Event& b) {
    return a.t_ns != b.t_ns ? a.t_ns < b.t_ns : a.kind < b.kind;
  });
  return ev;
}

// The true gyro bias at t (linear between the simulator's samples; zero without them).
Vec3 trueBias(const io::Dataset& d, Timestamp t) {
  const auto& b = d.true_gyro_bias;
  if (b.empty()) return Vec3::Zero();
  auto it = std::lower_bound(b.begin(), b.end(), t,
                             [](const auto& s, Timestamp x) { return s.first < x; });
  if (it == b.begin()) return b.front().second;
  if (it == b.end()) return b.back().second;
  const auto& [ta, va] = *std::prev(it);
  const auto& [tb, vb] = *it;
  const double f = static_cast<double>(t - ta) / static_cast<double>(tb - ta);
  return va + f * (vb - va);
}

struct FrameSample {
  double total_ms, latency_ms;
  bool finite;
};

int runSoak(const SoakArgs& args) {
  if (!(args.hours > 0)) fail("--hours: expected > 0, got {}", args.hours);
  Config config;
  config.applyOverrides(args.sets);
  applyBudget(config, args.budget, args.estimator);
  io::Dataset data = io::loadDataset(args.dataset);
  if (data.images.size() < 2) fail("{}: the soak needs a sequence of images", args.dataset);
  if (auto note = imagesOntoGyroClock(data)) spdlog::info("{}", *note);
  estimator::SensorSetup setup = sensorSetupFrom(data);
  for (const auto& note : estimator::applyNoiseFloors(setup)) spdlog::info("{}", note);
  if (estimator::estimatorUsesLidar(args.estimator, config))
    if (auto note = cameraHeightFromScans(data, &setup)) spdlog::info("{}", *note);
  auto est = estimator::makeEstimator(args.estimator, setup, config);
  // A robot's day streams its poses: the estimator keeps only what it may still change.
  est->keepHistory(args.keep_history);
  config.checkAllUsed();

  const Timestamp t0 = data.images.front().t_ns, t1 = data.images.back().t_ns;
  const Timestamp frame_dt = (t1 - t0) / static_cast<Timestamp>(data.images.size() - 1);
  const Timestamp pass_ns = t1 - t0 + frame_dt;  // the next pass starts one frame later
  const bool pingpong = args.mode == "pingpong";
  const std::vector<Event> forwards = passEvents(data, false, t0, t1, frame_dt);
  const std::vector<Event> backwards =
      pingpong ? passEvents(data, true, t0, t1, frame_dt) : forwards;
  const auto total_ns = static_cast<Timestamp>(args.hours * 3600.0 * kNsPerSec);
  const Timestamp base_ns = 1'000'000'000'000'000'000;  // stamps from 1e18 ns on: no collision

  std::mutex mutex;
  std::condition_variable processed_cv;
  std::vector<FrameSample> window;  // frames processed since the last CSV row
  long processed = 0, nonfinite = 0;
  OnlineOptions options;
  if (!args.keep_history) options.latency_history = kLongRunLatencyHistory;
  OnlinePipeline pipeline(*est, options, [&](const OnlineOutput& o) {
    const bool finite = allFinite(o.estimate.T_W_B);
    std::lock_guard lock(mutex);
    window.push_back({o.estimate.frontend_ms + o.estimate.estimator_ms, o.latency_ms, finite});
    ++processed;
    if (!finite) ++nonfinite;
    processed_cv.notify_all();
  });

  std::filesystem::create_directories(args.out);
  std::ofstream csv(std::filesystem::path(args.out) / "soak.csv");
  csv << "driving_s,wall_s,frames,rss_mb,heap_mb,malloc_free_mb,frame_ms_median,frame_ms_p90,"
         "frame_ms_max,latency_ms_median,nonfinite\n";
  std::vector<double> plot_h, plot_rss, plot_heap, plot_ms, plot_p90;
  const auto start = Clock::now();
  long fed_images = 0;
  Timestamp next_sample_ns = static_cast<Timestamp>(args.sample_s * kNsPerSec);
  auto writeSample = [&](Timestamp driving_ns) {
    std::vector<FrameSample> w;
    {
      std::lock_guard lock(mutex);
      w.swap(window);
    }
    std::vector<double> ms, lat;
    int bad = 0;
    for (const auto& f : w) {
      ms.push_back(f.total_ms);
      lat.push_back(f.latency_ms);
      bad += f.finite ? 0 : 1;
    }
    const double wall = std::chrono::duration<double>(Clock::now() - start).count();
    const double rss = residentMb();
    const MallocFigures m = mallocFigures();
    const double heap = m.in_use_mb;
    const double driving_s = toSeconds(driving_ns);
    csv << fmt::format(
        "{:.0f},{:.1f},{},{:.1f},{:.1f},{:.1f},{:.2f},{:.2f},{:.2f},{:.2f},{}\n", driving_s, wall,
        w.size(), rss, heap, m.free_mb, percentile(ms, 50), percentile(ms, 90),
        ms.empty() ? 0.0 : *std::max_element(ms.begin(), ms.end()), percentile(lat, 50), bad);
    csv.flush();
    plot_h.push_back(driving_s / 3600.0);
    plot_rss.push_back(rss);
    plot_heap.push_back(heap);
    plot_ms.push_back(percentile(ms, 50));
    plot_p90.push_back(percentile(ms, 90));
    spdlog::info(
        "soak: {:.2f} h of driving in {:.0f} s ({:.1f}x), RSS {:.0f} MB, heap {:.0f} MB, "
        "frame {:.1f} ms median",
        driving_s / 3600.0, wall, driving_s / std::max(wall, 1e-9), rss, heap, percentile(ms, 50));
  };

  pipeline.start();
  for (long pass = 0; pass * pass_ns < total_ns; ++pass) {
    const bool back = pingpong && pass % 2 == 1;
    const Timestamp pass_start = pass * pass_ns;
    for (const Event& e : back ? backwards : forwards) {
      const Timestamp driving_ns = pass_start + e.t_ns;
      if (driving_ns >= total_ns) break;
      while (driving_ns >= next_sample_ns) {
        writeSample(next_sample_ns);
        next_sample_ns += static_cast<Timestamp>(args.sample_s * kNsPerSec);
      }
      if (args.rate > 0)
        std::this_thread::sleep_until(
            start + std::chrono::duration_cast<Clock::duration>(
                        std::chrono::duration<double>(toSeconds(driving_ns) / args.rate)));
      const Timestamp t = base_ns + driving_ns;
      switch (e.kind) {
        case Event::kGyro: {
          ImuSample s = data.imu[e.index];
          s.t_ns = t;
          // Time-reversed: the rotation rate turns sign, the bias does not.
          if (back) s.gyro_radps = 2.0 * trueBias(data, data.imu[e.index].t_ns) - s.gyro_radps;
          pipeline.addGyro(s);
          break;
        }
        case Event::kScan: {
          LidarScan s = data.scans[e.index];
          s.t_ns = t;
          pipeline.addScan(s);
          break;
        }
        case Event::kImage: {
          const cv::Mat grey = io::loadDatasetImage(data, e.index);
          if (args.rate <= 0) {  // at most one frame waiting: none dropped
            std::unique_lock lock(mutex);
            processed_cv.wait(lock, [&] { return fed_images - processed < 2; });
          }
          pipeline.addImage(t, grey);
          ++fed_images;
          break;
        }
      }
    }
  }
  pipeline.stop();
  writeSample(total_ns);
  const OnlineStats stats = pipeline.stats();
  const double wall = std::chrono::duration<double>(Clock::now() - start).count();

  // First and last hour of driving (or the first and last tenth when shorter).
  const std::size_t n = plot_rss.size();
  const std::size_t span = std::max<std::size_t>(
      1, args.hours >= 2 ? static_cast<std::size_t>(3600.0 / args.sample_s) : n / 10);
  auto mean = [](const std::vector<double>& v, std::size_t a, std::size_t b) {
    double s = 0;
    for (std::size_t i = a; i < b; ++i) s += v[i];
    return b > a ? s / static_cast<double>(b - a) : 0.0;
  };
  const double rss_first = mean(plot_rss, 0, std::min(span, n));
  const double rss_last = mean(plot_rss, n - std::min(span, n), n);
  const double ms_first = mean(plot_ms, 0, std::min(span, n));
  const double ms_last = mean(plot_ms, n - std::min(span, n), n);
  spdlog::info(
      "soak done: {:.2f} h of driving in {:.0f} s ({:.2f}x real time), {} frames processed, {} "
      "dropped, {} non-finite poses; RSS first {:.1f} MB, last {:.1f} MB ({:+.1f} %); frame time "
      "median first {:.1f} ms, last {:.1f} ms",
      args.hours, wall, args.hours * 3600.0 / wall, stats.frames_processed, stats.frames_dropped,
      nonfinite, rss_first, rss_last, 100.0 * (rss_last / rss_first - 1.0), ms_first, ms_last);

  PlotOptions mem;
  mem.title = fmt::format("ovo_soak: {} on {} ({})", args.estimator,
                          std::filesystem::path(args.dataset).filename().string(), args.mode);
  mem.x_label = "driving time [h]";
  mem.y_label = "memory [MB]";
  mem.y_include_zero = true;
  PlotOptions time = mem;
  time.title = "per-frame time (frontend + estimator)";
  time.y_label = "ms";
  std::ofstream svg(std::filesystem::path(args.out) / "soak.svg");
  svg << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"640\" height=\"740\">\n"
      << svgLinePlot({{"resident (RSS)", plot_h, plot_rss, "#1f77b4"},
                      {"heap in use", plot_h, plot_heap, "#ff7f0e"}},
                     mem)
      << "\n<g transform=\"translate(0,370)\">\n"
      << svgLinePlot(
             {{"median", plot_h, plot_ms, "#2ca02c"}, {"p90", plot_h, plot_p90, "#d62728", true}},
             time)
      << "\n</g>\n</svg>\n";
  return nonfinite == 0 ? 0 : 1;
}

}  // namespace
}  // namespace ovo::app

int main(int argc, char** argv) {
  ovo::app::SoakArgs args;
  CLI::App app{"ovo_soak: the online pipeline fed a sequence again and again for hours"};
  app.add_option("--dataset", args.dataset, "Dataset folder (a simulated one has its true bias)")
      ->required();
  app.add_option("--hours", args.hours, "Hours of driving to feed")->capture_default_str();
  app.add_option("--rate", args.rate,
                 "Replay speed (x real time); 0: as fast as frames are taken without dropping")
      ->capture_default_str();
  app.add_option("--estimator", args.estimator, "window, kf or vo")->capture_default_str();
  app.add_option("--mode", args.mode, "pingpong (forwards then backwards) or restart")
      ->check(CLI::IsMember({"pingpong", "restart"}))
      ->capture_default_str();
  app.add_option("--sample-s", args.sample_s, "Driving seconds per CSV row")->capture_default_str();
  app.add_flag(
      "--keep-history", args.keep_history,
      "The estimator keeps every frame's pose, as ovo run does (memory grows with the run)");
  app.add_option("--out", args.out, "Folder for soak.csv and soak.svg")->capture_default_str();
  app.add_option("--set", args.sets, "Override a configuration key: key.path=value");
  app.add_option("--budget", args.budget, "Compute preset, as ovo run's: full or low")
      ->check(CLI::IsMember(ovo::app::budgetNames()))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  spdlog::set_pattern("[%^%l%$] %v");
  try {
    return ovo::app::runSoak(args);
  } catch (const ovo::Error& e) {
    std::fprintf(stderr, "ovo_soak: error: %s\n", e.what());
    return 2;
  }
}
