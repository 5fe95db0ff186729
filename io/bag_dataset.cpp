#include "io/bag_dataset.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <memory>

#include "camera/calib_io.hpp"
#include "common/error.hpp"
#include "io/cdr.hpp"
#include "io/rosbag1_reader.hpp"
#include "io/trajectory_io.hpp"

namespace ovo::io {

namespace fs = std::filesystem;
using bag::BagSource;
using bag::MessageRef;
using bag::Topic;
using ros::MsgType;

namespace {

std::string topicList(const BagSource& bag) {
  std::string s;
  for (const Topic& t : bag.topics())
    s += fmt::format("{}{} [{}, {} messages]", s.empty() ? "" : ", ", t.name, t.type, t.count);
  return s.empty() ? "none" : s;
}

const Topic* findTopic(const BagSource& bag, const std::string& name) {
  for (const Topic& t : bag.topics())
    if (t.name == name) return &t;
  return nullptr;
}

struct Role {
  const char* key;   // camera, imu, lidar
  const char* what;  // for messages
  std::vector<MsgType> types;
};

const Role kRoles[] = {
    {"camera",
     "sensor_msgs/Image or sensor_msgs/CompressedImage",
     {MsgType::kImage, MsgType::kCompressedImage}},
    {"imu", "sensor_msgs/Imu", {MsgType::kImu}},
    {"lidar", "sensor_msgs/LaserScan", {MsgType::kLaserScan}},
};

bool roleTakes(const Role& role, const Topic& t) {
  const MsgType type = ros::msgTypeOf(t.type);
  return std::find(role.types.begin(), role.types.end(), type) != role.types.end();
}

// A chosen topic must be of the role's type, in an encoding ovo decodes, with the MD5 sum of the
// definition it decodes (ROS 1).
void checkTopic(const BagSource& bag, const Role& role, const Topic& t) {
  if (!roleTakes(role, t))
    fail("{}: topic {} is {}; {} expects {}", bag.path().string(), t.name,
         t.type.empty() ? "of no type" : t.type, role.key, role.what);
  if (t.encoding != "cdr" && t.encoding != "ros1")
    fail("{}: topic {} has message encoding '{}': expected cdr (ROS 2) or ros1",
         bag.path().string(), t.name, t.encoding);
  if (t.encoding == "ros1" && !t.md5.empty() && t.md5 != "*") {
    const std::string expected = bag::ros1Md5Sum(ros::msgTypeOf(t.type));
    if (t.md5 != expected)
      fail(
          "{}: topic {}: {} with MD5 sum {}, but the sensor_msgs definition ovo decodes has {}: "
          "another version of the message",
          bag.path().string(), t.name, t.type, t.md5, expected);
  }
  if (t.count == 0) fail("{}: topic {} ({}) has no messages", bag.path().string(), t.name, t.type);
}

}  // namespace

BagTopics parseBagTopics(const std::string& spec, BagTopics* explicit_keys) {
  BagTopics topics, given;
  std::size_t start = 0;
  while (start <= spec.size() && !spec.empty()) {
    const std::size_t comma = std::min(spec.find(',', start), spec.size());
    const std::string entry = spec.substr(start, comma - start);
    const std::size_t eq = entry.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == entry.size())
      fail("--topics '{}': entry '{}': expected key=topic with key camera, imu or lidar", spec,
           entry);
    const std::string key = entry.substr(0, eq), value = entry.substr(eq + 1);
    std::string* slot = key == "camera"  ? &topics.camera
                        : key == "imu"   ? &topics.imu
                        : key == "lidar" ? &topics.lidar
                                         : nullptr;
    std::string* mark = key == "camera"  ? &given.camera
                        : key == "imu"   ? &given.imu
                        : key == "lidar" ? &given.lidar
                                         : nullptr;
    if (!slot) fail("--topics '{}': unknown key '{}' (expected camera, imu or lidar)", spec, key);
    if (!mark->empty()) fail("--topics '{}': '{}' given twice", spec, key);
    *mark = "1";
    *slot = value == "none" ? "" : value;
    start = comma + 1;
  }
  if (explicit_keys) *explicit_keys = given;
  return topics;
}

