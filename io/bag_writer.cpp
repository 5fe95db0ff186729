#include "io/bag_writer.hpp"

#include "common/error.hpp"

namespace ovo::io {

namespace fs = std::filesystem;

// In io/rosbag1_writer.cpp and io/rosbag2_writer.cpp.
std::unique_ptr<BagWriter> makeRos1BagWriter(const fs::path& path, const std::string& compression);
std::unique_ptr<BagWriter> makeSqlite3BagWriter(const fs::path& folder);
std::unique_ptr<BagWriter> makeMcapBagWriter(const fs::path& file, const std::string& compression);

BagFormat parseBagFormat(const std::string& name) {
  if (name == "rosbag" || name == "ros1" || name == "bag") return BagFormat::kRos1;
  if (name == "db3" || name == "sqlite3") return BagFormat::kSqlite3;
  if (name == "mcap") return BagFormat::kMcap;
  fail("bag format '{}': expected rosbag (ROS 1), db3 (rosbag2 sqlite3) or mcap", name);
}

fs::path bagPathIn(const fs::path& dir, const std::string& stem, BagFormat format) {
  switch (format) {
    case BagFormat::kRos1:
      return dir / (stem + ".bag");
    case BagFormat::kSqlite3:
      return dir / stem;
    case BagFormat::kMcap:
      return dir / (stem + ".mcap");
  }
  return dir / stem;
}

std::unique_ptr<BagWriter> BagWriter::create(BagFormat format, const fs::path& path,
                                             const std::string& compression) {
  switch (format) {
    case BagFormat::kRos1:
      return makeRos1BagWriter(path, compression);
    case BagFormat::kSqlite3:
      return makeSqlite3BagWriter(path);
    case BagFormat::kMcap:
      return makeMcapBagWriter(path, compression);
  }
  fail("BagWriter::create: unknown format");
}

}  // namespace ovo::io
