// ovo_ros: ovo's live odometry (api/ovo.hpp, realtime) as a ROS 1 node. A thin adapter: it
// subscribes to the camera, the IMU and the LiDAR, hands each message to ovo::Odometry with its
// header stamp, and publishes what comes out: nav_msgs/Odometry, the TF odom -> base_link, a
// nav_msgs/Path and a diagnostic_msgs status on /diagnostics. All estimation is the library's.
//
// Parameters (private):
//   ~rig            rig.yaml (required): extrinsics, noise figures, camera.calibration
//   ~estimator      window | kf | vo (window)
//   ~budget         full | low (full)
//   ~config         a YAML of ovo's configuration keys (optional)
//   ~set            "key=value" overrides: a list of strings, or one string of them separated by
//                   spaces
//   ~image_topic    sensor_msgs/Image, or CompressedImage when it ends in /compressed
//                   (/camera/image_raw)
//   ~imu_topic      sensor_msgs/Imu (/imu/data); "none" for a robot without a gyro
//   ~scan_topic     sensor_msgs/LaserScan (/scan); "none" for a robot without a LiDAR
//   ~odom_frame, ~base_frame   (odom, base_link); base_link is ovo's body frame (the IMU's)
//   ~publish_tf     (true); also the rig's camera and LiDAR extrinsics as static transforms from
//                   ~base_frame to the frame_id of the first image and scan (RViz shows the scan)
//   ~silent_after_s a topic silent this long is reported in the diagnostics (1.0)
//   ~path_spacing_m the path keeps a pose every this far (0.05), ~path_max_poses at most (20000)
//
// Stamps: each message's header stamp (the sensor's clock) goes to the library; the odometry, TF
// and path go out at the image's time on the IMU's clock (the image stamp less the rig's
// camera.time_offset_s and the window's own estimate), as `ovo run`'s trajectory has them. The
// poses are each frame's as it went out (`ovo run`'s trajectory_online.txt); the window's later
// corrections of past frames are not republished. A message with a zero
// stamp, an unreadable encoding or the wrong image size is skipped and counted (malformed); one not
// after the previous of its topic, or with a non-finite value, is refused by the library (counted).
// Both show in the diagnostics; neither stops the node.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>

#include <chrono>
#include <deque>
#include <memory>
#include <mutex>
#include <sstream>

#include "ros/messages.hpp"