BagTopics chooseBagTopics(const BagSource& bag, const std::string& topics_option) {
  BagTopics given;
  const BagTopics requested = parseBagTopics(topics_option, &given);
  BagTopics chosen;
  const std::string* requested_of[] = {&requested.camera, &requested.imu, &requested.lidar};
  const std::string* given_of[] = {&given.camera, &given.imu, &given.lidar};
  std::string* chosen_of[] = {&chosen.camera, &chosen.imu, &chosen.lidar};
  for (int r = 0; r < 3; ++r) {
    const Role& role = kRoles[r];
    if (!given_of[r]->empty()) {  // named (or "none")
      if (requested_of[r]->empty()) continue;
      const Topic* t = findTopic(bag, *requested_of[r]);
      if (!t)
        fail("{}: --topics {}={}: no such topic in the bag (topics: {})", bag.path().string(),
             role.key, *requested_of[r], topicList(bag));
      checkTopic(bag, role, *t);
      *chosen_of[r] = t->name;
      continue;
    }
    std::vector<const Topic*> candidates;
    for (const Topic& t : bag.topics())
      if (roleTakes(role, t) && t.count > 0) candidates.push_back(&t);
    if (candidates.size() > 1) {
      std::string names;
      for (const Topic* t : candidates) names += fmt::format(" {} ({})", t->name, t->type);
      fail("{}: {} topics of type {}:{}; choose one with --topics {}=NAME", bag.path().string(),
           candidates.size(), role.what, names, role.key);
    }
    if (candidates.empty()) {
      if (r == 0)
        fail("{}: no camera topic ({} with messages); topics in the bag: {}", bag.path().string(),
             role.what, topicList(bag));
      continue;  // no gyro or no LiDAR: the dataset goes without
    }
    checkTopic(bag, role, *candidates.front());
    *chosen_of[r] = candidates.front()->name;
  }
  if (chosen.camera.empty())
    fail("{}: --topics camera=none: a dataset needs a camera topic", bag.path().string());
  return chosen;
}

fs::path bagRigFile(const fs::path& bag_path, const fs::path& rig_option) {
  if (!rig_option.empty()) {
    if (!fs::is_regular_file(rig_option)) fail("--rig {}: file not found", rig_option.string());
    return rig_option;
  }
  std::vector<fs::path> places;
  if (fs::is_directory(bag_path)) places.push_back(bag_path / "rig.yaml");
  places.push_back(bag_path.parent_path() / "rig.yaml");
  for (const fs::path& p : places)
    if (fs::is_regular_file(p)) return p;
  std::string looked;
  for (const fs::path& p : places) looked += " " + p.string();
  fail(
      "{}: a bag carries no camera calibration: give --rig rig.yaml (extrinsics and noise, "
      "camera.calibration: the calibration file), or put a rig.yaml beside the bag (looked "
      "for:{})",
      bag_path.string(), looked);
}

fs::path rigCameraCalibration(const RigInfo& rig, const fs::path& rig_file) {
  if (!rig.camera_calibration.empty()) {
    if (!fs::is_regular_file(rig.camera_calibration))
      fail("{}: camera.calibration: {} does not exist", rig_file.string(),
           rig.camera_calibration.string());
    return rig.camera_calibration;
  }
  const fs::path dir = rig_file.parent_path();
  for (const fs::path& p : {dir / "calib_results.txt", dir / "sensor.yaml",
                            dir / "cam0" / "calib_results.txt", dir / "cam0" / "sensor.yaml"})
    if (fs::is_regular_file(p)) return p;
  fail(
      "{}: no camera calibration: expected a key camera.calibration (the calibration file, "
      "relative to the rig file), or calib_results.txt / sensor.yaml beside it or in cam0/",
      rig_file.string());
}

