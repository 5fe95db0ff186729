// The ROS 1 BagWriter (io/bag_writer.hpp): sensor_msgs messages written through librosbag.
#include <rosbag/bag.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/LaserScan.h>

#include "common/error.hpp"
#include "io/bag_writer.hpp"

namespace ovo::io {

namespace {

template <typename RosHeader>
void fillHeader(RosHeader& h, const ros::Header& m) {
  h.seq = m.seq;
  h.stamp.fromNSec(static_cast<std::uint64_t>(m.stamp_ns));
  h.frame_id = m.frame_id;
}

class Ros1Writer : public BagWriter {
 public:
  Ros1Writer(const std::filesystem::path& path, const std::string& compression) : path_(path) {
    try {
      bag_.open(path.string(), rosbag::bagmode::Write);
      if (compression == "bz2")
        bag_.setCompression(rosbag::compression::BZ2);
      else if (compression == "lz4")
        bag_.setCompression(rosbag::compression::LZ4);
      else if (!compression.empty() && compression != "none")
        fail("{}: ROS 1 bag compression '{}' (expected none, bz2 or lz4)", path.string(),
             compression);
    } catch (const ovo::Error&) {
      throw;
    } catch (const std::exception& e) {
      fail("{}: cannot create the bag: {}", path.string(), e.what());
    }
  }
  ~Ros1Writer() override {
    try {
      bag_.close();
    } catch (...) {
    }
  }

  void write(const std::string& topic, const ros::Image& m) override {
    sensor_msgs::Image msg;
    fillHeader(msg.header, m.header);
    msg.height = m.height;
    msg.width = m.width;
    msg.encoding = m.encoding;
    msg.is_bigendian = m.is_bigendian;
    msg.step = m.step;
    msg.data = m.data;
    put(topic, m.header.stamp_ns, msg);
  }
  void write(const std::string& topic, const ros::CompressedImage& m) override {
    sensor_msgs::CompressedImage msg;
    fillHeader(msg.header, m.header);
    msg.format = m.format;
    msg.data = m.data;
    put(topic, m.header.stamp_ns, msg);
  }
  void write(const std::string& topic, const ros::Imu& m) override {
    sensor_msgs::Imu msg;
    fillHeader(msg.header, m.header);
    msg.orientation.x = m.orientation_xyzw[0];
    msg.orientation.y = m.orientation_xyzw[1];
    msg.orientation.z = m.orientation_xyzw[2];
    msg.orientation.w = m.orientation_xyzw[3];
    msg.angular_velocity.x = m.angular_velocity.x();
    msg.angular_velocity.y = m.angular_velocity.y();
    msg.angular_velocity.z = m.angular_velocity.z();
    msg.linear_acceleration.x = m.linear_acceleration.x();
    msg.linear_acceleration.y = m.linear_acceleration.y();
    msg.linear_acceleration.z = m.linear_acceleration.z();
    for (int i = 0; i < 9; ++i) {
      msg.orientation_covariance[i] = m.orientation_covariance[i];
      msg.angular_velocity_covariance[i] = m.angular_velocity_covariance[i];
      msg.linear_acceleration_covariance[i] = m.linear_acceleration_covariance[i];
    }
    put(topic, m.header.stamp_ns, msg);
  }
  void write(const std::string& topic, const ros::LaserScan& m) override {
    sensor_msgs::LaserScan msg;
    fillHeader(msg.header, m.header);
    msg.angle_min = static_cast<float>(m.angle_min);
    msg.angle_max = static_cast<float>(m.angle_max);
    msg.angle_increment = static_cast<float>(m.angle_increment);
    msg.time_increment = static_cast<float>(m.time_increment);
    msg.scan_time = static_cast<float>(m.scan_time);
    msg.range_min = static_cast<float>(m.range_min);
    msg.range_max = static_cast<float>(m.range_max);
    msg.ranges = m.ranges;
    msg.intensities = m.intensities;
    put(topic, m.header.stamp_ns, msg);
  }
  void close() override {
    try {
      bag_.close();
    } catch (const std::exception& e) {
      fail("{}: writing the bag failed: {}", path_.string(), e.what());
    }
  }

 private:
  template <typename Msg>
  void put(const std::string& topic, Timestamp t_ns, const Msg& msg) {
    if (t_ns < 0) fail("{}: cannot write a negative time stamp into a ROS 1 bag", path_.string());
    try {
      ::ros::Time t;
      t.fromNSec(static_cast<std::uint64_t>(t_ns));
      bag_.write(topic, t, msg);
    } catch (const std::exception& e) {
      fail("{}: writing {} failed: {}", path_.string(), topic, e.what());
    }
  }

  std::filesystem::path path_;
  rosbag::Bag bag_;
};

}  // namespace

std::unique_ptr<BagWriter> makeRos1BagWriter(const std::filesystem::path& path,
                                             const std::string& compression) {
  return std::make_unique<Ros1Writer>(path, compression);
}

}  // namespace ovo::io
