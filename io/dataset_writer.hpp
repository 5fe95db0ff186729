// Writing a dataset folder in the ovo/EuRoC layout (DESIGN.md section 10), as `ovo simulate` does:
// everything goes into a hidden staging folder beside the target, renamed into place by commit(),
// so a failed or interrupted run never leaves a half-written dataset behind. With a bag format the
// images, gyro and scans go into one bag in the folder instead (run.bag, run/ with metadata.yaml
// and run_0.db3, or run.mcap; io/bag_writer.hpp), beside the same rig.yaml, cam0/ calibration and
// ground truth, which is what `ovo run` reads for a bag (io/bag_dataset.hpp).
#pragma once

#include <filesystem>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "camera/camera.hpp"
#include "common/types.hpp"
#include "io/bag_writer.hpp"
#include "io/dataset.hpp"
#include "io/staged_folder.hpp"

namespace ovo::io {

class DatasetWriter {
 public:
  /// Prepares a staging folder for `out` (io::StagedFolder). Throws ovo::Error when `out` exists
  /// and is not an empty folder (unless overwrite, which replaces a folder at commit()), or when
  /// the folder cannot be created. The staging folder goes unless commit() succeeds.
  explicit DatasetWriter(const std::filesystem::path& out, bool overwrite = false);
  /// The same with the measurements in a bag of `bag_format` (nullopt: the folder layout).
  DatasetWriter(const std::filesystem::path& out, bool overwrite,
                std::optional<BagFormat> bag_format);
  ~DatasetWriter();
  DatasetWriter(const DatasetWriter&) = delete;
  DatasetWriter& operator=(const DatasetWriter&) = delete;

  const std::filesystem::path& stagingDir() const { return folder_.staging(); }

  /// cam0/data/<t_ns>.png (8-bit grey, lossless), or a mono8 Image message in the bag (in the
  /// order of the calls: call in time order for a reproducible bag). Thread-safe.
  void writeImage(Timestamp t_ns, const cv::Mat& grey8);
  /// cam0/calib_results.txt for an OCamCalib camera, cam0/sensor.yaml (EuRoC) for the others.
  void writeCamera(const camera::Camera& camera, const SE3& T_B_C, double rate_hz);
  /// imu0/data.csv (gyro rad/s, accelerometer m/s^2, in B).
  void writeImu(const std::vector<ImuSample>& samples);
  /// lidar0/data.csv, one scan a row; no return written as nan; with a time_increment column when
  /// a scan has per-beam times (io::readLidarCsv reads both layouts). In a bag: LaserScan messages
  /// (float32 values, scan_time the median time between scans).
  void writeLidar(const std::vector<LidarScan>& scans);
  /// groundtruth.txt (TUM, T_W_B).
  void writeGroundTruth(const Trajectory& T_W_B);
  /// rig.yaml (T_B_C, T_B_L and the noise figures).
  void writeRig(const RigInfo& rig);
  /// sim/truth_bias.csv: the true gyro bias (rad/s).
  void writeTrueGyroBias(const std::vector<std::pair<Timestamp, Vec3>>& bias);
  /// Any text file at a path relative to the dataset root (e.g. sim/scenario.yaml).
  void writeText(const std::filesystem::path& relative, const std::string& text);

  /// Writes cam0/data.csv for the images written so far and moves the folder into place.
  void commit();

 private:
  StagedFolder folder_;
  std::mutex mutex_;
  std::vector<Timestamp> image_stamps_;
  std::unique_ptr<BagWriter> bag_;  // set with a bag format
};

}  // namespace ovo::io