namespace {

// Files that may sit beside the bag (or inside a rosbag2 folder): ground truth, simulator truth.
std::optional<fs::path> besideBag(const fs::path& bag_path, const fs::path& name) {
  std::vector<fs::path> places;
  if (fs::is_directory(bag_path)) places.push_back(bag_path / name);
  places.push_back(bag_path.parent_path() / name);
  for (const fs::path& p : places)
    if (fs::is_regular_file(p)) return p;
  return std::nullopt;
}

ros::Wire wireOf(const Topic& t) {
  return t.encoding == "ros1" ? ros::Wire::kRos1 : ros::Wire::kCdr;
}

// Sorts by time and drops repeated stamps (keeping the first); returns how many were dropped.
template <typename T, typename Stamp>
std::size_t sortUnique(std::vector<T>& items, Stamp stamp) {
  std::stable_sort(items.begin(), items.end(),
                   [&](const T& a, const T& b) { return stamp(a) < stamp(b); });
  const auto end = std::unique(items.begin(), items.end(),
                               [&](const T& a, const T& b) { return stamp(a) == stamp(b); });
  const auto dropped = static_cast<std::size_t>(items.end() - end);
  items.erase(end, items.end());
  return dropped;
}

}  // namespace

Dataset loadBagDataset(const fs::path& path, const LoadOptions& options) {
  std::shared_ptr<const BagSource> bag = bag::openBag(path);
  const BagTopics topics = chooseBagTopics(*bag, options.topics);

  Dataset ds;
  ds.root = path;
  ds.kind = "bag";
  const fs::path rig_file = bagRigFile(path, options.rig);
  ds.rig = readRigYaml(rig_file);
  ds.camera_file = rigCameraCalibration(ds.rig, rig_file);
  ds.camera = camera::loadCamera(ds.camera_file);
  std::optional<SE3> T_B_C_sensor;
  if (ds.camera_file.extension() == ".yaml")  // sensor.yaml (EuRoC) or Kalibr: T_BS
    T_B_C_sensor = camera::readSensorYamlExtrinsics(ds.camera_file);
  ds.rig.T_B_C = cameraExtrinsics(ds.rig, T_B_C_sensor, rig_file);

  // The chosen topics' messages, in record-time order.
  std::uint32_t camera_topic = UINT32_MAX, imu_topic = UINT32_MAX, lidar_topic = UINT32_MAX;
  for (std::uint32_t i = 0; i < bag->topics().size(); ++i) {
    const std::string& name = bag->topics()[i].name;
    if (name == topics.camera) camera_topic = i;
    if (name == topics.imu) imu_topic = i;
    if (name == topics.lidar) lidar_topic = i;
  }
  struct Decoded {
    Timestamp header_ns, record_ns;
    std::size_t index;  // in its topic
  };
  std::vector<Decoded> image_times, imu_times, scan_times;
  std::vector<MessageRef> image_refs;
  std::vector<ImuSample> imu;
  std::vector<LidarScan> scans;
  std::size_t n_image = 0, n_imu = 0, n_scan = 0;
  bool zero_stamp = false;
  std::string zero_stamp_topic;
  for (const MessageRef& ref : bag->messages()) {
    const Topic& t = bag->topics()[ref.topic];
    if (ref.topic != camera_topic && ref.topic != imu_topic && ref.topic != lidar_topic) continue;
    std::size_t& counter = ref.topic == camera_topic ? n_image
                           : ref.topic == imu_topic  ? n_imu
                                                     : n_scan;
    const std::string where = bag->describe(ref, counter);
    const std::vector<std::uint8_t> bytes = bag->payload(ref);
    Timestamp stamp = 0;
    if (ref.topic == camera_topic) {
      stamp = ros::decodeHeader(bytes, wireOf(t), where).stamp_ns;
      image_times.push_back({stamp, ref.log_time_ns, counter});
      image_refs.push_back(ref);
    } else if (ref.topic == imu_topic) {
      const ros::Imu m = ros::decodeImu(bytes, wireOf(t), where);
      stamp = m.header.stamp_ns;
      for (int k = 0; k < 3; ++k)
        if (!std::isfinite(m.angular_velocity[k]) || std::abs(m.angular_velocity[k]) > 1000.0)
          fail(
              "{}: angular_velocity {} = {} rad/s is no gyro reading (expected a finite value "
              "of at most 1000 rad/s)",
              where, "xyz"[k], m.angular_velocity[k]);
      imu.push_back(ros::imuSample(m, stamp));
      imu_times.push_back({stamp, ref.log_time_ns, counter});
    } else {
      const ros::LaserScan m = ros::decodeLaserScan(bytes, wireOf(t), where);
      stamp = m.header.stamp_ns;
      scans.push_back(ros::lidarScan(m, stamp, where));
      scan_times.push_back({stamp, ref.log_time_ns, counter});
    }
    if (stamp == 0 && !zero_stamp) {
      zero_stamp = true;
      zero_stamp_topic = t.name;
    }
    ++counter;
  }

  // One clock for all: header stamps, or the record times when a topic has zero stamps.
  if (zero_stamp)
    ds.notes.push_back(fmt::format(
        "{}: topic {} has messages with header.stamp 0: every topic is stamped with the bag's "
        "record times instead",
        path.string(), zero_stamp_topic));
  auto pick = [&](const Decoded& d) { return zero_stamp ? d.record_ns : d.header_ns; };
  for (std::size_t i = 0; i < imu.size(); ++i) imu[i].t_ns = pick(imu_times[i]);
  for (std::size_t i = 0; i < scans.size(); ++i) scans[i].t_ns = pick(scan_times[i]);

  const Topic& cam = bag->topics()[camera_topic];
  const MsgType cam_type = ros::msgTypeOf(cam.type);
  const ros::Wire cam_wire = wireOf(cam);
  for (std::size_t i = 0; i < image_refs.size(); ++i) {
    ImageEntry e;
    e.t_ns = pick(image_times[i]);
    const std::string where = bag->describe(image_refs[i], image_times[i].index);
    e.path = fs::path(fmt::format("{}:{}#{}", path.string(), cam.name, image_times[i].index));
    e.load = [bag, ref = image_refs[i], cam_type, cam_wire, where]() -> cv::Mat {
      const std::vector<std::uint8_t> bytes = bag->payload(ref);
      if (cam_type == MsgType::kImage)
        return ros::greyImage(ros::decodeImage(bytes, cam_wire, where), where);
      return ros::greyImage(ros::decodeCompressedImage(bytes, cam_wire, where), where);
    };
    ds.images.push_back(std::move(e));
  }
  auto dropped_note = [&](std::size_t n, const std::string& topic) {
    if (n > 0)
      ds.notes.push_back(
          fmt::format("{}: topic {}: {} messages repeat an earlier time stamp and "
                      "were left out",
                      path.string(), topic, n));
  };
  dropped_note(sortUnique(ds.images, [](const ImageEntry& e) { return e.t_ns; }), topics.camera);
  dropped_note(sortUnique(imu, [](const ImuSample& s) { return s.t_ns; }), topics.imu);
  dropped_note(sortUnique(scans, [](const LidarScan& s) { return s.t_ns; }), topics.lidar);
  ds.imu = std::move(imu);
  ds.scans = std::move(scans);

  if (auto gt = besideBag(path, "groundtruth.txt")) ds.groundtruth = readTum(*gt);
  if (auto bias = besideBag(path, fs::path("sim") / "truth_bias.csv"))
    ds.true_gyro_bias = readGyroBiasCsv(*bias);
  return ds;
}

}  // namespace ovo::io