namespace ovo::ros1 {
namespace {

using Clock = std::chrono::steady_clock;

struct Params {
  std::string rig, image_topic, imu_topic, scan_topic;
  Frames frames;
  bool publish_tf = true;
  double silent_after_s = 1.0;
  double path_spacing_m = 0.05;
  int path_max_poses = 20000;
  OdometryOptions options;
};

[[noreturn]] void badParam(const std::string& name, const std::string& expected) {
  throw std::runtime_error("parameter ~" + name + ": expected " + expected);
}

// ~set: a list of "key=value" strings, or one string of them separated by spaces.
std::vector<std::string> readSettings(const ros::NodeHandle& pn) {
  XmlRpc::XmlRpcValue value;
  if (!pn.getParam("set", value)) return {};
  std::vector<std::string> out;
  if (value.getType() == XmlRpc::XmlRpcValue::TypeString) {
    std::istringstream words(static_cast<std::string>(value));
    for (std::string w; words >> w;) out.push_back(w);
  } else if (value.getType() == XmlRpc::XmlRpcValue::TypeArray) {
    for (int i = 0; i < value.size(); ++i) {
      if (value[i].getType() != XmlRpc::XmlRpcValue::TypeString)
        badParam("set", "a list of \"key=value\" strings (item " + std::to_string(i) +
                            " is not a string)");
      out.push_back(static_cast<std::string>(value[i]));
    }
  } else {
    badParam("set", "a list of \"key=value\" strings or one string of them");
  }
  return out;
}

Params readParams(const ros::NodeHandle& pn) {
  Params p;
  if (!pn.getParam("rig", p.rig) || p.rig.empty())
    badParam("rig", "the path of a rig.yaml (as a dataset folder or `ovo simulate` gives)");
  pn.param<std::string>("estimator", p.options.estimator, "window");
  pn.param<std::string>("budget", p.options.budget, "full");
  pn.param<std::string>("config", p.options.config_file, "");
  p.options.settings = readSettings(pn);
  pn.param<std::string>("image_topic", p.image_topic, "/camera/image_raw");
  pn.param<std::string>("imu_topic", p.imu_topic, "/imu/data");
  pn.param<std::string>("scan_topic", p.scan_topic, "/scan");
  // "none" (what roslaunch can pass: it drops an empty argument) or empty: no such sensor.
  for (std::string* topic : {&p.imu_topic, &p.scan_topic})
    if (*topic == "none") topic->clear();
  if (p.image_topic.empty()) badParam("image_topic", "a camera topic (ovo needs the camera)");
  pn.param<std::string>("odom_frame", p.frames.odom, "odom");
  pn.param<std::string>("base_frame", p.frames.base, "base_link");
  pn.param("publish_tf", p.publish_tf, true);
  pn.param("silent_after_s", p.silent_after_s, 1.0);
  pn.param("path_spacing_m", p.path_spacing_m, 0.05);
  pn.param("path_max_poses", p.path_max_poses, 20000);
  if (!(p.silent_after_s > 0)) badParam("silent_after_s", "a time > 0 s");
  if (!(p.path_spacing_m >= 0)) badParam("path_spacing_m", "a distance >= 0 m");
  if (p.path_max_poses < 1) badParam("path_max_poses", "at least 1");
  p.options.use_gyro = !p.imu_topic.empty();
  p.options.use_lidar = !p.scan_topic.empty();
  p.options.realtime = true;
  p.options.keep_trajectory = false;  // a node runs for hours: the poses go out as they come
  return p;
}

/// One input topic's counters (written by the spinner thread, read by the diagnostics timer).
class Topic {
 public:
  explicit Topic(std::string name) : name_(std::move(name)) {}
  void heard() {
    std::lock_guard lock(mutex_);
    last_ = Clock::now();
    ++received_;
  }
  void malformed(const std::string& why) {
    {
      std::lock_guard lock(mutex_);
      ++malformed_;
    }
    ROS_WARN_THROTTLE(5.0, "ovo_ros: skipped a message on %s: %s", name_.c_str(), why.c_str());
  }
  TopicHealth health() const {
    std::lock_guard lock(mutex_);
    TopicHealth h{name_, -1.0, received_, malformed_};
    if (received_ > 0) h.silent_s = std::chrono::duration<double>(Clock::now() - last_).count();
    return h;
  }

