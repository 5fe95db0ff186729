// `ovo simulate`: renders a synthetic vineyard sequence (fisheye or pinhole images, gyro and
// accelerometer, planar LiDAR, exact ground truth) from a scenario file into a dataset folder
// (DESIGN.md sections 8 and 10), or with --format rosbag|db3|mcap into a bag beside the folder's
// rig.yaml, calibration and ground truth. Same scenario and seed: the same bytes. The LiDAR's
// values are rounded to float32 in every format (a LaserScan's type), so a folder and a bag of the
// same run hold the same numbers and give the same trajectory.
#include <spdlog/spdlog.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <chrono>
#include <optional>

#include "apps/command.hpp"
#include "common/config.hpp"
#include "common/error.hpp"
#include "io/dataset_writer.hpp"
#include "io/ros_messages.hpp"
#include "sim/board_scene.hpp"
#include "sim/scenario.hpp"
#include "sim/simulation.hpp"
#include "sim/truth_files.hpp"

namespace ovo::app {

// The checkerboard scene (apps/cmd_simulate_board.cpp).
int runBoardSimulation(const Config& config, const std::string& out, bool overwrite);

namespace {

struct SimulateArgs {
  std::string config = "configs/sim/vineyard_row.yaml";
  std::string out;
  std::optional<std::int64_t> seed;
  std::optional<int> frames;
  std::optional<double> duration_s;
  std::vector<std::string> sets;
  std::string format = "folder";
  bool overwrite = false;
};

int runSimulate(const SimulateArgs& args) {
  const auto start = std::chrono::steady_clock::now();
  Config config = Config::load(args.config);
  config.applyOverrides(args.sets);
  if (args.seed) config.applyOverride(fmt::format("seed={}", *args.seed));
  if (args.frames) config.applyOverride(fmt::format("frames={}", *args.frames));
  if (args.duration_s) config.applyOverride(fmt::format("duration_s={}", *args.duration_s));
  if (sim::isBoardScene(config)) return runBoardSimulation(config, args.out, args.overwrite);
  const sim::Scenario scenario = sim::readScenario(config);
  const sim::Simulation simulation(scenario);
  const std::optional<io::BagFormat> bag_format =
      args.format == "folder" ? std::nullopt : std::optional(io::parseBagFormat(args.format));
  io::DatasetWriter writer(args.out, args.overwrite, bag_format);
  const int frames = simulation.frameCount();
  spdlog::info("simulate: scenario '{}', seed {}, {} frames ({:.1f} s) of {}x{} ({}), writing {}",
               scenario.name, scenario.seed, frames, simulation.duration(),
               simulation.renderer().width(), simulation.renderer().height(),
               camera::modelName(simulation.camera()), args.out);

  // Frames in parallel (each also renders its rows in parallel); every random draw depends only
  // on the frame index, so the order does not change the bytes.
  std::atomic<int> done{0};
  if (!bag_format) {
    tbb::parallel_for(0, frames, [&](int k) {
      if (!simulation.frameDropped(k))
        writer.writeImage(simulation.frameStamp(k), simulation.renderFrame(k));
      const int n = ++done;
      if (n % std::max(1, frames / 10) == 0) spdlog::info("simulate: {}/{} frames", n, frames);
    });
  } else {
    // A bag's messages go in time order: frames rendered in parallel a batch at a time.
    constexpr int kBatch = 16;
    std::vector<cv::Mat> batch(kBatch);
    for (int first = 0; first < frames; first += kBatch) {
      const int n = std::min(kBatch, frames - first);
      tbb::parallel_for(0, n, [&](int i) {
        if (!simulation.frameDropped(first + i)) batch[i] = simulation.renderFrame(first + i);
      });
      for (int i = 0; i < n; ++i) {
        if (!simulation.frameDropped(first + i))
          writer.writeImage(simulation.frameStamp(first + i), batch[i]);
        if (++done % std::max(1, frames / 10) == 0)
          spdlog::info("simulate: {}/{} frames", done.load(), frames);
      }
    }
  }
  const auto rendered = std::chrono::steady_clock::now();

  std::vector<sim::GyroBiasSample> bias;
  writer.writeImu(simulation.imu(&bias));
  std::vector<std::pair<Timestamp, Vec3>> bias_pairs;
  bias_pairs.reserve(bias.size());
  for (const auto& b : bias) bias_pairs.emplace_back(b.t_ns, b.bias_radps);
  writer.writeTrueGyroBias(bias_pairs);
  std::vector<LidarScan> scans = simulation.lidar();
  for (LidarScan& scan : scans) io::ros::roundToLaserScan(scan);
  writer.writeLidar(scans);
  writer.writeGroundTruth(simulation.groundTruth());
  writer.writeCamera(simulation.camera(), simulation.T_B_C(), scenario.camera.rate_hz);

  io::RigInfo rig;
  rig.has_rig_file = true;
  rig.T_B_C = simulation.T_B_C();
  rig.T_B_L = simulation.T_B_L();
  rig.camera_rate_hz = scenario.camera.rate_hz;
  rig.pixel_sigma = scenario.camera.pixel_sigma;
  rig.camera_height_m = simulation.cameraHeightM();
  // The estimator's starting value of the time offset (not the truth) and the readout time (a
  // data-sheet value the user knows).
  rig.camera_time_offset_s = scenario.rig.camera_time_offset_s;
  rig.camera_rolling_shutter_s = scenario.camera.rolling_shutter_s;
  rig.gyro_rate_hz = scenario.imu.rate_hz;
  rig.gyro_noise_density = scenario.imu.noise ? scenario.imu.gyro_noise_density : 0.0;
  rig.gyro_bias_random_walk = scenario.imu.noise ? scenario.imu.gyro_bias_random_walk : 0.0;
  rig.lidar_rate_hz = scenario.lidar.rate_hz;
  rig.lidar_range_sigma_m = scenario.lidar.noise ? scenario.lidar.range_sigma_m : 0.0;
  writer.writeRig(rig);
  writer.writeText("sim/scenario.yaml", sim::scenarioYaml(scenario));
  if (sim::hasTimingRealities(scenario)) {
    writer.writeText("sim/truth_timing.yaml", sim::truthTimingYaml(simulation));
    writer.writeText("sim/truth_frames.csv", sim::truthFramesCsv(simulation));
  }
  writer.commit();

  const auto end = std::chrono::steady_clock::now();
  const double render_s = std::chrono::duration<double>(rendered - start).count();
  const double total_s = std::chrono::duration<double>(end - start).count();
  int dropped = 0;
  for (int k = 0; k < frames; ++k) dropped += simulation.frameDropped(k) ? 1 : 0;
  if (dropped > 0)
    spdlog::info("simulate: {} of {} frames dropped (camera.frame_drop_probability {})", dropped,
                 frames, scenario.camera.frame_drop_probability);
  spdlog::info("simulate: wrote {} frames to {} in {:.1f} s ({:.1f} frames/s rendering)",
               frames - dropped, args.out, total_s, frames / std::max(render_s, 1e-9));
  return 0;
}

CommandRunner setupSimulate(CLI::App& sub) {
  auto args = std::make_shared<SimulateArgs>();
  sub.add_option("--config", args->config, "Scenario YAML (configs/sim/*.yaml)")
      ->capture_default_str();
  sub.add_option("--out", args->out, "Dataset folder to create")->required();
  sub.add_option("--seed", args->seed,
                 "Seed (texture, noise, trajectory jitter); overrides the scenario's")
      ->check(CLI::Range(std::int64_t{0}, std::int64_t{INT64_MAX - 1}));  // 2^63 and up: clamped
  sub.add_option("--frames", args->frames, "Number of camera frames (short sequences)");
  sub.add_option("--duration", args->duration_s, "Length in seconds (ignored with --frames)");
  sub.add_option("--set", args->sets, "Override a scenario key: key.path=value (repeatable)");
  sub.add_option("--format", args->format,
                 "folder (EuRoC layout), or the images, gyro and scans in a bag beside rig.yaml: "
                 "rosbag (ROS 1 run.bag), db3 (rosbag2 sqlite3 folder run/), mcap (run.mcap)")
      ->check(CLI::IsMember({"folder", "rosbag", "db3", "mcap"}))
      ->capture_default_str();
  sub.add_flag("--overwrite", args->overwrite, "Replace --out if it exists");
  return [args] {
    if (args->seed && *args->seed < 0)
      fail("--seed: expected a non-negative integer, got {}", *args->seed);
    if (args->frames && *args->frames <= 0)
      fail("--frames: expected a positive count, got {}", *args->frames);
    if (args->duration_s && !(*args->duration_s > 0.0))
      fail("--duration: expected a positive number of seconds, got {}", *args->duration_s);
    return runSimulate(*args);
  };
}

}  // namespace

OVO_REGISTER_COMMAND(
    simulate, "Render a synthetic vineyard sequence (fisheye/pinhole, gyro, LiDAR, ground truth)",
    setupSimulate);

}  // namespace ovo::app
