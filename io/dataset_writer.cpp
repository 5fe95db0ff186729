#include "io/dataset_writer.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <system_error>

#include "camera/calib_io.hpp"
#include "common/error.hpp"
#include "io/trajectory_io.hpp"

namespace ovo::io {
namespace fs = std::filesystem;

namespace {

std::string matrixRow16(const SE3& T) {
  std::string s = "[";
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      s += fmt::format("{}{}", r + c == 0 ? "" : ", ", T.matrix()(r, c) + 0.0);  // + 0.0: no "-0"
  return s + "]";
}

class TextFile {
 public:
  explicit TextFile(const fs::path& path) : path_(path), out_(path) {
    if (!out_) fail("cannot write '{}'", path.string());
  }
  template <typename... Args>
  void print(fmt::format_string<Args...> format, Args&&... args) {
    out_ << fmt::format(format, std::forward<Args>(args)...);
  }
  void close() {
    out_.close();
    if (!out_) fail("writing '{}' failed (disk full?)", path_.string());
  }

 private:
  fs::path path_;
  std::ofstream out_;
};

}  // namespace

DatasetWriter::DatasetWriter(const fs::path& out, bool overwrite)
    : DatasetWriter(out, overwrite, std::nullopt) {}

DatasetWriter::DatasetWriter(const fs::path& out, bool overwrite,
                             std::optional<BagFormat> bag_format)
    : folder_(out, "--out",
              overwrite ? StagedFolder::Replace::kAlways : StagedFolder::Replace::kIfEmpty) {
  std::error_code ec;
  const fs::path dir = stagingDir() / "cam0" / (bag_format ? "" : "data");
  fs::create_directories(dir, ec);
  if (ec) fail("cannot create '{}': {}", dir.string(), ec.message());
  if (bag_format)
    bag_ = BagWriter::create(*bag_format, bagPathIn(stagingDir(), "run", *bag_format));
}

DatasetWriter::~DatasetWriter() = default;

void DatasetWriter::writeImage(Timestamp t_ns, const cv::Mat& grey8) {
  if (grey8.type() != CV_8UC1) fail("writeImage: expected an 8-bit grey image");
  if (bag_) {
    const ros::Image message = ros::imageMessage(grey8, t_ns, "camera");
    std::lock_guard<std::mutex> lock(mutex_);
    bag_->write(kBagCameraTopic, message);
    return;
  }
  const fs::path path = stagingDir() / "cam0" / "data" / fmt::format("{}.png", t_ns);
  if (!cv::imwrite(path.string(), grey8, {cv::IMWRITE_PNG_COMPRESSION, 1}))
    fail("cannot write image '{}'", path.string());
  std::lock_guard<std::mutex> lock(mutex_);
  image_stamps_.push_back(t_ns);
}

void DatasetWriter::writeCamera(const camera::Camera& cam, const SE3& T_B_C, double rate_hz) {
  if (const auto* ocam = std::get_if<camera::OcamCamera>(&cam)) {
    camera::writeOcamCalib(stagingDir() / "cam0" / "calib_results.txt", *ocam);
  } else {
    camera::writeSensorYaml(stagingDir() / "cam0" / "sensor.yaml", cam, T_B_C, rate_hz);
  }
}

void DatasetWriter::writeImu(const std::vector<ImuSample>& samples) {
  if (bag_) {
    for (const auto& s : samples) bag_->write(kBagImuTopic, ros::imuMessage(s, "imu"));
    return;
  }
  fs::create_directories(stagingDir() / "imu0");
  TextFile f(stagingDir() / "imu0" / "data.csv");
  f.print(
      "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
      "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n");
  for (const auto& s : samples)
    f.print("{},{},{},{},{},{},{}\n", s.t_ns, s.gyro_radps.x(), s.gyro_radps.y(), s.gyro_radps.z(),
            s.accel_mps2.x(), s.accel_mps2.y(), s.accel_mps2.z());
  f.close();
}

void DatasetWriter::writeLidar(const std::vector<LidarScan>& scans) {
  if (bag_) {
    std::vector<Timestamp> dt;
    for (std::size_t i = 1; i < scans.size(); ++i) dt.push_back(scans[i].t_ns - scans[i - 1].t_ns);
    std::nth_element(dt.begin(), dt.begin() + static_cast<std::ptrdiff_t>(dt.size() / 2), dt.end());
    const double scan_time_s = dt.empty() ? 0.0 : toSeconds(dt[dt.size() / 2]);
    for (const auto& s : scans)
      bag_->write(kBagLidarTopic, ros::laserScanMessage(s, scan_time_s, "laser"));
    return;
  }
  fs::create_directories(stagingDir() / "lidar0");
  TextFile f(stagingDir() / "lidar0" / "data.csv");
  // Per-beam times (a time_increment column) only when a scan has them: instantaneous scans keep
  // the plain layout.
  const bool timed = std::any_of(scans.begin(), scans.end(),
                                 [](const LidarScan& s) { return s.time_increment_s != 0.0; });
  if (timed)
    f.print(
        "#timestamp [ns],angle_min [rad],angle_increment [rad],time_increment [s],range_min [m],"
        "range_max [m],ranges [m]...\n");
  else
    f.print(
        "#timestamp [ns],angle_min [rad],angle_increment [rad],range_min [m],range_max [m],ranges "
        "[m]...\n");
  std::string line;
  for (const auto& s : scans) {
    line = timed ? fmt::format("{},{},{},{},{},{}", s.t_ns, s.angle_min_rad, s.angle_increment_rad,
                               s.time_increment_s, s.range_min_m, s.range_max_m)
                 : fmt::format("{},{},{},{},{}", s.t_ns, s.angle_min_rad, s.angle_increment_rad,
                               s.range_min_m, s.range_max_m);
    for (double r : s.ranges_m) line += (r == r) ? fmt::format(",{}", r) : std::string(",nan");
    line += '\n';
    f.print("{}", line);
  }
  f.close();
}

void DatasetWriter::writeGroundTruth(const Trajectory& T_W_B) {
  writeTum(stagingDir() / "groundtruth.txt", T_W_B);
}

void DatasetWriter::writeRig(const RigInfo& rig) {
  TextFile f(stagingDir() / "rig.yaml");
  f.print("# Rig of this dataset: extrinsics (row-major 4x4) and sensor noise figures.\n");
  f.print("T_B_C: {}   # camera -> body\n", matrixRow16(rig.T_B_C));
  f.print("T_B_L: {}   # LiDAR -> body\n", matrixRow16(rig.T_B_L));
  f.print("camera: {{rate_hz: {}, pixel_sigma: {}", rig.camera_rate_hz, rig.pixel_sigma);
  if (rig.camera_height_m) f.print(", height_m: {}", *rig.camera_height_m);
  if (rig.camera_time_offset_s != 0.0) f.print(", time_offset_s: {}", rig.camera_time_offset_s);
  if (rig.camera_rolling_shutter_s != 0.0)
    f.print(", rolling_shutter_s: {}", rig.camera_rolling_shutter_s);
  f.print("}}   # height_m: camera height above the ground (m)\n");
  if (rig.camera_time_offset_s != 0.0 || rig.camera_rolling_shutter_s != 0.0)
    f.print(
        "# time_offset_s: image stamp = gyro-clock time + this (s); rolling_shutter_s: rows read "
        "out top to bottom over this (s)\n");
  f.print(
      "gyro: {{rate_hz: {}, noise_density: {}, bias_random_walk: {}}}   # rad/s/sqrt(Hz), "
      "rad/s^2/sqrt(Hz)\n",
      rig.gyro_rate_hz, rig.gyro_noise_density, rig.gyro_bias_random_walk);
  f.print("lidar: {{rate_hz: {}, range_sigma_m: {}}}\n", rig.lidar_rate_hz,
          rig.lidar_range_sigma_m);
  f.close();
}

void DatasetWriter::writeTrueGyroBias(const std::vector<std::pair<Timestamp, Vec3>>& bias) {
  fs::create_directories(stagingDir() / "sim");
  writeGyroBiasCsv(stagingDir() / "sim" / "truth_bias.csv", bias);
}

void DatasetWriter::writeText(const fs::path& relative, const std::string& text) {
  const fs::path path = stagingDir() / relative;
  fs::create_directories(path.parent_path());
  TextFile f(path);
  f.print("{}", text);
  f.close();
}

void DatasetWriter::commit() {
  if (bag_) {
    bag_->close();
    folder_.commit();
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    std::sort(image_stamps_.begin(), image_stamps_.end());
    TextFile f(stagingDir() / "cam0" / "data.csv");
    f.print("#timestamp [ns],filename\n");
    for (Timestamp t : image_stamps_) f.print("{},{}.png\n", t, t);
    f.close();
  }
  folder_.commit();
}

}  // namespace ovo::io
