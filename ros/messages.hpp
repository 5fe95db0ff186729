// ROS 1 messages to and from ovo's public API (api/ovo.hpp): the node's conversions, kept apart
// from its wiring so that a ROS 2 node would swap only these types. No estimation here.
#pragma once

#include <diagnostic_msgs/DiagnosticStatus.h>
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/LaserScan.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "api/ovo.hpp"

namespace ovo::ros1 {

/// A header stamp in nanoseconds; nullopt for a zero stamp (a driver that does not stamp: ovo
/// needs the sensors' own times, not the arrival times).
std::optional<std::int64_t> stampNs(const ros::Time& stamp);
ros::Time rosTime(std::int64_t t_ns);

/// The image as 8-bit grey or BGR (mono8, 8UC1, mono16, 16UC1, bgr8, rgb8, bgra8, rgba8; a
/// CompressedImage in any format OpenCV decodes). Throws std::runtime_error naming the encoding or
/// the size when it cannot: the node counts the message as malformed.
cv::Mat imageFromMessage(const sensor_msgs::Image& msg);
cv::Mat imageFromMessage(const sensor_msgs::CompressedImage& msg);

/// The gyro and, unless linear_acceleration_covariance[0] is -1 (REP 145: no accelerometer), the
/// accelerometer.
GyroSample gyroFromMessage(const sensor_msgs::Imu& msg, std::int64_t t_ns);
Scan scanFromMessage(const sensor_msgs::LaserScan& msg, std::int64_t t_ns);

struct Frames {
  std::string odom = "odom", base = "base_link";
};
nav_msgs::Odometry odometryMessage(const Pose& pose, const Frames& frames);
geometry_msgs::TransformStamped transformMessage(const Pose& pose, const Frames& frames);
geometry_msgs::PoseStamped poseMessage(const Pose& pose, const Frames& frames);
/// A sensor's place on the robot (Odometry::cameraInBody, lidarInBody) as a static transform from
/// the base frame to the sensor's frame_id.
geometry_msgs::TransformStamped sensorTransform(const Pose& in_body, const std::string& base,
                                                const std::string& sensor_frame);

/// What the node saw of one input topic.
struct TopicHealth {
  std::string name;      // the topic
  double silent_s = -1;  // wall time since its last message; < 0: none yet
  long received = 0;     // messages
  long malformed = 0;    // messages that could not be read (bad encoding, size, zero stamp)
};

/// The node's diagnostic: ovo's Status, the topics' health and the frames dropped since the last
/// report. ERROR when processing stopped, WARN when not tracking, a topic has been silent for
/// silent_after_s or more, or frames were dropped since the last report; else OK.
diagnostic_msgs::DiagnosticStatus diagnosticStatus(const Status& status,
                                                   const std::vector<TopicHealth>& topics,
                                                   int dropped_since_last, double silent_after_s);

}  // namespace ovo::ros1
