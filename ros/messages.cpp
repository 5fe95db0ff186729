#include "ros/messages.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>

namespace ovo::ros1 {

std::optional<std::int64_t> stampNs(const ros::Time& stamp) {
  if (stamp.isZero()) return std::nullopt;
  return static_cast<std::int64_t>(stamp.toNSec());
}

ros::Time rosTime(std::int64_t t_ns) {
  ros::Time t;
  t.fromNSec(static_cast<std::uint64_t>(std::max<std::int64_t>(t_ns, 0)));
  return t;
}

cv::Mat imageFromMessage(const sensor_msgs::Image& msg) {
  struct Layout {
    int type;
    int channels;
    bool rgb;  // channel order R, G, B: swapped to OpenCV's B, G, R
  };
  const std::string& e = msg.encoding;
  Layout layout{};
  if (e == "mono8" || e == "8UC1")
    layout = {CV_8UC1, 1, false};
  else if (e == "mono16" || e == "16UC1")
    layout = {CV_16UC1, 1, false};
  else if (e == "bgr8" || e == "8UC3")
    layout = {CV_8UC3, 3, false};
  else if (e == "rgb8")
    layout = {CV_8UC3, 3, true};
  else if (e == "bgra8" || e == "8UC4")
    layout = {CV_8UC4, 4, false};
  else if (e == "rgba8")
    layout = {CV_8UC4, 4, true};
  else
    throw std::runtime_error("image encoding '" + e +
                             "' is not supported (expected mono8, mono16, bgr8, rgb8, bgra8, "
                             "rgba8 or a CompressedImage)");
  const std::size_t pixel_bytes = CV_ELEM_SIZE(layout.type);
  if (msg.width == 0 || msg.height == 0 || msg.step < msg.width * pixel_bytes ||
      msg.data.size() < static_cast<std::size_t>(msg.step) * msg.height) {
    std::ostringstream what;
    what << "image of " << msg.width << "x" << msg.height << " " << e << " has step " << msg.step
         << " and " << msg.data.size() << " bytes (expected at least width x " << pixel_bytes
         << " a row and step x height)";
    throw std::runtime_error(what.str());
  }
  const cv::Mat view(static_cast<int>(msg.height), static_cast<int>(msg.width), layout.type,
                     const_cast<std::uint8_t*>(msg.data.data()), msg.step);
  cv::Mat out;
  if (layout.type == CV_16UC1) {
    // Big-endian 16-bit data is rare enough that it is refused rather than guessed at.
    if (msg.is_bigendian) throw std::runtime_error("big-endian mono16 images are not supported");
    view.convertTo(out, CV_8UC1, 1.0 / 256.0);
  } else if (layout.rgb) {
    cv::cvtColor(view, out, layout.channels == 3 ? cv::COLOR_RGB2BGR : cv::COLOR_RGBA2BGRA);
  } else {
    out = view.clone();
  }
  return out;
}

cv::Mat imageFromMessage(const sensor_msgs::CompressedImage& msg) {
  if (msg.data.empty()) throw std::runtime_error("compressed image has no data");
  const cv::Mat bytes(1, static_cast<int>(msg.data.size()), CV_8UC1,
                      const_cast<std::uint8_t*>(msg.data.data()));
  cv::Mat out = cv::imdecode(bytes, cv::IMREAD_GRAYSCALE);
  if (out.empty())
    throw std::runtime_error("compressed image (format '" + msg.format + "') could not be decoded");
  return out;
}

GyroSample gyroFromMessage(const sensor_msgs::Imu& msg, std::int64_t t_ns) {
  GyroSample s;
  s.t_ns = t_ns;
  s.wx = msg.angular_velocity.x;
  s.wy = msg.angular_velocity.y;
  s.wz = msg.angular_velocity.z;
  if (msg.linear_acceleration_covariance[0] != -1.0) {
    s.ax = msg.linear_acceleration.x;
    s.ay = msg.linear_acceleration.y;
    s.az = msg.linear_acceleration.z;
  }
  return s;
}

Scan scanFromMessage(const sensor_msgs::LaserScan& msg, std::int64_t t_ns) {
  Scan s;
  s.t_ns = t_ns;
  s.angle_min_rad = msg.angle_min;
  s.angle_increment_rad = msg.angle_increment;
  s.range_min_m = msg.range_min;
  s.range_max_m = msg.range_max;
  s.time_increment_s = msg.time_increment;
  s.ranges_m = msg.ranges;
  return s;
}

namespace {

geometry_msgs::Pose poseOf(const Pose& p) {
  geometry_msgs::Pose out;
  out.position.x = p.position_m[0];
  out.position.y = p.position_m[1];
  out.position.z = p.position_m[2];
  out.orientation.x = p.orientation_xyzw[0];
  out.orientation.y = p.orientation_xyzw[1];
  out.orientation.z = p.orientation_xyzw[2];
  out.orientation.w = p.orientation_xyzw[3];
  return out;
}

}  // namespace

nav_msgs::Odometry odometryMessage(const Pose& pose, const Frames& frames) {
  nav_msgs::Odometry msg;
  msg.header.stamp = rosTime(pose.t_gyro_clock_ns);
  msg.header.frame_id = frames.odom;
  msg.child_frame_id = frames.base;
  msg.pose.pose = poseOf(pose);
  msg.twist.twist.linear.x = pose.velocity_body_mps[0];
  msg.twist.twist.linear.y = pose.velocity_body_mps[1];
  msg.twist.twist.linear.z = pose.velocity_body_mps[2];
  msg.twist.twist.angular.x = pose.angular_velocity_body_radps[0];
  msg.twist.twist.angular.y = pose.angular_velocity_body_radps[1];
  msg.twist.twist.angular.z = pose.angular_velocity_body_radps[2];
  // ovo gives no calibrated covariance yet (the window's is overconfident in position): the
  // covariances stay zero, which nav_msgs/Odometry's users read as "not given".
  return msg;
}

geometry_msgs::TransformStamped transformMessage(const Pose& pose, const Frames& frames) {
  geometry_msgs::TransformStamped msg;
  msg.header.stamp = rosTime(pose.t_gyro_clock_ns);
  msg.header.frame_id = frames.odom;
  msg.child_frame_id = frames.base;
  const geometry_msgs::Pose p = poseOf(pose);
  msg.transform.translation.x = p.position.x;
  msg.transform.translation.y = p.position.y;
  msg.transform.translation.z = p.position.z;
  msg.transform.rotation = p.orientation;
  return msg;
}

geometry_msgs::PoseStamped poseMessage(const Pose& pose, const Frames& frames) {
  geometry_msgs::PoseStamped msg;
  msg.header.stamp = rosTime(pose.t_gyro_clock_ns);
  msg.header.frame_id = frames.odom;
  msg.pose = poseOf(pose);
  return msg;
}

geometry_msgs::TransformStamped sensorTransform(const Pose& in_body, const std::string& base,
                                                const std::string& sensor_frame) {
  geometry_msgs::TransformStamped msg = transformMessage(in_body, {base, sensor_frame});
  msg.header.stamp = ros::Time(0);  // static: valid at every time
  return msg;
}

namespace {

diagnostic_msgs::KeyValue keyValue(const std::string& key, const std::string& value) {
  diagnostic_msgs::KeyValue kv;
  kv.key = key;
  kv.value = value;
  return kv;
}

std::string number(double x, int decimals) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(decimals);
  s << x;
  return s.str();
}

}  // namespace

