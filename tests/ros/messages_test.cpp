// The ROS node's conversions (ros/messages.*): images of every supported encoding to what ovo takes
// (rgb swapped to bgr, 16-bit scaled), malformed images refused with the reason, the IMU's
// accelerometer dropped when the message says it has none (REP 145), the odometry's frames, stamp
// and twist, the static sensor transform, and the diagnostic's level for each state.
#include "ros/messages.hpp"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

namespace ovo::ros1 {
namespace {

sensor_msgs::Image image(const std::string& encoding, int width, int height, int channels,
                         int bytes_per_channel = 1) {
  sensor_msgs::Image m;
  m.encoding = encoding;
  m.width = width;
  m.height = height;
  m.step = width * channels * bytes_per_channel;
  m.data.assign(m.step * height, 0);
  return m;
}

TEST(RosMessages, ImagesOfEachEncodingComeOutAsOvoTakesThem) {
  sensor_msgs::Image rgb = image("rgb8", 4, 2, 3);
  rgb.data[0] = 200;  // pixel (0, 0): red
  const cv::Mat bgr = imageFromMessage(rgb);
  ASSERT_EQ(bgr.type(), CV_8UC3);
  EXPECT_EQ(bgr.at<cv::Vec3b>(0, 0)[2], 200);  // red is OpenCV's third channel
  EXPECT_EQ(bgr.at<cv::Vec3b>(0, 0)[0], 0);

  sensor_msgs::Image mono16 = image("mono16", 3, 2, 1, 2);
  mono16.data[0] = 0x00;  // little-endian 0x8000
  mono16.data[1] = 0x80;
  const cv::Mat grey = imageFromMessage(mono16);
  ASSERT_EQ(grey.type(), CV_8UC1);
  EXPECT_EQ(grey.at<std::uint8_t>(0, 0), 128);

  // A padded row (step beyond the width) is read by its step.
  sensor_msgs::Image padded = image("mono8", 3, 2, 1);
  padded.step = 8;
  padded.data.assign(16, 0);
  padded.data[8] = 77;  // row 1, column 0
  EXPECT_EQ(imageFromMessage(padded).at<std::uint8_t>(1, 0), 77);

  EXPECT_EQ(imageFromMessage(image("bgra8", 2, 2, 4)).type(), CV_8UC4);
  EXPECT_EQ(imageFromMessage(image("rgba8", 2, 2, 4)).type(), CV_8UC4);
}

TEST(RosMessages, AnImageOvoCannotUseIsRefusedWithTheReason) {
  const auto reason = [](const auto& msg) {
    try {
      imageFromMessage(msg);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("(taken)");
  };
  EXPECT_NE(reason(image("bayer_rggb8", 4, 4, 1)).find("bayer_rggb8"), std::string::npos);
  sensor_msgs::Image short_data = image("mono8", 4, 4, 1);
  short_data.data.resize(10);
  EXPECT_NE(reason(short_data).find("10 bytes"), std::string::npos);
  sensor_msgs::Image big_endian = image("mono16", 2, 2, 1, 2);
  big_endian.is_bigendian = 1;
  EXPECT_NE(reason(big_endian).find("big-endian"), std::string::npos);
  sensor_msgs::CompressedImage junk;
  junk.format = "jpeg";
  junk.data = {1, 2, 3};
  EXPECT_NE(reason(junk).find("could not be decoded"), std::string::npos);

  // A real PNG decodes to grey.
  std::vector<std::uint8_t> png;
  cv::imencode(".png", cv::Mat(5, 7, CV_8UC3, cv::Scalar(10, 20, 30)), png);
  sensor_msgs::CompressedImage good;
  good.format = "png";
  good.data = png;
  const cv::Mat decoded = imageFromMessage(good);
  EXPECT_EQ(decoded.type(), CV_8UC1);
  EXPECT_EQ(decoded.cols, 7);
}

TEST(RosMessages, TheAccelerometerIsTakenUnlessTheImuSaysItHasNone) {
  sensor_msgs::Imu imu;
  imu.angular_velocity.z = 0.5;
  imu.linear_acceleration.z = 9.81;
  GyroSample s = gyroFromMessage(imu, 42);
  EXPECT_EQ(s.t_ns, 42);
  EXPECT_EQ(s.wz, 0.5);
  EXPECT_EQ(s.az, 9.81);
  imu.linear_acceleration_covariance[0] = -1.0;  // REP 145: no accelerometer
  s = gyroFromMessage(imu, 43);
  EXPECT_EQ(s.wz, 0.5);
  EXPECT_EQ(s.az, 0.0);
}

TEST(RosMessages, TheOdometryIsStampedOnTheGyroClockInTheGivenFrames) {
  Pose p;
  p.t_ns = 2'030'000'000;             // the image's stamp
  p.t_gyro_clock_ns = 2'000'000'000;  // its time on the IMU's clock
  p.position_m = {1, 2, 3};
  p.orientation_xyzw = {0, 0, 0.6, 0.8};
  p.velocity_body_mps = {0.9, 0, 0};
  p.angular_velocity_body_radps = {0, 0, 0.2};
  const nav_msgs::Odometry o = odometryMessage(p, {"odom", "base_link"});
  EXPECT_EQ(o.header.stamp.toNSec(), 2'000'000'000u);
  EXPECT_EQ(o.header.frame_id, "odom");
  EXPECT_EQ(o.child_frame_id, "base_link");
  EXPECT_EQ(o.pose.pose.position.y, 2);
  EXPECT_EQ(o.pose.pose.orientation.z, 0.6);
  EXPECT_EQ(o.twist.twist.linear.x, 0.9);
  EXPECT_EQ(o.twist.twist.angular.z, 0.2);
  const geometry_msgs::TransformStamped t = transformMessage(p, {"odom", "base_link"});
  EXPECT_EQ(t.header.stamp, o.header.stamp);
  EXPECT_EQ(t.transform.translation.z, 3);
  const geometry_msgs::TransformStamped lidar = sensorTransform(p, "base_link", "laser");
  EXPECT_EQ(lidar.header.frame_id, "base_link");
  EXPECT_EQ(lidar.child_frame_id, "laser");
  EXPECT_TRUE(lidar.header.stamp.isZero());
  EXPECT_FALSE(stampNs(ros::Time(0, 0)).has_value());
  EXPECT_EQ(*stampNs(ros::Time(1, 5)), 1'000'000'005);
}

TEST(RosMessages, TheDiagnosticSaysWhatIsWrong) {
  Status s;
  s.frames_processed = 10;
  s.tracking = true;
  std::vector<TopicHealth> topics = {{"/camera/image_raw", 0.05, 10, 0},
                                     {"/imu/data", 0.01, 100, 0}};
  EXPECT_EQ(diagnosticStatus(s, topics, 0, 1.0).level, diagnostic_msgs::DiagnosticStatus::OK);

  topics[1].silent_s = 5.2;
  auto d = diagnosticStatus(s, topics, 3, 1.0);
  EXPECT_EQ(d.level, diagnostic_msgs::DiagnosticStatus::WARN);
  EXPECT_NE(d.message.find("no message on /imu/data for 5.2 s"), std::string::npos) << d.message;
  EXPECT_NE(d.message.find("3 frames dropped"), std::string::npos) << d.message;

  s.tracking = false;
  s.reason = "too_few_landmarks";
  topics[1].silent_s = 0.01;
  d = diagnosticStatus(s, topics, 0, 1.0);
  EXPECT_EQ(d.level, diagnostic_msgs::DiagnosticStatus::WARN);
  EXPECT_NE(d.message.find("not tracking: too_few_landmarks"), std::string::npos) << d.message;

  s.error = "the window's solve threw";
  d = diagnosticStatus(s, topics, 0, 1.0);
  EXPECT_EQ(d.level, diagnostic_msgs::DiagnosticStatus::ERROR);
  EXPECT_NE(d.message.find("the window's solve threw"), std::string::npos);
  bool has_dropped = false;
  for (const auto& kv : d.values) has_dropped = has_dropped || kv.key == "frames_dropped";
  EXPECT_TRUE(has_dropped);
}

}  // namespace
}  // namespace ovo::ros1
