// A bag (ROS 1 .bag, rosbag2 .db3 or folder, MCAP) read as the same Dataset a folder gives
// (io/dataset.hpp): the camera, gyro and LiDAR topics chosen by type or by name, their messages
// decoded (io/cdr.hpp), stamped with their header stamps, and the calibration and extrinsics taken
// from a rig file, since bags rarely carry them.
//
// Topics: with no choice given, the one topic of each type (camera: sensor_msgs/Image or
// CompressedImage; imu: Imu; lidar: LaserScan) among those with messages; several of a type are an
// error asking for --topics. A camera topic is required; gyro and LiDAR are optional ("none"
// leaves one out). Time: each message's header.stamp; when a chosen topic has zero stamps (as
// some drivers and scripts write), every chosen topic takes the bag's record times instead (one
// clock), with a note. Messages are put in time order; a repeated stamp keeps the first message
// (counted in a note).
//
// The rig file (--rig, else rig.yaml beside the bag; for a rosbag2 folder inside it, then beside
// it) is a dataset folder's rig.yaml. The camera calibration is the file its `camera.calibration`
// key names (relative to the rig file), else calib_results.txt or sensor.yaml beside the rig
// file or in cam0/ beside it (so a dataset folder's rig.yaml serves its bag as it is). Ground truth
// (groundtruth.txt) and the simulator's sim/truth_bias.csv are taken from the same places when
// present.
#pragma once

#include <filesystem>
#include <string>

#include "io/bag_source.hpp"
#include "io/dataset.hpp"

namespace ovo::io {

/// The chosen topic names (empty: none).
struct BagTopics {
  std::string camera, imu, lidar;
};

/// Parses --topics "camera=/cam/image,imu=/imu/data,lidar=/scan" (any subset; "none" leaves a
/// sensor out). Throws ovo::Error naming --topics on an unknown key or a malformed entry.
/// `explicit_keys` gets the keys given.
BagTopics parseBagTopics(const std::string& spec, BagTopics* explicit_keys = nullptr);

/// The topics a dataset takes from `bag` (see the header comment). Throws ovo::Error naming the
/// file, the topic and what was expected: a chosen topic missing or of another type (or
/// encoding, or MD5 sum), no camera topic, several topics of a type without a choice.
BagTopics chooseBagTopics(const bag::BagSource& bag, const std::string& topics_option);

/// The rig file a bag at `bag_path` uses: `rig_option` when given (must exist), else the first
/// rig.yaml of the places above; throws ovo::Error saying where it looked.
std::filesystem::path bagRigFile(const std::filesystem::path& bag_path,
                                 const std::filesystem::path& rig_option);

/// The camera calibration file of a rig file: the one its camera.calibration key names
/// (relative to the rig file), else calib_results.txt or sensor.yaml beside it or in cam0/ beside
/// it. Throws ovo::Error naming the rig file when there is none.
std::filesystem::path rigCameraCalibration(const RigInfo& rig,
                                           const std::filesystem::path& rig_file);

/// Reads the bag at `path` into a Dataset (kind "bag"); images are decoded when loaded
/// (loadImageGrey). Throws ovo::Error naming the file, topic and what was expected.
Dataset loadBagDataset(const std::filesystem::path& path, const LoadOptions& options);

}  // namespace ovo::io