 private:
  const std::string name_;
  mutable std::mutex mutex_;
  Clock::time_point last_;
  long received_ = 0, malformed_ = 0;
};

class Node {
 public:
  Node(ros::NodeHandle& nh, ros::NodeHandle& pn, Params params)
      : params_(std::move(params)),
        odo_(params_.rig, params_.options, [this](const Pose& p) { onPose(p); }) {
    odom_pub_ = pn.advertise<nav_msgs::Odometry>("odometry", 50);
    path_pub_ = pn.advertise<nav_msgs::Path>("path", 1, true);
    diag_pub_ = nh.advertise<diagnostic_msgs::DiagnosticArray>("/diagnostics", 10);
    const std::string compressed = "/compressed";
    const std::string& image_topic = params_.image_topic;
    if (image_topic.size() > compressed.size() &&
        image_topic.compare(image_topic.size() - compressed.size(), compressed.size(),
                            compressed) == 0)
      subscribe<sensor_msgs::CompressedImage>(
          nh, image_topic, 10, [this](const auto& m, std::int64_t t) {
            announceSensorFrame(m.header.frame_id, odo_.cameraInBody(), camera_frame_sent_);
            odo_.addImage(t, imageFromMessage(m));
          });
    else
      subscribe<sensor_msgs::Image>(nh, image_topic, 10, [this](const auto& m, std::int64_t t) {
        announceSensorFrame(m.header.frame_id, odo_.cameraInBody(), camera_frame_sent_);
        odo_.addImage(t, imageFromMessage(m));
      });
    if (!params_.imu_topic.empty())
      subscribe<sensor_msgs::Imu>(
          nh, params_.imu_topic, 2000,
          [this](const auto& m, std::int64_t t) { odo_.addGyro(gyroFromMessage(m, t)); });
    if (!params_.scan_topic.empty())
      subscribe<sensor_msgs::LaserScan>(
          nh, params_.scan_topic, 50, [this](const auto& m, std::int64_t t) {
            announceSensorFrame(m.header.frame_id, odo_.lidarInBody(), lidar_frame_sent_);
            odo_.addScan(scanFromMessage(m, t));
          });
    // Wall timers: with use_sim_time a stopped bag stops the ROS clock, and a silent topic is
    // exactly what the diagnostics must report.
    diag_timer_ = nh.createWallTimer(ros::WallDuration(1.0),
                                     [this](const ros::WallTimerEvent&) { publishDiagnostics(); });
    path_timer_ = nh.createWallTimer(ros::WallDuration(0.5),
                                     [this](const ros::WallTimerEvent&) { publishPath(); });
    ROS_INFO("ovo_ros: %s estimator on %s%s%s; rig %s", params_.options.estimator.c_str(),
             params_.image_topic.c_str(),
             params_.imu_topic.empty() ? " (no gyro)" : (", " + params_.imu_topic).c_str(),
             params_.scan_topic.empty() ? " (no LiDAR)" : (", " + params_.scan_topic).c_str(),
             params_.rig.c_str());
  }

  /// Processes what is still queued and ends the run; an error that stopped processing is
  /// reported here.
  void finish() {
    odo_.finish();
    const Status s = odo_.status();
    ROS_INFO("ovo_ros: %d frames processed, %d dropped, %d measurements refused",
             s.frames_processed, s.frames_dropped, s.refused);
  }

 private:
  // The first message of a sensor names its frame: the rig's extrinsics go out as a static
  // transform base -> frame (once; the spinner thread only).
  void announceSensorFrame(const std::string& frame_id, const Pose& in_body, bool& done) {
    if (done || !params_.publish_tf) return;
    done = true;
    if (frame_id.empty() || frame_id == params_.frames.base) return;
    static_tf_.push_back(sensorTransform(in_body, params_.frames.base, frame_id));
    static_tf_broadcaster_.sendTransform(static_tf_);
  }

  // Subscribes `take` (message, its stamp in ns) to `topic`, counted in the diagnostics: a message
  // with a zero stamp, or one `take` throws for (an image encoding or size ovo cannot use), is
  // skipped as malformed.
  template <class Message, class Take>
  void subscribe(ros::NodeHandle& nh, const std::string& topic, int queue, Take take) {
    topics_.push_back(std::make_unique<Topic>(topic));
    Topic* health = topics_.back().get();
    subs_.push_back(nh.subscribe<Message>(
        topic, queue,
        [health, take](const typename Message::ConstPtr& m) {
          health->heard();
          const auto t = stampNs(m->header.stamp);
          if (!t) return health->malformed("zero header stamp (ovo needs the sensor's time)");
          try {
            take(*m, *t);
          } catch (const std::exception& e) {
            health->malformed(e.what());
          }
        },
        ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay()));
  }

