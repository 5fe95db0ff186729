#include "io/bag_source.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "common/error.hpp"
#include "io/rosbag1_reader.hpp"
#include "io/rosbag2_reader.hpp"

namespace ovo::io::bag {

namespace fs = std::filesystem;

void BagSource::finishListing() {
  std::stable_sort(
      messages_.begin(), messages_.end(),
      [](const MessageRef& a, const MessageRef& b) { return a.log_time_ns < b.log_time_ns; });
  for (Topic& t : topics_) t.count = 0;
  for (const MessageRef& m : messages_) ++topics_.at(m.topic).count;
}

std::string BagSource::describe(const MessageRef& ref, std::size_t index_in_topic) const {
  return fmt::format("{}: topic {}, message {} (record time {:.9f} s)", path_.string(),
                     topics_.at(ref.topic).name, index_in_topic, toSeconds(ref.log_time_ns));
}

bool isBagPath(const fs::path& path) {
  if (fs::is_directory(path)) return fs::is_regular_file(path / "metadata.yaml");
  const std::string ext = path.extension().string();
  return ext == ".bag" || ext == ".db3" || ext == ".mcap";
}

std::unique_ptr<BagSource> openBag(const fs::path& path) {
  if (fs::is_directory(path)) {
    if (!fs::is_regular_file(path / "metadata.yaml"))
      fail("{}: not a rosbag2 folder (expected metadata.yaml in it)", path.string());
    return openRosbag2Folder(path);
  }
  if (!fs::exists(path)) fail("{}: bag file not found", path.string());
  const std::string ext = path.extension().string();
  if (ext == ".bag") return openRos1Bag(path);
  if (ext == ".db3") return openSqlite3Bag(path);
  if (ext == ".mcap") return openMcapBag(path);
  fail("{}: not a bag ovo reads (expected a .bag, .db3 or .mcap file, or a rosbag2 folder)",
       path.string());
}

}  // namespace ovo::io::bag
