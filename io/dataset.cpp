#include "io/dataset.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <regex>

#include "camera/calib_io.hpp"
#include "common/config.hpp"
#include "common/error.hpp"
#include "io/bag_dataset.hpp"
#include "io/image_decode.hpp"
#include "io/record_stream.hpp"
#include "io/text_reader.hpp"
#include "io/trajectory_io.hpp"

namespace fs = std::filesystem;

namespace ovo::io {

namespace {

// 1 / median time step, or nullopt with fewer than two stamps.
template <typename T, typename Stamp>
std::optional<double> rateHz(const std::vector<T>& items, Stamp stamp) {
  if (items.size() < 2) return std::nullopt;
  std::vector<Timestamp> dt;
  for (std::size_t i = 1; i < items.size(); ++i)
    dt.push_back(stamp(items[i]) - stamp(items[i - 1]));
  std::nth_element(dt.begin(), dt.begin() + static_cast<std::ptrdiff_t>(dt.size() / 2), dt.end());
  const Timestamp median = dt[dt.size() / 2];
  if (median <= 0) return std::nullopt;
  return kNsPerSec / static_cast<double>(median);
}

SE3 rigidFrom(const Eigen::Matrix4d& M, const std::string& where, const std::string& key) {
  const Mat3 R = M.topLeftCorner<3, 3>();
  const bool last_row = (M.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() < 1e-9;
  if (!M.allFinite() || !last_row || (R.transpose() * R - Mat3::Identity()).norm() > 1e-6 ||
      R.determinant() < 0.0)
    fail(
        "{}: key '{}': expected a rigid transform (orthonormal rotation with determinant +1, "
        "last row 0 0 0 1)",
        where, key);
  // A sensor further from the body origin than any robot is long: the translation was typed in
  // another unit (mm), and the run would go on with poses off by that factor.
  constexpr double kMaxOffsetM = 10.0;
  const double offset_m = M.topRightCorner<3, 1>().stableNorm();
  if (offset_m > kMaxOffsetM)
    fail("{}: key '{}': translation {:.4g} m from the body origin; expected metres (at most {} m)",
         where, key, offset_m, kMaxOffsetM);
  SE3 T = SE3::Identity();
  T.matrix() = M;
  return T;
}

std::vector<ImageEntry> readImageList(const fs::path& cam_dir, const RecordPolicy& policy,
                                      SkippedRecords& skipped) {
  const fs::path csv = cam_dir / "data.csv";
  if (!fs::exists(csv))
    fail("{}: missing (expected the image list: #timestamp [ns],filename)", csv.string());
  TextReader in(csv, "the image list: #timestamp [ns],filename");
  auto images = readRecordStream(in, "camera", policy, skipped, [&](const auto& tok) {
    if (tok.size() != 2)
      in.reject("columns", "expected 2 columns (timestamp [ns], filename), got {}", tok.size());
    ImageEntry e;
    e.t_ns = in.integer(tok[0], "the time stamp [ns]");
    e.path = cam_dir / "data" / std::string(tok[1]);
    if (!fs::is_regular_file(e.path))
      in.reject("missing_file", "image file {} does not exist", e.path.string());
    return e;
  });
  if (images.empty()) fail("{}: no images listed", csv.string());
  return images;
}

// Far beyond any gyro's full scale (MEMS: 35 rad/s, 2000 deg/s); larger readings are corrupt and
// would overflow the rotation integration.
constexpr double kMaxGyroRadps = 1000.0;

std::vector<ImuSample> readImu(const fs::path& csv, const RecordPolicy& policy,
                               SkippedRecords& skipped) {
  TextReader in(csv, "IMU samples: t[ns], w_x, w_y, w_z [rad/s], a_x, a_y, a_z [m/s^2]");
  auto imu = readRecordStream(in, "gyro", policy, skipped, [&](const auto& tok) {
    if (tok.size() != 7)
      in.reject("columns",
                "expected 7 columns (t[ns], w_x, w_y, w_z [rad/s], a_x, a_y, a_z [m/s^2]), got {}",
                tok.size());
    ImuSample s;
    s.t_ns = in.integer(tok[0], "the time stamp [ns]");
    s.gyro_radps =
        Vec3(in.number(tok[1], "w_x"), in.number(tok[2], "w_y"), in.number(tok[3], "w_z"));
    for (int k = 0; k < 3; ++k)
      if (std::abs(s.gyro_radps[k]) > kMaxGyroRadps)
        in.reject("out_of_range",
                  "w_{} = {} rad/s is no gyro reading (expected at most {} rad/s in magnitude)",
                  "xyz"[k], s.gyro_radps[k], kMaxGyroRadps);
    s.accel_mps2 =
        Vec3(in.number(tok[4], "a_x"), in.number(tok[5], "a_y"), in.number(tok[6], "a_z"));
    return s;
  });
  if (imu.empty()) fail("{}: no IMU samples (remove the file when there is no IMU)", csv.string());
  return imu;
}

// True when the file's first line is a '#' header naming `column`.
bool headerNames(const fs::path& file, std::string_view column) {
  std::ifstream in(file);
  std::string line;
  if (!std::getline(in, line)) return false;
  const std::size_t first = line.find('#');
  return first != std::string::npos && line.find_first_not_of(" \t\xEF\xBB\xBF") == first &&
         line.find(column) != std::string::npos;
}

// A scan longer than this is no scan (time_increment in another unit).
constexpr double kMaxScanDurationS = 1.0;

std::vector<LidarScan> readLidar(const fs::path& csv, const RecordPolicy& policy,
                                 SkippedRecords& skipped, bool* beam_times) {
  // With per-beam times (a time_increment column after angle_increment, named in the header).
  const bool timed = headerNames(csv, "time_increment");
  if (beam_times) *beam_times = timed;
  const std::size_t t = timed ? 1 : 0;  // columns before range_min beyond the plain layout's
  TextReader in(csv, timed ? "LiDAR scans: t[ns], angle_min, angle_increment [rad], "
                             "time_increment [s], range_min, range_max, ranges [m]..."
                           : "LiDAR scans: t[ns], angle_min, angle_increment [rad], range_min, "
                             "range_max, ranges [m]...");
  std::size_t columns = 0;
  auto scans = readRecordStream(in, "lidar", policy, skipped, [&](const auto& tok) {
    if (tok.size() < 6 + t)
      in.reject("columns",
                "expected t[ns], angle_min, angle_increment, {}range_min, range_max and at least "
                "one range, got {} columns",
                timed ? "time_increment, " : "", tok.size());
    if (columns != 0 && tok.size() != columns)
      in.reject("columns", "expected {} columns like the first scan, got {}", columns, tok.size());
    LidarScan s;
    s.t_ns = in.integer(tok[0], "the time stamp [ns]");
    s.angle_min_rad = in.number(tok[1], "angle_min [rad]");
    s.angle_increment_rad = in.number(tok[2], "angle_increment [rad]");
    if (timed) s.time_increment_s = in.number(tok[3], "time_increment [s]");
    s.range_min_m = in.number(tok[3 + t], "range_min [m]");
    s.range_max_m = in.number(tok[4 + t], "range_max [m]");
    if (s.angle_increment_rad == 0.0) in.reject("bad_header", "angle_increment must not be 0");
    if (std::abs(s.time_increment_s) * static_cast<double>(tok.size() - 6 - t) > kMaxScanDurationS)
      in.reject("bad_header",
                "time_increment {} s makes the scan's {} beams last over {} s: expected seconds",
                s.time_increment_s, tok.size() - 5 - t, kMaxScanDurationS);
    if (!(s.range_min_m >= 0.0 && s.range_min_m < s.range_max_m))
      in.reject("bad_header", "expected 0 <= range_min < range_max, got {} and {}", s.range_min_m,
                s.range_max_m);
    s.ranges_m.reserve(tok.size() - 5 - t);
    for (std::size_t i = 5 + t; i < tok.size(); ++i) {
      // nan/inf or a value outside [range_min, range_max] is "no return".
      const double r = in.numberOrNonFinite(tok[i], "a range [m]");
      s.ranges_m.push_back(std::isnan(r) ? std::numeric_limits<double>::quiet_NaN() : r);
    }
    columns = tok.size();
    return s;
  });
  if (scans.empty())
    fail("{}: no LiDAR scans (remove the file when there is no LiDAR)", csv.string());
  return scans;
}

// Ground truth of the EuRoC/ovo layout: root/groundtruth.txt, else mav0/groundtruth.txt, else
// state_groundtruth_estimate0/data.csv, else the one TUM .txt in that folder.
std::optional<Trajectory> readOvoGroundtruth(const fs::path& root, const fs::path& base) {
  for (const fs::path& p : {root / "groundtruth.txt", base / "groundtruth.txt"})
    if (fs::exists(p)) return readTum(p);
  const fs::path gt_dir = base / "state_groundtruth_estimate0";
  if (!fs::is_directory(gt_dir)) return std::nullopt;
  if (fs::exists(gt_dir / "data.csv")) return readEurocGroundtruthCsv(gt_dir / "data.csv");
  std::vector<fs::path> txt;
  for (const auto& e : fs::directory_iterator(gt_dir))
    if (e.is_regular_file() && e.path().extension() == ".txt") txt.push_back(e.path());
  std::sort(txt.begin(), txt.end());
  if (txt.empty()) return std::nullopt;
  if (txt.size() > 1)
    fail("{}: {} TUM files and no data.csv: cannot tell which is the ground truth", gt_dir.string(),
         txt.size());
  return readTum(txt.front());
}

Dataset loadOvo(const fs::path& root, const fs::path& base, const RecordPolicy& policy) {
  Dataset ds;
  ds.root = root;
  ds.kind = "ovo";
  const fs::path cam_dir = base / "cam0";
  ds.images = readImageList(cam_dir, policy, ds.skipped);

  const fs::path ocam = cam_dir / "calib_results.txt";
  const fs::path sensor = cam_dir / "sensor.yaml";
  std::optional<SE3> T_B_C_sensor;
  if (fs::exists(ocam)) {
    ds.camera = camera::loadCamera(ocam);
    ds.camera_file = ocam;
  } else if (fs::exists(sensor)) {
    ds.camera = camera::loadCamera(sensor);
    ds.camera_file = sensor;
    T_B_C_sensor = camera::readSensorYamlExtrinsics(sensor);
  } else {
    fail("{}: no camera calibration (expected calib_results.txt or sensor.yaml there)",
         cam_dir.string());
  }

  fs::path rig_file;
  for (const fs::path& p : {root / "rig.yaml", base / "rig.yaml"}) {
    if (fs::exists(p)) {
      ds.rig = readRigYaml(p);
      rig_file = p;
      break;
    }
  }
  ds.rig.T_B_C = cameraExtrinsics(ds.rig, T_B_C_sensor, rig_file);

  if (fs::exists(base / "imu0" / "data.csv"))
    ds.imu = readImu(base / "imu0" / "data.csv", policy, ds.skipped);
  if (fs::exists(base / "lidar0" / "data.csv"))
    ds.scans = readLidar(base / "lidar0" / "data.csv", policy, ds.skipped, nullptr);
  if (auto gt = readOvoGroundtruth(root, base)) ds.groundtruth = std::move(*gt);
  if (fs::exists(root / "sim" / "truth_bias.csv"))
    ds.true_gyro_bias = readGyroBiasCsv(root / "sim" / "truth_bias.csv");
  if (fs::exists(root / "sim" / "truth_timing.yaml"))
    ds.true_timing = readTrueTiming(root / "sim" / "truth_timing.yaml");

  if (!ds.rig.has_rig_file) {
    if (auto r = rateHz(ds.images, [](const ImageEntry& e) { return e.t_ns; }))
      ds.rig.camera_rate_hz = *r;
    if (auto r = rateHz(ds.imu, [](const ImuSample& s) { return s.t_ns; }))
      ds.rig.gyro_rate_hz = *r;
    if (auto r = rateHz(ds.scans, [](const LidarScan& s) { return s.t_ns; }))
      ds.rig.lidar_rate_hz = *r;
  }
  return ds;
}

// KITTI calib.txt: the P0 row "P0: 12 numbers" (3x4 projection of the rectified left camera).
Eigen::Matrix<double, 3, 4> readKittiP0(const fs::path& file) {
  TextReader in(file, "KITTI calibration: rows 'P0: <12 numbers>'");
  std::vector<std::string_view> tok;
  while (in.next(tok)) {
    if (tok.empty() || tok[0] != "P0:") continue;
    if (tok.size() != 13) in.fail("expected 'P0:' and 12 numbers, got {} numbers", tok.size() - 1);
    Eigen::Matrix<double, 3, 4> P;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) P(r, c) = in.number(tok[1 + 4 * r + c], "a P0 element");
    if (!(P(0, 0) > 0.0 && P(1, 1) > 0.0))
      in.fail("expected positive focal lengths in P0, got fx {} fy {}", P(0, 0), P(1, 1));
    return P;
  }
  fail("{}: no 'P0:' row (expected the left grey camera's 3x4 projection matrix)", file.string());
}

std::vector<Timestamp> readKittiTimes(const fs::path& file) {
  TextReader in(file, "KITTI times: one time [s] a line");
  std::vector<Timestamp> times;
  std::vector<std::string_view> tok;
  while (in.next(tok)) {
    if (tok.size() != 1) in.fail("expected one time [s] a line, got {} values", tok.size());
    const Timestamp t = in.secondsToNs(tok[0], "the time [s]");
    checkIncreasing(in, times.empty() ? 0 : times.back(), t, times.empty());
    times.push_back(t);
  }
  if (times.empty()) fail("{}: no time stamps", file.string());
  return times;
}

SE3 kittiBodyFromCamera() {
  SE3 T_B_C = SE3::Identity();
  T_B_C.linear() << 0, 0, 1,  //
      -1, 0, 0,               //
      0, -1, 0;
  return T_B_C;
}

// KITTI ground truth, T_Wc_C in KITTI's camera-style world (the first camera frame), as T_W_B with
// W z-up: T_W_B = A T_Wc_C A^-1, A = T_B_C. Rows without a time take times.txt's stamp by index.
Trajectory kittiCameraPosesAsBody(Trajectory poses, bool has_time,
                                  const std::vector<Timestamp>& times, const fs::path& pose_file,
                                  const fs::path& times_file) {
  if (!has_time) {
    if (poses.size() > times.size())
      fail("{}: {} poses but {} has only {} time stamps", pose_file.string(), poses.size(),
           times_file.string(), times.size());
    for (std::size_t i = 0; i < poses.size(); ++i) poses[i].t_ns = times[i];
  }
  const SE3 A = kittiBodyFromCamera();
  for (auto& p : poses) p.T_W_B = A * p.T_W_B * A.inverse();
  return poses;
}

Dataset loadKitti(const fs::path& root) {
  Dataset ds;
  ds.root = root;
  ds.kind = "kitti";
  const fs::path times_file = root / "times.txt";
  if (!fs::exists(times_file))
    fail("{}: missing (expected one time [s] per frame)", times_file.string());
  const std::vector<Timestamp> times = readKittiTimes(times_file);

  // Frames are image_0/<index>.png; only those present are used, with times.txt's stamps.
  std::vector<std::pair<std::size_t, fs::path>> frames;
  for (const auto& e : fs::directory_iterator(root / "image_0")) {
    if (!e.is_regular_file() || e.path().extension() != ".png") continue;
    const std::string stem = e.path().stem().string();
    if (stem.empty() || stem.size() > 9 ||  // 9 digits: 1e9 frames, and stoul cannot overflow
        !std::all_of(stem.begin(), stem.end(), [](char c) { return c >= '0' && c <= '9'; }))
      fail("{}: expected a frame number of at most 9 digits as the file name (e.g. 000042.png)",
           e.path().string());
    const std::size_t index = std::stoul(stem);
    if (index >= times.size())
      fail("{}: frame {} has no time stamp ({} has {} rows)", e.path().string(), index,
           times_file.string(), times.size());
    frames.emplace_back(index, e.path());
  }
  if (frames.empty()) fail("{}: no .png images", (root / "image_0").string());
  std::sort(frames.begin(), frames.end());
  for (const auto& [index, path] : frames) ds.images.push_back({times[index], path});

  const Eigen::Matrix<double, 3, 4> P0 = readKittiP0(root / "calib.txt");
  const cv::Mat first = loadImageGrey(ds.images.front());
  ds.camera =
      camera::PinholeRadtanCamera(P0(0, 0), P0(1, 1), P0(0, 2), P0(1, 2), first.cols, first.rows);
  ds.camera_file = root / "calib.txt";  // its image size is the first image's
  // The KITTI rig: body B x forward, y left, z up at the camera centre, camera pitch 0 (x_C = -y_B,
  // y_C = -z_B, z_C = x_B), 1.65 m above the road. Estimators take "up" from T_B_C.
  ds.rig.T_B_C = kittiBodyFromCamera();
  ds.rig.camera_height_m = 1.65;
  if (auto r = rateHz(ds.images, [](const ImageEntry& e) { return e.t_ns; }))
    ds.rig.camera_rate_hz = *r;

  // Ground truth: poses*.txt or NN.txt beside image_0 (camera poses, turned into T_W_B).
  std::vector<fs::path> pose_files;
  const std::regex pose_name(R"((poses.*|[0-9][0-9])\.txt)");
  for (const auto& e : fs::directory_iterator(root))
    if (e.is_regular_file() && std::regex_match(e.path().filename().string(), pose_name))
      pose_files.push_back(e.path());
  std::sort(pose_files.begin(), pose_files.end());
  if (pose_files.size() > 1)
    fail("{}: {} pose files ({}, {}, ...): keep one", root.string(), pose_files.size(),
         pose_files[0].filename().string(), pose_files[1].filename().string());
  if (!pose_files.empty()) {
    bool has_time = false;
    Trajectory poses = readKitti(pose_files.front(), &has_time);
    ds.groundtruth =
        kittiCameraPosesAsBody(std::move(poses), has_time, times, pose_files.front(), times_file);
  }
  return ds;
}

}  // namespace

SE3 cameraExtrinsics(const RigInfo& rig, const std::optional<SE3>& T_B_C_calib,
                     const fs::path& rig_file) {
  if (rig.has_T_B_C) return rig.T_B_C;
  if (T_B_C_calib) return *T_B_C_calib;
  if (rig.has_rig_file)
    fail(
        "{}: no T_B_C (the camera's pose in the body frame, 4x4 row-major) and no T_BS in the "
        "camera calibration (sensor.yaml): expected one of them",
        rig_file.string());
  return rig.T_B_C;
}

RigInfo readRigYaml(const fs::path& file) {
  if (!fs::exists(file)) fail("rig file '{}' does not exist (expected a rig.yaml)", file.string());
  const Config cfg = Config::load(file);
  const std::string where = file.string();
  constexpr double kMin = 1e-9;  // rates, sigmas and heights must be positive
  constexpr double kMax = 1e6;
  RigInfo rig;
  rig.has_rig_file = true;
  rig.has_T_B_C = cfg.has("T_B_C");
  rig.T_B_C =
      rigidFrom(cfg.get<Eigen::Matrix4d>("T_B_C", Eigen::Matrix4d::Identity()), where, "T_B_C");
  rig.T_B_L =
      rigidFrom(cfg.get<Eigen::Matrix4d>("T_B_L", Eigen::Matrix4d::Identity()), where, "T_B_L");
  rig.camera_rate_hz = cfg.getInRange("camera.rate_hz", rig.camera_rate_hz, kMin, kMax);
  rig.pixel_sigma = cfg.getInRange("camera.pixel_sigma", rig.pixel_sigma, kMin, kMax);
  if (cfg.has("camera.height_m"))
    rig.camera_height_m = cfg.getInRange("camera.height_m", 0.0, kMin, kMax);
  rig.camera_time_offset_s =
      cfg.getInRange("camera.time_offset_s", rig.camera_time_offset_s, -1.0, 1.0);
  rig.camera_rolling_shutter_s =
      cfg.getInRange("camera.rolling_shutter_s", rig.camera_rolling_shutter_s, 0.0, 1.0);
  rig.gyro_rate_hz = cfg.getInRange("gyro.rate_hz", rig.gyro_rate_hz, kMin, kMax);
  rig.gyro_noise_density = cfg.getInRange("gyro.noise_density", rig.gyro_noise_density, 0.0, kMax);
  rig.gyro_bias_random_walk =
      cfg.getInRange("gyro.bias_random_walk", rig.gyro_bias_random_walk, 0.0, kMax);
  rig.lidar_rate_hz = cfg.getInRange("lidar.rate_hz", rig.lidar_rate_hz, kMin, kMax);
  rig.lidar_range_sigma_m =
      cfg.getInRange("lidar.range_sigma_m", rig.lidar_range_sigma_m, 0.0, kMax);
  if (cfg.has("camera.calibration")) {
    const std::string calib = cfg.get<std::string>("camera.calibration", "");
    if (calib.empty())
      fail("{}: key 'camera.calibration': expected the camera calibration file's path", where);
    rig.camera_calibration = file.parent_path() / calib;
  }
  cfg.checkAllUsed();
  return rig;
}

std::vector<LidarScan> readLidarCsv(const fs::path& csv, bool* beam_times) {
  SkippedRecords skipped;
  return readLidar(csv, RecordPolicy{.strict = true}, skipped, beam_times);
}

TrueTiming readTrueTiming(const fs::path& file) {
  const Config cfg = Config::load(file);
  TrueTiming t;
  t.camera_time_offset_s = cfg.getInRange("camera.time_offset_s", 0.0, -1.0, 1.0);
  t.camera_rolling_shutter_s = cfg.getInRange("camera.rolling_shutter_s", 0.0, 0.0, 1.0);
  t.camera_frames = cfg.getIntInRange("camera.frames", 0, 0, 1'000'000'000);
  t.camera_frames_dropped = cfg.getIntInRange("camera.frames_dropped", 0, 0, 1'000'000'000);
  t.lidar_time_increment_s = cfg.getInRange("lidar.time_increment_s", 0.0, -1.0, 1.0);
  t.lidar_scan_time_s = cfg.getInRange("lidar.scan_time_s", 0.0, 0.0, 1000.0);
  t.lidar_beams = cfg.getIntInRange("lidar.beams", 0, 0, 1'000'000'000);
  t.imu_time_jitter_s = cfg.getInRange("imu.time_jitter_s", 0.0, 0.0, 1.0);
  cfg.checkAllUsed();
  return t;
}

std::vector<std::string> lidarTimingNotes(const Dataset& data) {
  if (data.scans.empty() ||
      std::any_of(data.scans.begin(), data.scans.end(),
                  [](const LidarScan& s) { return s.time_increment_s != 0.0; }))
    return {};
  return {
      fmt::format("LiDAR: {} scans without per-beam times (no time_increment column): taken as "
                  "instantaneous",
                  data.scans.size())};
}

namespace {

// The one bag in a folder without an image list (`ovo simulate --format rosbag|db3|mcap`
// writes the bag beside its rig.yaml): *.bag, *.db3, *.mcap or a rosbag2 sub-folder.
std::optional<fs::path> singleBagIn(const fs::path& root) {
  if (fs::exists(root / "cam0" / "data.csv") || fs::exists(root / "mav0" / "cam0" / "data.csv") ||
      fs::exists(root / "image_0"))
    return std::nullopt;
  std::vector<fs::path> bags;
  for (const auto& e : fs::directory_iterator(root))
    if (e.path().filename().string()[0] != '.' && bag::isBagPath(e.path()) &&
        (e.is_directory() || e.is_regular_file()))
      bags.push_back(e.path());
  if (bags.size() != 1) return std::nullopt;
  return bags.front();
}

}  // namespace

Dataset loadDataset(const fs::path& root, const LoadOptions& options) {
  if (bag::isBagPath(root)) return loadBagDataset(root, options);
  if (!fs::is_directory(root)) fail("{}: dataset folder not found", root.string());
  if (auto bag = singleBagIn(root)) return loadBagDataset(*bag, options);
  if (!options.rig.empty() || !options.topics.empty())
    fail(
        "{}: --rig and --topics apply to bags (.bag, .db3, .mcap, a rosbag2 folder); a dataset "
        "folder has its own rig.yaml",
        root.string());
  if (fs::is_directory(root / "mav0" / "cam0"))
    return loadOvo(root, root / "mav0", options.records());
  if (fs::is_directory(root / "cam0")) return loadOvo(root, root, options.records());
  if (fs::is_directory(root / "image_0")) {
    if (!fs::exists(root / "calib.txt"))
      fail("{}: missing (a KITTI folder needs calib.txt beside image_0/)",
           (root / "calib.txt").string());
    return loadKitti(root);
  }
  fail(
      "{}: not a dataset folder: expected cam0/ or mav0/cam0/ (EuRoC/ASL layout) or image_0/ "
      "with calib.txt and times.txt (KITTI)",
      root.string());
}

Trajectory readGroundtruthFor(const Dataset& ds, const fs::path& file) {
  TrajectoryFile gt = readTrajectory(file);
  if (ds.kind != "kitti" || gt.format != TrajectoryFormat::kKitti) return std::move(gt.poses);
  const fs::path times_file = ds.root / "times.txt";
  return kittiCameraPosesAsBody(std::move(gt.poses), gt.has_time, readKittiTimes(times_file), file,
                                times_file);
}

cv::Mat loadImageGrey(const ImageEntry& entry) {
  if (entry.load) return entry.load();
  return readImageGrey(entry.path);
}

cv::Mat loadDatasetImage(const Dataset& ds, std::size_t index) {
  const ImageEntry& entry = ds.images.at(index);
  if (entry.load) {  // a bag's message, decoded by its reader
    cv::Mat image = entry.load();
    if (ds.camera) {
      const int w = camera::width(*ds.camera), h = camera::height(*ds.camera);
      if (image.cols != w || image.rows != h)
        fail("{}: the image is {}x{}, but the camera calibration ({}) is for {}x{} images",
             entry.path.string(), image.cols, image.rows, ds.camera_file.string(), w, h);
    }
    return image;
  }
  if (!ds.camera) return readImageGrey(entry.path);
  return readImageGrey(entry.path,
                       {cv::Size(camera::width(*ds.camera), camera::height(*ds.camera)),
                        fmt::format("the camera calibration ({})", ds.camera_file.string())});
}

std::vector<std::string> clockOverlapNotes(const Dataset& data, const Trajectory& groundtruth) {
  std::vector<std::string> notes;
  if (data.images.empty()) return notes;
  const Timestamp first = data.images.front().t_ns, last = data.images.back().t_ns;
  auto check = [&](const char* what, std::size_t n, Timestamp a, Timestamp b) {
    if (b >= first && a <= last) return;
    notes.push_back(fmt::format(
        "{}: its {} stamps ({:.3f} .. {:.3f} s) do not overlap the camera's ({:.3f} .. {:.3f} s), "
        "so it is not used; expected the camera's clock",
        what, n, toSeconds(a), toSeconds(b), toSeconds(first), toSeconds(last)));
  };
  if (!data.imu.empty())
    check("gyro", data.imu.size(), data.imu.front().t_ns, data.imu.back().t_ns);
  if (!data.scans.empty())
    check("LiDAR", data.scans.size(), data.scans.front().t_ns, data.scans.back().t_ns);
  if (!groundtruth.empty())
    check("ground truth", groundtruth.size(), groundtruth.front().t_ns, groundtruth.back().t_ns);
  return notes;
}

}  // namespace ovo::io
