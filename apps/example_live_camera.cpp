// ovo_live_camera: the live API (apps/online_pipeline.hpp) run from a camera or a video file and a
// gyro stream in csv on standard input (`t_ns,wx,wy,wz[,ax,ay,az]`, rad/s, body frame), printing
// one pose per processed frame on standard output (TUM: t[s] tx ty tz qx qy qz qw, T_W_B).
//
// Time: a camera device's frames are stamped with the system clock (ns since the epoch), so the
// gyro lines must use the same clock; a video file's frames get t0 + index / fps (--t0-ns, --fps)
// and are replayed at --rate times their frame rate. Ends at the end of the file, at Ctrl-C, or
// (for a device) when standard input reaches its end.
//
//   some_gyro_source | ovo_live_camera --camera 0 --calib calib_results.txt --estimator vo
//   ovo_live_camera --camera run.avi --calib sensor.yaml --no-gyro < /dev/null
#include <fmt/format.h>
#include <poll.h>
#include <pthread.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <iostream>
#include <opencv2/videoio.hpp>
#include <sstream>
#include <thread>

#include "apps/offline_runner.hpp"
#include "apps/online_pipeline.hpp"
#include "apps/run_budget.hpp"
#include "apps/run_metrics.hpp"
#include "apps/viewer.hpp"
#include "camera/calib_io.hpp"
#include "common/error.hpp"
#include "io/dataset.hpp"

namespace {

std::atomic<bool> g_stop{false};

// Ctrl-C and SIGTERM end the run with its summary. Both signals are blocked in every thread from
// the start of main (threads inherit the mask, the OpenCL runtime's too) and taken by one watcher
// thread, so no handler is ever involved: PoCL's LLVM installs a one-shot (SA_RESETHAND) SIGINT
// handler in front of any of ours, and a second SIGINT arriving before it re-installs ours (as
// `timeout -s INT` sends one to the process and one to its group) killed the run with status 130.
class StopSignals {
 public:
  StopSignals() {
    sigemptyset(&set_);
    sigaddset(&set_, SIGINT);
    sigaddset(&set_, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &set_, nullptr);
    watcher_ = std::thread([this] {
      const timespec tick{0, 100'000'000};
      while (!done_) {
        if (sigtimedwait(&set_, nullptr, &tick) > 0) g_stop = true;  // further signals: same
      }
    });
  }
  ~StopSignals() {
    done_ = true;
    watcher_.join();
  }
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;

