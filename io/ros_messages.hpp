// The four sensor_msgs types ovo reads from bags (Image, CompressedImage, Imu, LaserScan), as
// plain structs independent of ROS 1 or ROS 2 and their wire formats (io/cdr.hpp decodes both),
// and their conversion into ovo's measurements (8-bit grey images, gyro samples, scans).
#pragma once

#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "common/types.hpp"

namespace ovo::io::ros {

/// The sensor_msgs types ovo knows; kOther for every other type.
enum class MsgType { kImage, kCompressedImage, kImu, kLaserScan, kOther };

/// "sensor_msgs/Imu" (ROS 1) and "sensor_msgs/msg/Imu" (ROS 2) are the same type.
MsgType msgTypeOf(std::string_view type_name);
/// "sensor_msgs/Imu" etc. (the ROS 1 spelling; for messages).
const char* msgTypeName(MsgType type);

/// std_msgs/Header. ROS 2's has no seq (0 here).
struct Header {
  std::uint32_t seq = 0;
  Timestamp stamp_ns = 0;
  std::string frame_id;
};

/// sensor_msgs/Image.
struct Image {
  Header header;
  std::uint32_t height = 0, width = 0;
  std::string encoding;  // mono8, rgb8, bgr8, mono16, ...
  std::uint8_t is_bigendian = 0;
  std::uint32_t step = 0;  // bytes per row
  std::vector<std::uint8_t> data;
};

/// sensor_msgs/CompressedImage.
struct CompressedImage {
  Header header;
  std::string format;  // "jpeg", "png", "rgb8; jpeg compressed bgr8", ...
  std::vector<std::uint8_t> data;
};

/// sensor_msgs/Imu (covariances row-major, as in the message).
struct Imu {
  Header header;
  std::array<double, 4> orientation_xyzw{0, 0, 0, 1};
  std::array<double, 9> orientation_covariance{};
  Vec3 angular_velocity = Vec3::Zero();  // [rad/s]
  std::array<double, 9> angular_velocity_covariance{};
  Vec3 linear_acceleration = Vec3::Zero();  // [m/s^2]
  std::array<double, 9> linear_acceleration_covariance{};
};

/// sensor_msgs/LaserScan (float32 fields widened to double exactly).
struct LaserScan {
  Header header;
  double angle_min = 0, angle_max = 0, angle_increment = 0;  // [rad]
  double time_increment = 0;                                 // [s] between beams
  double scan_time = 0;                                      // [s] between scans
  double range_min = 0, range_max = 0;                       // [m]
  std::vector<float> ranges;
  std::vector<float> intensities;
};

/// The image as 8-bit grey: mono8/8UC1 as they are, rgb8/bgr8/rgba8/bgra8 (and 8UC3 as bgr8)
/// converted, mono16/16UC1 (either byte order) scaled by 1/256. Throws ovo::Error naming `where`
/// for another encoding or when step/data do not hold height x width pixels.
cv::Mat greyImage(const Image& image, const std::string& where);
/// The compressed image decoded by OpenCV (PNG, JPEG, ...) as 8-bit grey; throws naming `where`.
cv::Mat greyImage(const CompressedImage& image, const std::string& where);

/// The gyro (and accelerometer) sample at `t_ns` (the header stamp, or the record time).
ImuSample imuSample(const Imu& imu, Timestamp t_ns);
/// The scan at `t_ns`: NaN/inf ranges become NaN (no return); time_increment kept. Throws naming
/// `where` for a zero or non-finite angle_increment or a bad range interval.
LidarScan lidarScan(const LaserScan& scan, Timestamp t_ns, const std::string& where);

/// The scan with every value rounded to float32, as a LaserScan message carries it: `ovo simulate`
/// rounds its scans so that a folder and a bag of the same run hold the same numbers.
void roundToLaserScan(LidarScan& scan);

/// The messages ovo writes into bags (ovo simulate --format, ovo convert's round trip).
Image imageMessage(const cv::Mat& grey8, Timestamp t_ns, const std::string& frame_id);
Imu imuMessage(const ImuSample& sample, const std::string& frame_id);
/// scan_time: the time between scans [s]. Values are stored as float32 (the message's type).
LaserScan laserScanMessage(const LidarScan& scan, double scan_time_s, const std::string& frame_id);

}  // namespace ovo::io::ros
