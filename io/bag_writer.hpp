// Writing bags of the four sensor_msgs types: ROS 1 .bag (through librosbag-storage and
// libsensor-msgs), rosbag2 sqlite3 (a folder with metadata.yaml and one .db3) and MCAP (ros2
// profile, CDR, zstd chunks by default). Used by `ovo simulate --format` and `ovo convert`, and by
// the tests that check the readers against bags ovo wrote. Record time = the header stamp.
#pragma once

#include <filesystem>
#include <memory>
#include <string>

#include "io/ros_messages.hpp"

namespace ovo::io {

enum class BagFormat { kRos1, kSqlite3, kMcap };

/// "rosbag" (or "ros1", "bag"), "db3" (or "sqlite3"), "mcap"; throws ovo::Error otherwise.
BagFormat parseBagFormat(const std::string& name);
/// Where a bag of this format named `stem` goes in `dir`: stem.bag, stem/ (a rosbag2 folder
/// holding metadata.yaml and stem_0.db3) or stem.mcap.
std::filesystem::path bagPathIn(const std::filesystem::path& dir, const std::string& stem,
                                BagFormat format);

class BagWriter {
 public:
  /// `path` as bagPathIn gives. compression: ROS 1 "none", "bz2" or "lz4"; MCAP "", "zstd" or
  /// "lz4"; ignored for db3; empty: none (ROS 1), zstd (MCAP). Throws ovo::Error when the file
  /// cannot be created.
  static std::unique_ptr<BagWriter> create(BagFormat format, const std::filesystem::path& path,
                                           const std::string& compression = "");
  virtual ~BagWriter() = default;

  /// Messages in any order (readers sort by time); each topic keeps one type.
  virtual void write(const std::string& topic, const ros::Image& m) = 0;
  virtual void write(const std::string& topic, const ros::CompressedImage& m) = 0;
  virtual void write(const std::string& topic, const ros::Imu& m) = 0;
  virtual void write(const std::string& topic, const ros::LaserScan& m) = 0;
  /// Finishes the file (index, summary, metadata.yaml). Throws ovo::Error on a write failure.
  virtual void close() = 0;
};

/// The topics ovo writes.
inline constexpr const char* kBagCameraTopic = "/camera/image_raw";
inline constexpr const char* kBagImuTopic = "/imu/data";
inline constexpr const char* kBagLidarTopic = "/scan";

}  // namespace ovo::io
