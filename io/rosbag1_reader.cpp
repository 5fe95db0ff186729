#include "io/rosbag1_reader.hpp"

#include <ros/serialization.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/LaserScan.h>

#include <map>
#include <mutex>

#include "common/error.hpp"
#include "io/rosbag1_check.hpp"

namespace ovo::io::bag {

namespace fs = std::filesystem;

bool ros1BagsBuilt() { return true; }

std::string ros1Md5Sum(ros::MsgType type) {
  using ::ros::message_traits::MD5Sum;
  switch (type) {
    case ros::MsgType::kImage:
      return MD5Sum<sensor_msgs::Image>::value();
    case ros::MsgType::kCompressedImage:
      return MD5Sum<sensor_msgs::CompressedImage>::value();
    case ros::MsgType::kImu:
      return MD5Sum<sensor_msgs::Imu>::value();
    case ros::MsgType::kLaserScan:
      return MD5Sum<sensor_msgs::LaserScan>::value();
    case ros::MsgType::kOther:
      break;
  }
  return "";
}

namespace {

class Ros1Bag : public BagSource {
 public:
  explicit Ros1Bag(const fs::path& file) : BagSource(file, "ROS 1 bag") {
    // librosbag trusts the lengths inside the file (a corrupt record header makes it read out of
    // bounds), so the structure is checked first: every length, chunk and index entry.
    checkRos1BagStructure(file);
    try {
      bag_.open(file.string(), rosbag::bagmode::Read);
      rosbag::View view(bag_);
      std::map<std::string, std::uint32_t> by_name;
      std::map<const rosbag::ConnectionInfo*, std::uint32_t> topic_of;
      for (const rosbag::ConnectionInfo* c : view.getConnections()) {
        auto it = by_name.find(c->topic);
        if (it == by_name.end()) {
          topics_.push_back({c->topic, c->datatype, "ros1", c->md5sum, 0});
          it = by_name.emplace(c->topic, static_cast<std::uint32_t>(topics_.size() - 1)).first;
        } else if (topics_[it->second].type != c->datatype ||
                   topics_[it->second].md5 != c->md5sum) {
          fail("{}: topic {} has connections of two types, {} and {}: expected one type a topic",
               file.string(), c->topic, topics_[it->second].type, c->datatype);
        }
        topic_of[c] = it->second;
      }
      instances_.reserve(view.size());
      for (const rosbag::MessageInstance& m : view) {
        MessageRef ref;
        ref.topic = by_name.at(m.getTopic());
        ref.log_time_ns = static_cast<Timestamp>(m.getTime().toNSec());
        ref.offset = instances_.size();
        messages_.push_back(ref);
        instances_.push_back(m);
      }
    } catch (const ovo::Error&) {
      throw;
    } catch (const std::exception& e) {
      fail("{}: librosbag cannot read it: {} (expected a ROS 1 bag, format 2.0)", file.string(),
           e.what());
    }
    finishListing();
  }

  std::vector<std::uint8_t> payload(const MessageRef& ref) const override {
    std::lock_guard lock(mutex_);
    const rosbag::MessageInstance& m = instances_.at(ref.offset);
    try {
      std::vector<std::uint8_t> bytes(m.size());
      ::ros::serialization::OStream stream(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
      m.write(stream);
      return bytes;
    } catch (const std::exception& e) {
      fail("{}: cannot read message {} on {}: {}", path_.string(), ref.offset, m.getTopic(),
           e.what());
    }
  }

 private:
  rosbag::Bag bag_;
  std::vector<rosbag::MessageInstance> instances_;
  mutable std::mutex mutex_;  // rosbag::Bag keeps one decompressed chunk: not thread-safe
};

}  // namespace

std::unique_ptr<BagSource> openRos1Bag(const fs::path& file) {
  return std::make_unique<Ros1Bag>(file);
}

}  // namespace ovo::io::bag
