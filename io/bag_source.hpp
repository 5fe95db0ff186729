// A recorded bag as a list of topics and messages, whatever stores it: a ROS 1 .bag
// (io/rosbag1_reader), rosbag2's sqlite3 .db3 or an MCAP file (io/rosbag2_reader). Opening lists
// every message (topic, record time, where it is); payload() fetches one message's serialized
// bytes on demand, so images are read only when they are used.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "common/types.hpp"

namespace ovo::io::bag {

struct Topic {
  std::string name;
  std::string type;         // "sensor_msgs/Imu" (ROS 1) or "sensor_msgs/msg/Imu" (ROS 2)
  std::string encoding;     // "ros1" or "cdr" (MCAP message_encoding, rosbag2 serialization)
  std::string md5;          // ROS 1 only: the type's MD5 sum from the connection header
  std::uint64_t count = 0;  // messages in the bag (a topic may have none)
};

/// One message: its topic, record time and where its bytes are (reader-specific).
struct MessageRef {
  std::uint32_t topic = 0;  // index into BagSource::topics()
  Timestamp log_time_ns = 0;
  std::uint64_t offset = 0;  // reader-specific: row id, offset, index
  std::uint32_t block = 0;   // reader-specific: file or chunk number
};

class BagSource {
 public:
  virtual ~BagSource() = default;
  /// What was opened: the file (or rosbag2 folder) and its kind ("ROS 1 bag", "rosbag2 sqlite3",
  /// "MCAP").
  const std::filesystem::path& path() const { return path_; }
  const std::string& kind() const { return kind_; }
  const std::vector<Topic>& topics() const { return topics_; }
  /// Every message, sorted by record time (stable: the file's order among equal times).
  const std::vector<MessageRef>& messages() const { return messages_; }
  /// The message's serialized bytes. Thread-safe. Throws ovo::Error naming the file on a read
  /// or decompression failure.
  virtual std::vector<std::uint8_t> payload(const MessageRef& ref) const = 0;
  /// "file: topic /x, message 12 (t = ... s)" for error messages.
  std::string describe(const MessageRef& ref, std::size_t index_in_topic) const;

 protected:
  BagSource(std::filesystem::path path, std::string kind)
      : path_(std::move(path)), kind_(std::move(kind)) {}
  /// Sorts messages_ by record time and fills each topic's count.
  void finishListing();

  std::filesystem::path path_;
  std::string kind_;
  std::vector<Topic> topics_;
  std::vector<MessageRef> messages_;
};

/// True when `path` is a bag ovo can open: a .bag, .db3 or .mcap file, or a folder holding a
/// rosbag2 metadata.yaml.
bool isBagPath(const std::filesystem::path& path);
/// Opens a bag by its file name (.bag, .db3, .mcap) or a rosbag2 folder (metadata.yaml and the
/// files it lists). Throws ovo::Error naming the file on anything unreadable.
std::unique_ptr<BagSource> openBag(const std::filesystem::path& path);

}  // namespace ovo::io::bag
