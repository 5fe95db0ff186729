// ROS 1 bags (format 2.0: uncompressed, bz2 and lz4 chunks) as a BagSource
// (io/bag_source.hpp), read through Debian's librosbag-storage (rosbag::Bag, rosbag::View), which
// needs no ROS installation or environment. Connections are merged by topic; a connection whose
// type is a known sensor_msgs type must carry that type's MD5 sum (from libsensor-msgs-dev), else
// the topic is refused when chosen. Messages are ROS 1 serialized (decoded by io/cdr.hpp).
#pragma once

#include <filesystem>
#include <memory>

#include "io/bag_source.hpp"
#include "io/ros_messages.hpp"

namespace ovo::io::bag {

/// Opens a .bag. Throws ovo::Error naming the file when it is not a readable ROS 1 bag
/// (truncated, unindexed, corrupt chunk).
std::unique_ptr<BagSource> openRos1Bag(const std::filesystem::path& file);

/// The MD5 sum libsensor-msgs-dev gives the type (empty for another type, and in a build
/// without ROS 1 bags).
std::string ros1Md5Sum(ros::MsgType type);

/// false in a build without ROS 1 bags (CMake OVO_WITH_ROS1=OFF: io/rosbag1_absent.cpp), where
/// openRos1Bag and a ROS 1 BagWriter throw ovo::Error saying so.
bool ros1BagsBuilt();

}  // namespace ovo::io::bag
