// ROS 1 bags in a build without Debian's librosbag-storage-dev (CMake OVO_WITH_ROS1=OFF; Debian 12
// does not build it for arm64): compiled instead of io/rosbag1_reader.cpp and rosbag1_writer.cpp.
// A .bag is refused with an error naming the file and the reason; rosbag2 (.db3, folders) and MCAP
// read and write as in every build.
#include <filesystem>
#include <memory>
#include <string>

#include "common/error.hpp"
#include "io/bag_writer.hpp"
#include "io/rosbag1_reader.hpp"

namespace ovo::io {
namespace bag {

bool ros1BagsBuilt() { return false; }

std::string ros1Md5Sum(ros::MsgType) { return {}; }

std::unique_ptr<BagSource> openRos1Bag(const std::filesystem::path& file) {
  fail(
      "{}: this ovo was built without ROS 1 bags (CMake OVO_WITH_ROS1=OFF); convert the bag to "
      "rosbag2 (.db3) or MCAP where ovo has them (ovo convert --format mcap)",
      file.string());
}

}  // namespace bag

std::unique_ptr<BagWriter> makeRos1BagWriter(const std::filesystem::path& path,
                                             const std::string& /*compression*/) {
  fail(
      "{}: this ovo was built without ROS 1 bags (CMake OVO_WITH_ROS1=OFF); write rosbag2 (db3) "
      "or MCAP instead (--format db3|mcap)",
      path.string());
}

}  // namespace ovo::io