 private:
  sigset_t set_{};
  std::atomic<bool> done_{false};
  std::thread watcher_;
};

struct Args {
  std::string camera = "0";
  std::string calib, rig, config, estimator = "vo", budget = "full";
  std::vector<std::string> sets;
  double fps = 0.0, rate = 1.0;
  long long t0_ns = 0;
  int queue_depth = 2;
  bool no_gyro = false, viewer = false;
};

bool isDeviceIndex(const std::string& s) {
  return !s.empty() && s.size() < 4 && s.find_first_not_of("0123456789") == std::string::npos;
}

// One csv line `t_ns,wx,wy,wz[,ax,ay,az]`; nullopt when malformed.
std::optional<ovo::ImuSample> parseGyroLine(const std::string& line) {
  std::stringstream ss(line);
  std::string field;
  std::vector<double> v;
  long long t_ns = 0;
  for (int i = 0; std::getline(ss, field, ','); ++i) {
    try {
      std::size_t used = 0;
      if (i == 0) {
        t_ns = std::stoll(field, &used);
      } else {
        v.push_back(std::stod(field, &used));
      }
      if (field.find_first_not_of(" \t\r", used) != std::string::npos) return std::nullopt;
    } catch (const std::exception&) {
      return std::nullopt;
    }
  }
  if (v.size() != 3 && v.size() != 6) return std::nullopt;
  ovo::ImuSample s;
  s.t_ns = t_ns;
  s.gyro_radps = ovo::Vec3(v[0], v[1], v[2]);
  if (v.size() == 6) s.accel_mps2 = ovo::Vec3(v[3], v[4], v[5]);
  if (!s.gyro_radps.allFinite()) return std::nullopt;
  return s;
}

// A gyro line is under 200 characters; a longer one is garbage (and, unbounded, made the search
// for its end rescan the buffer with every chunk: a 64 MB line stalled the reader).
constexpr std::size_t kMaxGyroLine = 4096;

// Reads gyro lines from stdin until EOF or stop (poll, so Ctrl-C is never stuck in a read);
// counts the lines skipped in *skipped.
void readGyro(ovo::app::OnlinePipeline& pipeline, std::atomic<bool>& eof,
              std::atomic<long>& skipped) {
  std::string buffer;
  long line_no = 0;
  bool skipping_long_line = false;
  char chunk[4096];
  while (!g_stop) {
    pollfd pfd{STDIN_FILENO, POLLIN, 0};
    const int ready = poll(&pfd, 1, 100);
    if (ready < 0 && errno != EINTR) break;
    if (ready <= 0) continue;
    const ssize_t n = read(STDIN_FILENO, chunk, sizeof(chunk));
    if (n <= 0) break;  // EOF (or a closed pipe)
    buffer.append(chunk, static_cast<std::size_t>(n));
    std::size_t start = 0, end;
    while ((end = buffer.find('\n', start)) != std::string::npos) {
      const std::string line = buffer.substr(start, end - start);
      start = end + 1;
      ++line_no;
      if (skipping_long_line) {  // the end of a line already reported as too long
        skipping_long_line = false;
        continue;
      }
      if (line.empty() || line[0] == '#' || line == "\r") continue;
      const auto s = parseGyroLine(line);
      if (!s) {
        ++skipped;
        spdlog::warn("stdin:{}: expected t_ns,wx,wy,wz[,ax,ay,az]: line skipped", line_no);
      } else if (!pipeline.addGyro(*s) && !g_stop) {
        ++skipped;
        spdlog::warn("stdin:{}: gyro time stamp {} is not after the previous one: line skipped",
                     line_no, s->t_ns);
      }
    }
    buffer.erase(0, start);
    if (buffer.size() > kMaxGyroLine) {
      if (!skipping_long_line) {
        ++skipped;
        spdlog::warn("stdin:{}: a line longer than {} characters: skipped", line_no + 1,
                     kMaxGyroLine);
      }
      skipping_long_line = true;
      buffer.clear();
    }
  }
  eof = true;
}

int run(const Args& args) {
  using namespace ovo;
  cv::VideoCapture capture;
  const bool device = isDeviceIndex(args.camera);
  // A device index is a video device (/dev/videoN on Linux): open it through V4L2 directly.
  // CAP_ANY would first probe every backend, gphoto2's USB scan of still cameras among them (a
  // second of start-up, and memory that library never frees).
#ifdef __linux__
  constexpr int kDeviceApi = cv::CAP_V4L2;
#else
  constexpr int kDeviceApi = cv::CAP_ANY;
#endif
  if (device)
    capture.open(std::stoi(args.camera), kDeviceApi);
  else
    capture.open(args.camera);
  if (!capture.isOpened() && device)
    fail(
        "cannot open camera {}: no such device, or it is busy or not readable (check "
        "/dev/video*, permissions, or pass a video file to --camera)",
        args.camera);
  if (!capture.isOpened())
    fail("cannot open the video file '{}' (missing or not a format OpenCV can read)", args.camera);

  estimator::SensorSetup setup{.camera = camera::loadCamera(args.calib)};
  const auto T_B_C_calib = camera::readSensorYamlExtrinsics(args.calib);
  if (!args.rig.empty()) {
    const io::RigInfo rig = io::readRigYaml(args.rig);
    setup = app::sensorSetupFromRig(rig, setup.camera,
                                    io::cameraExtrinsics(rig, T_B_C_calib, args.rig));
  } else if (T_B_C_calib) {
    setup.T_B_C = *T_B_C_calib;
  }
  // The rig's camera-gyro time offset: the images go to the estimator at their time on the gyro
  // clock (stamp - offset), the poses come out at their stamps.
  const Timestamp image_shift_ns = fromSeconds(setup.time_offset_s);
  const double fps = args.fps > 0 ? args.fps : capture.get(cv::CAP_PROP_FPS);
  if (fps > 0) setup.camera_rate_hz = fps;
  setup.has_gyro = !args.no_gyro;
  for (const std::string& note : estimator::applyNoiseFloors(setup)) spdlog::info("{}", note);

  Config config;
  if (!args.config.empty()) config = Config::load(args.config);
  config.applyOverrides(args.sets);
  app::applyBudget(config, args.budget, args.estimator);
  app::applyOnlineSolveBudget(config, args.estimator);
  auto est = estimator::makeEstimator(args.estimator, setup, config);
  est->keepHistory(false);  // the poses go out as they come: memory stays flat for hours
  config.checkAllUsed();

  std::unique_ptr<app::Viewer> viewer;
  if (args.viewer) {
    app::Viewer::checkDisplay();
    viewer = std::make_unique<app::Viewer>(setup, est->name());
  }
  app::OnlineOptions options;
  options.image_queue_depth = args.queue_depth;
  options.latency_history = app::kLongRunLatencyHistory;  // a day on the robot
  app::OnlinePipeline pipeline(*est, options, [&](const app::OnlineOutput& out) {
    const SE3& T = out.estimate.T_W_B;
    const Quat q(T.linear());
    std::printf("%.9f %.6f %.6f %.6f %.9f %.9f %.9f %.9f\n",
                toSeconds(out.estimate.t_ns + image_shift_ns), T.translation().x(),
                T.translation().y(), T.translation().z(), q.x(), q.y(), q.z(), q.w());
    std::fflush(stdout);
    if (viewer) viewer->addFrame(out.estimate, out.grey, {out.frames_dropped, out.latency_ms});
  });

  std::atomic<bool> gyro_eof{args.no_gyro};
  std::atomic<long> gyro_skipped{0};
  std::thread gyro_thread;
  if (!args.no_gyro) gyro_thread = std::thread([&] { readGyro(pipeline, gyro_eof, gyro_skipped); });
  pipeline.start();

  auto capture_loop = [&] {
    const double frame_rate = fps > 0 ? fps : 20.0;
    const auto start = std::chrono::steady_clock::now();
    cv::Mat frame;
    for (long index = 0; !g_stop; ++index) {
      if (device && gyro_eof && !args.no_gyro) break;  // the gyro stream ended
      if (!capture.read(frame) || frame.empty()) {
        if (device) spdlog::error("camera {} stopped delivering frames", args.camera);
        break;
      }
      if (index == 0 &&
          (frame.cols != camera::width(setup.camera) || frame.rows != camera::height(setup.camera)))
        fail("the images are {}x{} but the calibration '{}' is for {}x{}", frame.cols, frame.rows,
             args.calib, camera::width(setup.camera), camera::height(setup.camera));
      Timestamp t_ns;
      if (device) {
        t_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                   std::chrono::system_clock::now().time_since_epoch())
                   .count();
      } else {
        const double t_rel_s = static_cast<double>(index) / frame_rate;
        t_ns = args.t0_ns + fromSeconds(t_rel_s);
        std::this_thread::sleep_until(start +
                                      std::chrono::duration_cast<std::chrono::nanoseconds>(
                                          std::chrono::duration<double>(t_rel_s / args.rate)));
      }
      pipeline.addImage(t_ns - image_shift_ns, frame);
    }
  };
  try {
    if (viewer)
      app::runWithViewer(*viewer, capture_loop);
    else
      capture_loop();
  } catch (...) {
    g_stop = true;
    if (gyro_thread.joinable()) gyro_thread.join();
    throw;
  }
  g_stop = true;
  if (gyro_thread.joinable()) gyro_thread.join();
  pipeline.stop();
  const app::OnlineStats stats = pipeline.stats();
  spdlog::info(
      "ovo_live_camera: {} frames in, {} processed, {} dropped; latency median {:.1f} ms, p99 "
      "{:.1f} ms; {} gyro samples",
      stats.frames_in, stats.frames_processed, stats.frames_dropped, stats.latencyMedianMs(),
      stats.latencyP99Ms(), stats.gyro_in);
  // Without a single gyro sample the run was vision-only: not what was asked for.
  if (!args.no_gyro && stats.gyro_in == 0)
    fail(
        "no gyro sample came on standard input ({} lines skipped): expected lines "
        "t_ns,wx,wy,wz[,ax,ay,az] (rad/s); pass --no-gyro to run on the camera alone",
        gyro_skipped.load());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const StopSignals stop_signals;  // from the start: Ctrl-C during start-up ends cleanly too
  CLI::App app{
      "ovo_live_camera: live odometry from a camera (or video file) and a gyro csv stream"};
  Args args;
  app.add_option("--camera", args.camera, "Camera index (0, 1, ...) or a video file")
      ->capture_default_str();
  app.add_option("--calib", args.calib, "Camera calibration (calib_results.txt or sensor.yaml)")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--rig", args.rig, "rig.yaml (extrinsics, noise figures, camera height)");
  app.add_option("--estimator", args.estimator, "vo (default), kf or window")
      ->check(CLI::IsMember({"window", "kf", "vo"}));
  app.add_option("--config", args.config, "Estimator configuration (YAML)");
  app.add_option("--set", args.sets, "Override a configuration key: key.path=value");
  app.add_option("--budget", args.budget,
                 "Compute preset, as ovo run's: full or low (half-resolution frontend, 2 solver "
                 "iterations); keys set by --config or --set win")
      ->check(CLI::IsMember(ovo::app::budgetNames()))
      ->capture_default_str();
  // Bounded: a rate or fps of 1e-6 slept for days between frames (past Ctrl-C), inf or 1e300
  // gave every frame one stamp, and a t0 near 2^63 overflowed.
  app.add_option("--fps", args.fps, "Frame rate of a video file (default: from the file)")
      ->check(CLI::Range(0.1, 1000.0));
  app.add_option("--rate", args.rate, "Replay speed of a video file")
      ->check(CLI::Range(ovo::app::kMinReplayRate, ovo::app::kMaxReplayRate))
      ->capture_default_str();
  app.add_option("--t0-ns", args.t0_ns, "Time of a video file's first frame [ns]")
      ->check(CLI::Range(0LL, 4'000'000'000'000'000'000LL));
  app.add_option("--queue-depth", args.queue_depth, "Frames waiting for the estimator")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  app.add_flag("--no-gyro", args.no_gyro, "Do not read gyro samples from standard input");
  app.add_flag("--viewer", args.viewer, "Show the live viewer window (needs a display)");
  CLI11_PARSE(app, argc, argv);
  // Standard output carries the TUM pose stream only: messages go to standard error.
  spdlog::set_default_logger(spdlog::stderr_color_mt("ovo_live_camera"));
  spdlog::set_pattern("[%^%l%$] %v");
  try {
    return run(args);
  } catch (const ovo::Error& e) {
    std::cerr << "ovo_live_camera: error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "ovo_live_camera: internal error: " << e.what() << "\n";
    return 3;
  }
}