diagnostic_msgs::DiagnosticStatus diagnosticStatus(const Status& status,
                                                   const std::vector<TopicHealth>& topics,
                                                   int dropped_since_last, double silent_after_s) {
  diagnostic_msgs::DiagnosticStatus d;
  d.name = "ovo: odometry";
  d.hardware_id = "ovo";
  std::vector<std::string> warnings;
  for (const TopicHealth& t : topics)
    if (t.silent_s >= silent_after_s)
      warnings.push_back("no message on " + t.name + " for " + number(t.silent_s, 1) + " s");
  if (dropped_since_last > 0)
    warnings.push_back(std::to_string(dropped_since_last) +
                       " frames dropped since the last report (processing behind)");
  if (!status.tracking && status.frames_processed > 0)
    warnings.push_back("not tracking" +
                       (status.reason.empty() ? std::string() : ": " + status.reason));
  if (!status.error.empty()) {
    d.level = diagnostic_msgs::DiagnosticStatus::ERROR;
    d.message = "processing stopped: " + status.error;
  } else if (!warnings.empty()) {
    d.level = diagnostic_msgs::DiagnosticStatus::WARN;
    for (std::size_t i = 0; i < warnings.size(); ++i) d.message += (i ? "; " : "") + warnings[i];
  } else {
    d.level = diagnostic_msgs::DiagnosticStatus::OK;
    d.message = status.frames_processed > 0 ? "tracking" : "waiting for images";
  }
  d.values.push_back(keyValue("tracking", status.tracking ? "true" : "false"));
  d.values.push_back(keyValue("frames_processed", std::to_string(status.frames_processed)));
  d.values.push_back(keyValue("frames_dropped", std::to_string(status.frames_dropped)));
  d.values.push_back(keyValue("measurements_refused", std::to_string(status.refused)));
  d.values.push_back(keyValue("tracking_losses", std::to_string(status.tracking_losses)));
  d.values.push_back(keyValue("frame_ms", number(status.frame_ms, 1)));
  d.values.push_back(keyValue("solve_ms", number(status.solve_ms, 1)));
  d.values.push_back(keyValue("solve_failures", std::to_string(status.solve_failures)));
  d.values.push_back(keyValue("time_offset_s", number(status.time_offset_s, 6)));
  d.values.push_back(
      keyValue("time_offset_estimated", status.time_offset_estimated ? "true" : "false"));
  for (const TopicHealth& t : topics) {
    d.values.push_back(keyValue(t.name + " received", std::to_string(t.received)));
    d.values.push_back(keyValue(t.name + " malformed", std::to_string(t.malformed)));
    d.values.push_back(
        keyValue(t.name + " silent_s", t.silent_s < 0 ? "never heard" : number(t.silent_s, 2)));
  }
  return d;
}

}  // namespace ovo::ros1
