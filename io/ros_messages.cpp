#include "io/ros_messages.hpp"

#include <bit>
#include <cmath>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/error.hpp"

namespace ovo::io::ros {

MsgType msgTypeOf(std::string_view name) {
  if (name == "sensor_msgs/Image" || name == "sensor_msgs/msg/Image") return MsgType::kImage;
  if (name == "sensor_msgs/CompressedImage" || name == "sensor_msgs/msg/CompressedImage")
    return MsgType::kCompressedImage;
  if (name == "sensor_msgs/Imu" || name == "sensor_msgs/msg/Imu") return MsgType::kImu;
  if (name == "sensor_msgs/LaserScan" || name == "sensor_msgs/msg/LaserScan")
    return MsgType::kLaserScan;
  return MsgType::kOther;
}

const char* msgTypeName(MsgType type) {
  switch (type) {
    case MsgType::kImage:
      return "sensor_msgs/Image";
    case MsgType::kCompressedImage:
      return "sensor_msgs/CompressedImage";
    case MsgType::kImu:
      return "sensor_msgs/Imu";
    case MsgType::kLaserScan:
      return "sensor_msgs/LaserScan";
    case MsgType::kOther:
      break;
  }
  return "another type";
}

namespace {

struct EncodingInfo {
  int cv_type;
  int channels;
  int bytes_per_channel;
  int to_grey;  // cv::ColorConversionCodes, or -1
};

bool encodingInfo(const std::string& e, EncodingInfo* info) {
  if (e == "mono8" || e == "8UC1")
    *info = {CV_8UC1, 1, 1, -1};
  else if (e == "rgb8")
    *info = {CV_8UC3, 3, 1, cv::COLOR_RGB2GRAY};
  else if (e == "bgr8" || e == "8UC3")
    *info = {CV_8UC3, 3, 1, cv::COLOR_BGR2GRAY};
  else if (e == "rgba8")
    *info = {CV_8UC4, 4, 1, cv::COLOR_RGBA2GRAY};
  else if (e == "bgra8" || e == "8UC4")
    *info = {CV_8UC4, 4, 1, cv::COLOR_BGRA2GRAY};
  else if (e == "mono16" || e == "16UC1")
    *info = {CV_16UC1, 1, 2, -1};
  else
    return false;
  return true;
}

}  // namespace

cv::Mat greyImage(const Image& image, const std::string& where) {
  EncodingInfo info{};
  if (!encodingInfo(image.encoding, &info))
    fail(
        "{}: image encoding '{}' is not supported (expected mono8, 8UC1, rgb8, bgr8, rgba8, "
        "bgra8, mono16 or 16UC1)",
        where, image.encoding);
  if (image.width == 0 || image.height == 0 || image.width > 100000 || image.height > 100000)
    fail("{}: image size {}x{}: expected 1 to 100000 pixels a side", where, image.width,
         image.height);
  const std::uint64_t row_bytes =
      std::uint64_t{image.width} *
      static_cast<std::uint64_t>(info.channels * info.bytes_per_channel);
  if (image.step < row_bytes)
    fail("{}: step {} bytes is less than a row of {} {} pixels ({} bytes)", where, image.step,
         image.width, image.encoding, row_bytes);
  const std::uint64_t needed = std::uint64_t{image.step} * (image.height - 1) + row_bytes;
  if (image.data.size() < needed)
    fail("{}: {} bytes of pixel data, expected at least {} for {}x{} {} with step {}", where,
         image.data.size(), needed, image.width, image.height, image.encoding, image.step);
  // A view of the message's bytes (OpenCV does not write through it), then a copy or conversion.
  const cv::Mat view(static_cast<int>(image.height), static_cast<int>(image.width), info.cv_type,
                     const_cast<std::uint8_t*>(image.data.data()), image.step);
  cv::Mat grey;
  if (info.bytes_per_channel == 2) {
    cv::Mat native = view.clone();
    const bool host_big = std::endian::native == std::endian::big;
    if ((image.is_bigendian != 0) != host_big)
      for (int r = 0; r < native.rows; ++r) {
        auto* p = native.ptr<std::uint16_t>(r);
        for (int c = 0; c < native.cols; ++c)
          p[c] = static_cast<std::uint16_t>((p[c] >> 8) | (p[c] << 8));
      }
    native.convertTo(grey, CV_8U, 1.0 / 256.0);
  } else if (info.to_grey >= 0) {
    cv::cvtColor(view, grey, info.to_grey);
  } else {
    grey = view.clone();
  }
  return grey;
}

cv::Mat greyImage(const CompressedImage& image, const std::string& where) {
  if (image.data.empty()) fail("{}: compressed image ('{}') has no data", where, image.format);
  const cv::Mat bytes(1, static_cast<int>(image.data.size()), CV_8UC1,
                      const_cast<std::uint8_t*>(image.data.data()));
  cv::Mat grey = cv::imdecode(bytes, cv::IMREAD_GRAYSCALE);
  if (grey.empty())
    fail("{}: cannot decode the compressed image (format '{}', {} bytes; expected PNG or JPEG)",
         where, image.format, image.data.size());
  return grey;
}

ImuSample imuSample(const Imu& imu, Timestamp t_ns) {
  ImuSample s;
  s.t_ns = t_ns;
  s.gyro_radps = imu.angular_velocity;
  s.accel_mps2 = imu.linear_acceleration;
  return s;
}

LidarScan lidarScan(const LaserScan& scan, Timestamp t_ns, const std::string& where) {
  if (!(std::isfinite(scan.angle_increment) && scan.angle_increment != 0.0))
    fail("{}: angle_increment {} rad: expected a finite non-zero number", where,
         scan.angle_increment);
  if (!std::isfinite(scan.angle_min))
    fail("{}: angle_min {} rad: expected a finite number", where, scan.angle_min);
  if (!(scan.range_min >= 0.0 && scan.range_min < scan.range_max))
    fail("{}: expected 0 <= range_min < range_max, got {} and {} m", where, scan.range_min,
         scan.range_max);
  if (!(std::isfinite(scan.time_increment) && std::abs(scan.time_increment) < 1.0))
    fail("{}: time_increment {} s: expected a finite time between beams under 1 s", where,
         scan.time_increment);
  if (scan.ranges.empty()) fail("{}: the scan has no ranges", where);
  LidarScan s;
  s.t_ns = t_ns;
  s.angle_min_rad = scan.angle_min;
  s.angle_increment_rad = scan.angle_increment;
  s.range_min_m = scan.range_min;
  s.range_max_m = std::isfinite(scan.range_max) ? scan.range_max : 1e9;
  s.time_increment_s = scan.time_increment;
  s.ranges_m.reserve(scan.ranges.size());
  for (float r : scan.ranges)
    s.ranges_m.push_back(std::isfinite(r) ? static_cast<double>(r)
                                          : std::numeric_limits<double>::quiet_NaN());
  return s;
}

void roundToLaserScan(LidarScan& scan) {
  auto f32 = [](double& v) { v = static_cast<double>(static_cast<float>(v)); };
  f32(scan.angle_min_rad);
  f32(scan.angle_increment_rad);
  f32(scan.range_min_m);
  f32(scan.range_max_m);
  f32(scan.time_increment_s);
  for (double& r : scan.ranges_m) f32(r);
}

Image imageMessage(const cv::Mat& grey8, Timestamp t_ns, const std::string& frame_id) {
  if (grey8.type() != CV_8UC1) fail("imageMessage: expected an 8-bit grey image");
  Image m;
  m.header.stamp_ns = t_ns;
  m.header.frame_id = frame_id;
  m.height = static_cast<std::uint32_t>(grey8.rows);
  m.width = static_cast<std::uint32_t>(grey8.cols);
  m.encoding = "mono8";
  m.step = m.width;
  m.data.resize(std::size_t{m.width} * m.height);
  for (int r = 0; r < grey8.rows; ++r)
    std::copy(grey8.ptr<std::uint8_t>(r), grey8.ptr<std::uint8_t>(r) + grey8.cols,
              m.data.begin() + static_cast<std::ptrdiff_t>(std::size_t{m.step} * r));
  return m;
}

Imu imuMessage(const ImuSample& sample, const std::string& frame_id) {
  Imu m;
  m.header.stamp_ns = sample.t_ns;
  m.header.frame_id = frame_id;
  m.orientation_covariance[0] = -1.0;  // REP 145: no orientation estimate
  m.angular_velocity = sample.gyro_radps;
  m.linear_acceleration = sample.accel_mps2;
  return m;
}

LaserScan laserScanMessage(const LidarScan& scan, double scan_time_s, const std::string& frame_id) {
  auto f32 = [](double v) { return static_cast<double>(static_cast<float>(v)); };
  LaserScan m;
  m.header.stamp_ns = scan.t_ns;
  m.header.frame_id = frame_id;
  m.angle_min = f32(scan.angle_min_rad);
  m.angle_increment = f32(scan.angle_increment_rad);
  m.angle_max = f32(scan.angle(scan.ranges_m.empty() ? 0 : scan.ranges_m.size() - 1));
  m.time_increment = f32(scan.time_increment_s);
  m.scan_time = f32(scan_time_s);
  m.range_min = f32(scan.range_min_m);
  m.range_max = f32(scan.range_max_m);
  m.ranges.reserve(scan.ranges_m.size());
  for (double r : scan.ranges_m)
    m.ranges.push_back(r == r ? static_cast<float>(r) : std::numeric_limits<float>::quiet_NaN());
  return m;
}

}  // namespace ovo::io::ros
