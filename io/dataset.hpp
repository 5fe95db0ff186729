// Reading a recorded or simulated sequence from disk: the ovo/EuRoC (ASL) folder layout, KITTI
// odometry folders (DESIGN.md section 10) and bags (ROS 1, rosbag2 sqlite3, MCAP:
// io/bag_dataset.hpp). Errors name the file, the line and what was expected; nothing is read
// lazily except the images themselves (loadImageGrey).
#pragma once

#include <filesystem>
#include <functional>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "camera/camera.hpp"
#include "common/types.hpp"
#include "io/skipped_records.hpp"

namespace ovo::io {

/// One camera frame on disk.
struct ImageEntry {
  Timestamp t_ns = 0;
  std::filesystem::path path;
  /// Set for an image inside a bag: decodes it as 8-bit grey (path then only names it).
  std::function<cv::Mat()> load = {};
};

/// Rig extrinsics and sensor noise figures: from rig.yaml when there is one (has_rig_file), else
/// T_B_C from the camera's sensor.yaml T_BS and rates measured from the time stamps.
struct RigInfo {
  SE3 T_B_C = SE3::Identity();  // camera -> body
  SE3 T_B_L = SE3::Identity();  // LiDAR -> body
  double camera_rate_hz = 20.0;
  double pixel_sigma = 0.5;               // image noise [px]
  std::optional<double> camera_height_m;  // camera height above the ground [m]
  double camera_time_offset_s = 0.0;      // image stamp = gyro-clock time + this (a prior) [s]
  double camera_rolling_shutter_s = 0.0;  // rows read out top to bottom over this (0: global) [s]
  double gyro_rate_hz = 200.0;
  double gyro_noise_density = 1.7e-4;     // [rad/s/sqrt(Hz)]
  double gyro_bias_random_walk = 2.0e-5;  // [rad/s^2/sqrt(Hz)]
  double lidar_rate_hz = 10.0;
  double lidar_range_sigma_m = 0.02;
  bool has_rig_file = false;
  bool has_T_B_C = false;  // the rig file gave T_B_C (without it: the camera's sensor.yaml T_BS)
  std::filesystem::path camera_calibration;  // camera.calibration (bags): the calibration file
};

/// The simulator's truth of the sensors' timing (sim/truth_timing.yaml), in seconds.
struct TrueTiming {
  double camera_time_offset_s = 0.0;      // image stamp = true time + this
  double camera_rolling_shutter_s = 0.0;  // readout time, top row to bottom
  int camera_frames = 0;                  // frames rendered, dropped ones included
  int camera_frames_dropped = 0;
  double lidar_time_increment_s = 0.0;  // beam i at the scan's stamp + i * this
  double lidar_scan_time_s = 0.0;       // one turn of the mirror (0: instantaneous)
  int lidar_beams = 0;
  double imu_time_jitter_s = 0.0;  // std of the gyro stamps around the true sample times
};

/// Everything of a sequence except the pixels. Ground truth is T_W_B.
struct Dataset {
  std::filesystem::path root;
  std::string kind;  // "ovo" (EuRoC/ASL layout), "kitti" or "bag"
  std::vector<ImageEntry> images;
  std::optional<camera::Camera> camera;
  std::filesystem::path camera_file;  // where the calibration came from (messages)
  RigInfo rig;
  std::vector<ImuSample> imu;
  std::vector<LidarScan> scans;
  Trajectory groundtruth;                                  // T_W_B; empty when there is none
  std::vector<std::pair<Timestamp, Vec3>> true_gyro_bias;  // [rad/s], simulator only
  std::vector<std::string> notes;  // what the reader assumed (a bag's record times, ...)
  SkippedRecords skipped;  // bad records the readers skipped (RecordPolicy), by sensor and reason
  std::optional<TrueTiming> true_timing;  // sim/truth_timing.yaml, simulator only
};

/// How a dataset is read: for bags the rig file (--rig) and the topics (--topics
/// camera=...,imu=...,lidar=...), see io/bag_dataset.hpp (both empty for folders); for folders
/// whether a bad record in a sensor stream is an error (strict) or skipped and counted.
struct LoadOptions {
  std::filesystem::path rig;
  std::string topics;
  bool strict = false;
  RecordPolicy records() const { return {.strict = strict}; }
};

/// Detects the layout of `root` and reads it:
/// - ovo/EuRoC: root holds cam0/ (or mav0/cam0/): cam0/data.csv + cam0/data/*.png and a
///   calibration in cam0/ (calib_results.txt or sensor.yaml); optional imu0/data.csv,
///   lidar0/data.csv (with or without per-beam times: readLidarCsv), rig.yaml, groundtruth.txt
///   (TUM) or state_groundtruth_estimate0/ (data.csv or a TUM .txt), sim/truth_bias.csv,
///   sim/truth_timing.yaml;
/// - KITTI odometry: image_0/*.png, calib.txt (P0), times.txt, optional poses file (poses*.txt or
///   NN.txt, 3x4 rows with or without a leading time); the KITTI rig (kittiBodyFromCamera(), camera
///   1.65 m above the road, pitch 0) and the ground truth turned into T_W_B with W z-up.
/// - a bag: a .bag, .db3 or .mcap file or a rosbag2 folder (io/bag_dataset.hpp), or a folder
///   holding no cam0/data.csv but exactly one bag (as `ovo simulate --format` writes).
/// Throws ovo::Error naming the file and line on anything missing or malformed, except a bad
/// record in a folder's sensor stream (an image-list, gyro or LiDAR row: unparsable, non-finite,
/// a stamp out of order, an image file missing), which is skipped and counted in Dataset::skipped
/// unless options.strict (io/skipped_records.hpp); options for bags given for a folder are an
/// error.
Dataset loadDataset(const std::filesystem::path& root, const LoadOptions& options = {});

/// A ground-truth file for `ds` (`ovo run --gt`): TUM, KITTI or EuRoC csv, as readTrajectory()
/// reads it. On a KITTI folder a KITTI-format file is taken as the folder's own poses file is:
/// camera poses, turned into T_W_B, and rows without a time stamped from times.txt by index.
Trajectory readGroundtruthFor(const Dataset& ds, const std::filesystem::path& file);

/// T_B_C of the KITTI rig: body x forward, y left, z up at the camera centre, camera pitch 0.
SE3 kittiBodyFromCamera();

/// The image as 8-bit grey (colour is converted), through io/image_decode (no codec library
/// prints). Throws a RecordError naming the file when it is missing (reason "missing_file") or
/// does not decode (truncated, corrupt: "decode").
cv::Mat loadImageGrey(const ImageEntry& entry);
/// Image `index` of the dataset, as loadImageGrey, checked against the calibration's image size
/// (a RecordError "size" naming the image and the calibration file when they differ; checked
/// before decoding when the file's header tells).
cv::Mat loadDatasetImage(const Dataset& ds, std::size_t index);

/// The camera's pose in the body frame: the rig file's T_B_C when it gives one, else the camera
/// calibration's own (T_B_C_calib, a sensor.yaml T_BS), else the rig's identity when there is no
/// rig file. Throws naming rig_file when a rig file gives neither (identity: the camera looks up).
SE3 cameraExtrinsics(const RigInfo& rig, const std::optional<SE3>& T_B_C_calib,
                     const std::filesystem::path& rig_file);

/// Reads rig.yaml (unknown keys, bad values and non-rigid transforms are errors naming the key).
/// camera.calibration (a path relative to the rig file) is kept for bags; folders use cam0/.
RigInfo readRigYaml(const std::filesystem::path& file);

/// Reads lidar0/data.csv, one scan a row, in either layout (DESIGN.md section 10 and README):
///   t_ns, angle_min, angle_increment, range_min, range_max, r_0, ..., r_n-1
///   t_ns, angle_min, angle_increment, time_increment, range_min, range_max, r_0, ..., r_n-1
/// The second when the header line (the first line, a '#' comment) names a time_increment column:
/// beam i was taken at t_ns + i * time_increment [s] (ROS LaserScan's stamp and time_increment).
/// The first gives instantaneous scans (time_increment 0); *beam_times says which it was.
std::vector<LidarScan> readLidarCsv(const std::filesystem::path& csv, bool* beam_times = nullptr);

/// Reads sim/truth_timing.yaml (what `ovo simulate` writes there).
TrueTiming readTrueTiming(const std::filesystem::path& file);

/// Notes on how the dataset's LiDAR scans are timed: none without scans or when a scan has
/// per-beam times (a time_increment), else that the scans are taken as instantaneous.
std::vector<std::string> lidarTimingNotes(const Dataset& data);

/// One note per sensor of `data` (gyro, LiDAR) and for `groundtruth` whose stamps do not overlap
/// the camera frames' span: it is on another clock (or in another unit) and would go unused
/// without a word (the ground truth leaving every accuracy metric out). None without images.
std::vector<std::string> clockOverlapNotes(const Dataset& data, const Trajectory& groundtruth);

}  // namespace ovo::io
