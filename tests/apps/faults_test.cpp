// Faults in the middle of a run, on a short simulated row (rendered once per test program): a run
// of corrupt or truncated images, a camera that stops for 5 s, a gyro that stops and returns with
// a jump in its clock, gyro spikes at the sensor's range, NaN / negative ranges and scans with
// every beam dropped, stamps going backwards, and the output disk full or read-only. Each gives a
// continuous trajectory without a NaN pose (or a clear error, the output folder as before).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "apps/offline_runner.hpp"
#include "apps/online_replay.hpp"
#include "common/so3.hpp"
#include "eval/metrics.hpp"
#include "io/dataset.hpp"
#include "tests/apps/online_test_data.hpp"
#include "tests/apps/simulated_row.hpp"

namespace ovo::app {
namespace {

namespace fs = std::filesystem;

#define OVO_REQUIRE_OVO() \
  if (!fs::exists(test::ovoBinaryPath())) GTEST_SKIP() << "not built: " << test::ovoBinaryPath()

// 10 s of the vineyard row (still for 0.5 s, then 0.8 m/s along the row): 200 frames, 2000 gyro
// samples, 100 scans.
fs::path simulatedRow() { return test::simulatedRow(10); }

// A copy of the simulated row in `dir` whose files can be damaged: the csv, YAML and calibration
// files copied, each image a symbolic link (replace the link to damage one).
fs::path copyOfRow(const fs::path& dir) {
  const fs::path src = simulatedRow();
  fs::create_directories(dir);
  for (const auto& e : fs::recursive_directory_iterator(src)) {
    const fs::path to = dir / fs::relative(e.path(), src);
    if (e.is_directory())
      fs::create_directories(to);
    else if (e.path().filename() == "done")
      continue;
    else if (e.path().extension() == ".png")
      fs::create_symlink(e.path(), to);
    else
      fs::copy_file(e.path(), to);
  }
  return dir;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::vector<std::string> lines(const fs::path& p) {
  std::vector<std::string> out;
  std::ifstream in(p);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

void writeLines(const fs::path& p, const std::vector<std::string>& rows) {
  std::ofstream out(p, std::ios::trunc);
  for (const auto& r : rows) out << r << "\n";
}

struct WindowRun {
  Trajectory trajectory;
  OfflineRunResult result;
  estimator::EstimatorStats stats;
};

WindowRun runEstimator(const std::string& name, const io::Dataset& data,
                       const OfflineOptions& options = {}) {
  auto est = estimator::makeEstimator(name, sensorSetupFrom(data), Config());
  WindowRun run;
  run.result = runOffline(data, *est, {}, {}, options);
  run.trajectory = est->trajectory();
  run.stats = est->stats();
  return run;
}

WindowRun runWindow(const io::Dataset& data, const OfflineOptions& options = {}) {
  return runEstimator("window", data, options);
}

// No NaN, and no step between consecutive poses beyond what the robot can do in the time between
// them (0.8 m/s and 20 deg/s, twice that, plus 5 cm and 2 deg).
void expectContinuous(const Trajectory& t) {
  ASSERT_FALSE(t.empty());
  for (std::size_t i = 0; i < t.size(); ++i) {
    ASSERT_TRUE(allFinite(t[i].T_W_B)) << "non-finite pose at frame " << i;
    if (i == 0) continue;
    const double dt = toSeconds(t[i].t_ns - t[i - 1].t_ns);
    ASSERT_GT(dt, 0.0) << "frame " << i;
    const double step_m = (t[i].T_W_B.translation() - t[i - 1].T_W_B.translation()).norm();
    const double turn_deg =
        so3::angle(t[i - 1].T_W_B.linear().transpose() * t[i].T_W_B.linear()) * 180.0 / M_PI;
    EXPECT_LE(step_m, 2.0 * 0.8 * dt + 0.05) << "jump at frame " << i << " (t " << t[i].t_ns << ")";
    EXPECT_LE(turn_deg, 2.0 * 20.0 * dt + 2.0) << "turn at frame " << i;
  }
}

// SE(3)-aligned ATE RMSE against the simulator's ground truth [m].
double ate(const Trajectory& estimate, const Trajectory& truth) {
  const eval::Associated a = eval::associateByTime(truth, estimate);
  const auto r = eval::computeAte(a, eval::AlignMode::kSE3);
  return r ? r->trans_m.rmse : INFINITY;
}

// The undamaged 10 s row's ATE is 1.4 mm (window); a damaged run may lose some accuracy (12
// frames without an image lose track of 0.5 m of motion), not diverge: at most 10 cm (1.3 % of
// the 7.6 m path) where the damage leaves the estimator enough to go on.
constexpr double kMaxAteM = 0.10;

TEST(Faults, ARunOfCorruptAndTruncatedImagesIsSkipped) {
  OVO_REQUIRE_OVO();
  const fs::path dir = copyOfRow(test::tempDir() / "row");
  const io::Dataset clean = io::loadDataset(dir);
  // Frames 60..71: truncated to half, to 100 bytes, to nothing, or overwritten with noise.
  for (int k = 60; k < 72; ++k) {
    const fs::path p = clean.images[k].path;
    const std::string png = slurp(fs::read_symlink(p));
    fs::remove(p);
    std::ofstream out(p, std::ios::binary);
    switch (k % 4) {
      case 0:
        out << png.substr(0, png.size() / 2);
        break;
      case 1:
        out << png.substr(0, 100);
        break;
      case 2:
        break;
      case 3:
        out << std::string(png.size(), '\x5a');
        break;
    }
  }
  const io::Dataset data = io::loadDataset(dir);
  const WindowRun run = runWindow(data);
  EXPECT_EQ(run.result.skipped.count("camera", "decode"), 12);
  EXPECT_EQ(run.result.frames.size(), data.images.size() - 12);
  expectContinuous(run.trajectory);
  EXPECT_LT(ate(run.trajectory, data.groundtruth), kMaxAteM);
  // --strict: the first of them is the error, naming it.
  EXPECT_CONTAINS(test::errorOf([&] { runWindow(data, {.records = {.strict = true}}); }),
                  data.images[60].path.string() + ": truncated PNG");
}

TEST(Faults, ByDefaultOvoRunSkipsBadImagesQuietlyAndCountsThemInMetrics) {
  OVO_REQUIRE_OVO();
  const fs::path dir = copyOfRow(test::tempDir() / "row");
  const io::Dataset clean = io::loadDataset(dir);
  for (int k = 30; k < 33; ++k) {
    const std::string png = slurp(fs::read_symlink(clean.images[k].path));
    fs::remove(clean.images[k].path);
    std::ofstream(clean.images[k].path, std::ios::binary) << png.substr(0, png.size() / 3);
  }
  std::string out;
  const std::string run = "'" + test::ovoBinaryPath().string() + "' run --quiet --estimator vo " +
                          "--dataset '" + dir.string() + "' --out '" + (dir / "run").string() + "'";
  ASSERT_EQ(test::runShell(run, dir, &out), 0) << out;
  // One warning for the kind, no library noise (libpng printed "libpng error: Read Error").
  EXPECT_EQ(out.find("libpng"), std::string::npos) << out;
  EXPECT_CONTAINS(out, "camera: bad record skipped (decode): " + clean.images[30].path.string());
  EXPECT_EQ(out.find(clean.images[31].path.string()), std::string::npos) << out;
  const auto m = nlohmann::json::parse(slurp(dir / "run" / "metrics.json"));
  EXPECT_EQ(m["skipped"], nlohmann::json({{"camera", {{"decode", 3}}}})) << m["skipped"];
  EXPECT_EQ(m["frames"].get<int>(), static_cast<int>(clean.images.size()) - 3);
  // --strict: exit 2, the file named, the output folder as it was.
  const std::string before = slurp(dir / "run" / "metrics.json");
  EXPECT_EQ(test::runShell(run + " --strict", dir, &out), 2) << out;
  EXPECT_CONTAINS(out, clean.images[30].path.string() + ": truncated PNG");
  EXPECT_EQ(slurp(dir / "run" / "metrics.json"), before);
}

TEST(Faults, ACameraThatStopsFor5sAndComesBack) {
  OVO_REQUIRE_OVO();
  io::Dataset data = io::loadDataset(simulatedRow());
  // No image from 3 s to 8 s after the first (the gyro and the LiDAR go on).
  const Timestamp t0 = data.images.front().t_ns;
  std::erase_if(data.images, [&](const io::ImageEntry& e) {
    return e.t_ns > t0 + 3'000'000'000 && e.t_ns < t0 + 8'000'000'000;
  });
  const WindowRun run = runWindow(data);
  expectContinuous(run.trajectory);
  // Tracking resumes after the gap.
  int tracked_after = 0;
  for (const auto& f : run.result.frames)
    if (f.t_ns >= t0 + 8'000'000'000 && f.tracked) ++tracked_after;
  EXPECT_GT(tracked_after, 20);
}

TEST(Faults, AGyroThatStopsThenReturnsWithAJumpInItsClock) {
  OVO_REQUIRE_OVO();
  io::Dataset data = io::loadDataset(simulatedRow());
  // No gyro sample from 3 s to 5 s; after it, its stamps run 0.5 s ahead of the camera's.
  const Timestamp t0 = data.images.front().t_ns;
  std::erase_if(data.imu, [&](const ImuSample& s) {
    return s.t_ns > t0 + 3'000'000'000 && s.t_ns < t0 + 5'000'000'000;
  });
  for (auto& s : data.imu)
    if (s.t_ns >= t0 + 5'000'000'000) s.t_ns += 500'000'000;
  const WindowRun run = runWindow(data);
  expectContinuous(run.trajectory);
  EXPECT_GE(run.stats.gyro_gaps, 1);
  // The trajectory comes out on the gyro's clock (the image stamps less the estimated offset),
  // which here jumps: no offset the window may take (+-0.1 s) matches the gyro before and after
  // the jump. Whether the poses diverged is judged at their images' stamps, the truth's clock.
  Trajectory at_image_stamps = run.trajectory;
  const Timestamp offset_ns = fromSeconds(run.stats.time_offset_s.value_or(0.0));
  for (auto& p : at_image_stamps) p.t_ns += offset_ns;
  RecordProperty("time_offset_ms", std::to_string(toSeconds(offset_ns) * 1e3));
  EXPECT_LT(ate(at_image_stamps, data.groundtruth), kMaxAteM);
}

// A clipped gyro: a few samples at the sensor's full scale. The window leaves out samples whose
// rate jumps further than a robot turns in one sample period (window.gyro_max_jump_radps); before
// it followed the spikes, each turning its pose by 25 degrees in one frame (ATE 0.59 m against
// 1.4 mm undamaged).
// Saturation at +-2000 deg/s (34.9 rad/s, an MPU-9250's range) on one axis for 3 samples (15 ms),
// once a second.
void clipGyro(io::Dataset& data) {
  const double full_scale = 2000.0 * M_PI / 180.0;
  for (std::size_t i = 300; i + 3 < data.imu.size(); i += 200)
    for (std::size_t k = i; k < i + 3; ++k) data.imu[k].gyro_radps[(i / 200) % 3] = full_scale;
}

TEST(Faults, GyroSpikesAtTheSensorsRange) {
  OVO_REQUIRE_OVO();
  io::Dataset data = io::loadDataset(simulatedRow());
  clipGyro(data);
  const WindowRun run = runWindow(data);
  expectContinuous(run.trajectory);
  EXPECT_LT(ate(run.trajectory, data.groundtruth), kMaxAteM);
}

// The kf takes the gyro through the same front as the window (estimator/common/gyro_front.hpp):
// the spikes reach neither its filter nor its frontend's matching prior, and it ends where it
// ends on the undamaged data. (Before, its filter integrated each spike: a turn of about 25 deg
// in one frame.)
TEST(Faults, GyroSpikesReachNeitherTheKfNorItsMatchingPrior) {
  OVO_REQUIRE_OVO();
  const io::Dataset clean = io::loadDataset(simulatedRow());
  io::Dataset data = clean;
  clipGyro(data);
  const WindowRun damaged = runEstimator("kf", data);
  const WindowRun undamaged = runEstimator("kf", clean);
  expectContinuous(damaged.trajectory);
  const double ate_damaged = ate(damaged.trajectory, data.groundtruth);
  const double ate_clean = ate(undamaged.trajectory, clean.groundtruth);
  EXPECT_LT(ate_damaged, 1.2 * ate_clean + 0.002) << "undamaged: " << ate_clean;
  const bool said = std::any_of(damaged.stats.notes.begin(), damaged.stats.notes.end(),
                                [](const std::string& n) { return n.find("spikes") != n.npos; });
  EXPECT_TRUE(said) << "no note of the spikes";
}

TEST(Faults, NanAndNegativeRangesAndScansWithEveryBeamDropped) {
  OVO_REQUIRE_OVO();
  const fs::path dir = copyOfRow(test::tempDir() / "row");
  // In the file: one range in 10 of every scan nan, one in 20 negative; every 10th scan has
  // every beam dropped (nan).
  std::vector<std::string> rows = lines(dir / "lidar0" / "data.csv");
  for (std::size_t r = 0; r < rows.size(); ++r) {
    if (rows[r].empty() || rows[r][0] == '#') continue;
    std::vector<std::string> cols;
    std::stringstream ss(rows[r]);
    for (std::string c; std::getline(ss, c, ',');) cols.push_back(c);
    for (std::size_t c = 5; c < cols.size(); ++c) {
      const std::size_t h = (c * 7919 + r * 104729) % 20;  // scattered, the same every run
      if (r % 10 == 5 || h < 2)
        cols[c] = "nan";
      else if (h == 2)
        cols[c] = "-" + cols[c];
    }
    std::string joined;
    for (std::size_t c = 0; c < cols.size(); ++c) joined += (c ? "," : "") + cols[c];
    rows[r] = joined;
  }
  writeLines(dir / "lidar0" / "data.csv", rows);
  const io::Dataset data = io::loadDataset(dir);
  EXPECT_TRUE(data.skipped.empty());  // no return is no bad record
  const WindowRun run = runWindow(data);
  expectContinuous(run.trajectory);
  EXPECT_GT(run.stats.lidar_ranges, 0);
  EXPECT_LT(ate(run.trajectory, data.groundtruth), kMaxAteM);
}

TEST(Faults, StampsGoingBackwards) {
  OVO_REQUIRE_OVO();
  const fs::path dir = copyOfRow(test::tempDir() / "row");
  // Image list: rows 50 and 51 swapped (the first of them, ahead of both neighbours, goes), row
  // 120 repeated. Gyro: a sample 1 s back at 700, one 100 s ahead at 1300. LiDAR: a scan repeated.
  auto swapRows = [](std::vector<std::string>& rows, std::size_t a, std::size_t b) {
    std::swap(rows[a], rows[b]);
  };
  std::vector<std::string> cam = lines(dir / "cam0" / "data.csv");
  swapRows(cam, 50, 51);
  cam.insert(cam.begin() + 121, cam[120]);
  writeLines(dir / "cam0" / "data.csv", cam);
  std::vector<std::string> imu = lines(dir / "imu0" / "data.csv");
  auto shifted = [](const std::string& row, long long delta_ns) {
    const std::size_t comma = row.find(',');
    return std::to_string(std::stoll(row.substr(0, comma)) + delta_ns) + row.substr(comma);
  };
  imu[700] = shifted(imu[700], -1'000'000'000);
  imu[1300] = shifted(imu[1300], 100'000'000'000);
  writeLines(dir / "imu0" / "data.csv", imu);
  std::vector<std::string> lidar = lines(dir / "lidar0" / "data.csv");
  lidar.insert(lidar.begin() + 41, lidar[40]);
  writeLines(dir / "lidar0" / "data.csv", lidar);

  const io::Dataset data = io::loadDataset(dir);
  const nlohmann::json expected = {{"camera", {{"stamp_ahead", 1}, {"stamp_duplicate", 1}}},
                                   {"gyro", {{"stamp_backwards", 1}, {"stamp_ahead", 1}}},
                                   {"lidar", {{"stamp_duplicate", 1}}}};
  EXPECT_EQ(data.skipped.toJson(), expected) << data.skipped.toJson().dump();
  const WindowRun run = runWindow(data);
  expectContinuous(run.trajectory);
  EXPECT_LT(ate(run.trajectory, data.groundtruth), kMaxAteM);
  EXPECT_CONTAINS(
      test::errorOf([&] { io::loadDataset(dir, {.rig = {}, .topics = {}, .strict = true}); }),
      "cam0/data.csv:52: time stamps must increase");
}

TEST(Faults, CorruptImagesInTheRealtimeReplayAreSkipped) {
  OVO_REQUIRE_OVO();
  const fs::path dir = copyOfRow(test::tempDir() / "row");
  io::Dataset data = io::loadDataset(dir);
  for (int k = 40; k < 45; ++k) {
    fs::remove(data.images[k].path);
    std::ofstream(data.images[k].path) << "not an image";
  }
  auto est = estimator::makeEstimator("vo", sensorSetupFrom(data), Config());
  RealtimeOptions options;
  options.rate = 5.0;
  options.pipeline.image_queue_depth = 1000;  // nothing dropped: every good frame processed
  const RealtimeRunResult r = runRealtime(data, *est, options);
  EXPECT_EQ(r.skipped.count("camera", "decode"), 5);
  EXPECT_EQ(r.stats.frames_in, static_cast<int>(data.images.size()) - 5);
  for (const auto& p : est->trajectory()) ASSERT_TRUE(allFinite(p.T_W_B));
}

// The output disk: a tmpfs mounted in a private mount namespace (root, or an unprivileged user
// namespace), full or remounted read-only during the run. Skipped where neither is allowed.
std::string namespacePrefix() {
  static const std::string prefix = [] {
    const fs::path dir = fs::temp_directory_path();
    std::string out;
    for (const std::string p : {"unshare --mount --propagation private", "unshare -rm"})
      if (test::runShell(p + " sh -c 'mount -t tmpfs -o size=64k tmpfs \"" + dir.string() +
                             "\" && umount \"" + dir.string() + "\"'",
                         dir, &out) == 0)
        return p;
    return std::string();
  }();
  return prefix;
}

TEST(Faults, OutputDiskFullIsAnErrorAndTheOutputFolderStaysAsItWas) {
  OVO_REQUIRE_OVO();
  if (namespacePrefix().empty()) GTEST_SKIP() << "cannot mount a tmpfs here (no mount namespace)";
  const fs::path dir = test::tempDir();
  const fs::path disk = dir / "disk";
  fs::create_directories(disk);
  std::string out;
  // 16 kB: room for the earlier output and the staging folder, not for the new trajectory.
  const std::string script =
      "set -e; mount -t tmpfs -o size=16k tmpfs '" + disk.string() + "'; mkdir -p '" +
      disk.string() + "/run'; printf 'earlier\\n' > '" + disk.string() +
      "/run/trajectory.txt'; code=0; '" + test::ovoBinaryPath().string() +
      "' run --quiet --estimator vo --dataset '" + simulatedRow().string() + "' --out '" +
      disk.string() + "/run' || code=$?; echo \"exit $code\"; ls -a '" + disk.string() +
      "'; cat '" + disk.string() + "/run/trajectory.txt'; ls '" + disk.string() + "/run'";
  std::ofstream(dir / "script.sh") << script;
  ASSERT_EQ(
      test::runShell(namespacePrefix() + " sh '" + (dir / "script.sh").string() + "'", dir, &out),
      0)
      << out;
  EXPECT_CONTAINS(out, "exit 2");
  EXPECT_CONTAINS(out, "ovo: error: ");
  EXPECT_CONTAINS(out, "write failed (disk full?)");
  EXPECT_EQ(out.find("\n.run.partial-"), std::string::npos) << out;  // the staging folder went
  EXPECT_CONTAINS(out, "earlier\ntrajectory.txt\n");                 // the earlier output stayed
}

TEST(Faults, OutputDiskTurnedReadOnlyDuringTheRunIsAnErrorAndTheOutputStays) {
  OVO_REQUIRE_OVO();
  if (namespacePrefix().empty()) GTEST_SKIP() << "cannot mount a tmpfs here (no mount namespace)";
  const fs::path dir = test::tempDir();
  const fs::path disk = dir / "disk";
  fs::create_directories(disk);
  std::string out;
  // The window run takes seconds; the disk goes read-only once its staging folder exists.
  const std::string script =
      "set -e; mount -t tmpfs -o size=8m tmpfs '" + disk.string() + "'; mkdir -p '" +
      disk.string() + "/run'; printf 'earlier\\n' > '" + disk.string() + "/run/trajectory.txt'; '" +
      test::ovoBinaryPath().string() + "' run --quiet --dataset '" + simulatedRow().string() +
      "' --out '" + disk.string() + "/run' > '" + dir.string() +
      "/ovo.log' 2>&1 & pid=$!; i=0; until ls -a '" + disk.string() +
      "' | grep -q partial || [ $i -ge 200 ]; do sleep 0.05; i=$((i+1)); done; mount -o "
      "remount,ro '" +
      disk.string() +
      "'; code=0; wait $pid || code=$?; echo \"exit $code\"; "
      "cat '" +
      dir.string() + "/ovo.log'; cat '" + disk.string() + "/run/trajectory.txt'; ls '" +
      disk.string() + "/run'";
  std::ofstream(dir / "script.sh") << script;
  ASSERT_EQ(
      test::runShell(namespacePrefix() + " sh '" + (dir / "script.sh").string() + "'", dir, &out),
      0)
      << out;
  EXPECT_CONTAINS(out, "exit 2");
  EXPECT_CONTAINS(out, "ovo: error: ");
  EXPECT_CONTAINS(out, "earlier\ntrajectory.txt\n");
}

}  // namespace
}  // namespace ovo::app