  // On ovo's estimator thread.
  void onPose(const Pose& p) {
    if (p.tracked != tracking_) {
      const Status status = odo_.status();
      if (!p.tracked && tracking_ && status.reason != "initializing")
        ROS_WARN(
            "ovo_ros: tracking lost at %.3f s (%s): the pose is held or propagated by the "
            "gyro until the camera tracks again",
            ros1::rosTime(p.t_gyro_clock_ns).toSec(), status.reason.c_str());
      else if (p.tracked && ever_tracked_)
        ROS_INFO("ovo_ros: tracking again at %.3f s", ros1::rosTime(p.t_gyro_clock_ns).toSec());
      tracking_ = p.tracked;
      ever_tracked_ = ever_tracked_ || p.tracked;
    }
    odom_pub_.publish(odometryMessage(p, params_.frames));
    if (params_.publish_tf) tf_.sendTransform(transformMessage(p, params_.frames));
    std::lock_guard lock(path_mutex_);
    const auto far_enough = [&](const geometry_msgs::PoseStamped& last) {
      const double dx = p.position_m[0] - last.pose.position.x;
      const double dy = p.position_m[1] - last.pose.position.y;
      const double dz = p.position_m[2] - last.pose.position.z;
      return dx * dx + dy * dy + dz * dz >= params_.path_spacing_m * params_.path_spacing_m;
    };
    if (!path_.empty() && !far_enough(path_.back())) return;
    path_.push_back(poseMessage(p, params_.frames));
    if (static_cast<int>(path_.size()) > params_.path_max_poses) path_.pop_front();
    path_changed_ = true;
  }

  void publishPath() {
    // The message is made and sent here, on the spinner's thread, not on ovo's estimator thread
    // that adds the poses.
    nav_msgs::Path path;
    {
      std::lock_guard lock(path_mutex_);
      if (!path_changed_) return;
      path.poses.assign(path_.begin(), path_.end());
      path_changed_ = false;
    }
    path.header.frame_id = params_.frames.odom;
    path.header.stamp = path.poses.back().header.stamp;
    path_pub_.publish(path);
  }

  void publishDiagnostics() {
    const Status s = odo_.status();
    std::vector<TopicHealth> health;
    for (const auto& t : topics_) health.push_back(t->health());
    diagnostic_msgs::DiagnosticArray array;
    array.header.stamp = ros::Time::now();
    array.status.push_back(
        diagnosticStatus(s, health, s.frames_dropped - dropped_reported_, params_.silent_after_s));
    dropped_reported_ = s.frames_dropped;
    if (!s.error.empty() && !error_logged_) {
      ROS_ERROR("ovo_ros: processing stopped: %s", s.error.c_str());
      error_logged_ = true;
    }
    diag_pub_.publish(array);
  }

  const Params params_;
  std::vector<std::unique_ptr<Topic>> topics_;
  std::vector<ros::Subscriber> subs_;
  ros::Publisher odom_pub_, path_pub_, diag_pub_;
  tf2_ros::TransformBroadcaster tf_;
  tf2_ros::StaticTransformBroadcaster static_tf_broadcaster_;
  std::vector<geometry_msgs::TransformStamped> static_tf_;  // all of them: each send replaces
  bool camera_frame_sent_ = false, lidar_frame_sent_ = false;
  ros::WallTimer diag_timer_, path_timer_;
  std::mutex path_mutex_;
  std::deque<geometry_msgs::PoseStamped> path_;  // under path_mutex_
  bool path_changed_ = false;
  int dropped_reported_ = 0;
  bool error_logged_ = false;
  bool tracking_ = false, ever_tracked_ = false;  // onPose's thread only
  // Last: made after the publishers its callback uses, and stopped (its threads joined) before
  // they go.
  Odometry odo_;
};

}  // namespace
}  // namespace ovo::ros1

int main(int argc, char** argv) {
  ros::init(argc, argv, "ovo");
  ros::NodeHandle nh, pn("~");
  std::unique_ptr<ovo::ros1::Node> node;
  try {
    node = std::make_unique<ovo::ros1::Node>(nh, pn, ovo::ros1::readParams(pn));
  } catch (const std::exception& e) {  // a missing or bad parameter, rig file or configuration
    ROS_FATAL("ovo_ros: %s", e.what());
    return 1;
  }
  ros::spin();
  try {
    node->finish();
  } catch (const std::exception& e) {
    ROS_ERROR("ovo_ros: %s", e.what());
    return 1;
  }
  return 0;
}
