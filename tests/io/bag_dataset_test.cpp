// Bags read as datasets (io/bag_dataset.hpp): a small dataset written as a folder and as each bag
// format loads to the same images, gyro, scans (with their beam time), rig and ground truth; topics
// are found by type or chosen by name, and every wrong choice, a missing rig or calibration, and a
// bag without a camera is an error naming the bag, the topic and what was expected; header stamps
// of 0 fall back to the record times with a note.
#include "io/bag_dataset.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/core.hpp>

#include "camera/calib_io.hpp"
#include "io/bag_writer.hpp"
#include "io/dataset_writer.hpp"
#include "io/rosbag1_reader.hpp"
#include "tests/test_support.hpp"

namespace ovo::io {
namespace {

namespace fs = std::filesystem;
using test::errorOf;

constexpr Timestamp kT0 = 1'700'000'000'000'000'000LL;

// 6 frames of 64x48 at 20 Hz, gyro at 200 Hz, scans at 10 Hz with a beam time, ground truth.
void writeSmallDataset(const fs::path& out, std::optional<BagFormat> format) {
  DatasetWriter w(out, /*overwrite=*/true, format);
  cv::RNG rng(7);
  for (int k = 0; k < 6; ++k) {
    cv::Mat img(48, 64, CV_8UC1);
    rng.fill(img, cv::RNG::UNIFORM, 0, 256);
    w.writeImage(kT0 + k * 50'000'000LL, img);
  }
  std::vector<ImuSample> imu;
  for (int k = 0; k < 60; ++k)
    imu.push_back({kT0 + k * 5'000'000LL, Vec3(0.01 * k, -0.02, 0.3), Vec3(0.1, 0.0, 9.81)});
  w.writeImu(imu);
  std::vector<LidarScan> scans;
  for (int k = 0; k < 3; ++k) {
    LidarScan s;
    s.t_ns = kT0 + k * 100'000'000LL;
    s.angle_min_rad = -1.5;
    s.angle_increment_rad = 0.25;
    s.range_min_m = 0.1;
    s.range_max_m = 12.0;
    s.time_increment_s = 1.0 / 1440.0;
    s.ranges_m = {1.0 + k, std::nan(""), 2.5, 12.5};
    ros::roundToLaserScan(s);
    scans.push_back(s);
  }
  w.writeLidar(scans);
  Trajectory gt;
  for (int k = 0; k < 6; ++k) {
    StampedPose p;
    p.t_ns = kT0 + k * 50'000'000LL;
    p.T_W_B.translation() = Vec3(0.1 * k, 0, 0);
    gt.push_back(p);
  }
  w.writeGroundTruth(gt);
  w.writeCamera(camera::PinholeRadtanCamera(50, 50, 32, 24, 64, 48), SE3::Identity(), 20.0);
  RigInfo rig;
  rig.T_B_L.translation() = Vec3(0.2, 0, 0.3);
  rig.camera_height_m = 0.7;
  w.writeRig(rig);
  w.commit();
}

TEST(BagDataset, EveryFormatLoadsAsTheFolderDoes) {
  const fs::path dir = test::tempDir();
  writeSmallDataset(dir / "folder", std::nullopt);
  const Dataset folder = loadDataset(dir / "folder");
  ASSERT_EQ(folder.images.size(), 6u);
  for (BagFormat format : {BagFormat::kRos1, BagFormat::kSqlite3, BagFormat::kMcap}) {
    if (format == BagFormat::kRos1 && !bag::ros1BagsBuilt()) continue;
    const fs::path out = dir / ("bag" + std::to_string(static_cast<int>(format)));
    writeSmallDataset(out, format);
    const fs::path bag = bagPathIn(out, "run", format);
    ASSERT_TRUE(fs::exists(bag)) << bag;
    EXPECT_FALSE(fs::exists(out / "cam0" / "data"));
    // Both the bag itself and the folder holding it (its only bag) load.
    for (const fs::path& path : {bag, out}) {
      SCOPED_TRACE(path.string());
      const Dataset ds = loadDataset(path);
      EXPECT_EQ(ds.kind, "bag");
      EXPECT_TRUE(ds.notes.empty());
      ASSERT_EQ(ds.images.size(), folder.images.size());
      for (std::size_t i = 0; i < ds.images.size(); ++i) {
        EXPECT_EQ(ds.images[i].t_ns, folder.images[i].t_ns);
        EXPECT_EQ(cv::norm(loadDatasetImage(ds, i), loadDatasetImage(folder, i), cv::NORM_INF), 0);
      }
      ASSERT_EQ(ds.imu.size(), folder.imu.size());
      for (std::size_t i = 0; i < ds.imu.size(); ++i) {
        EXPECT_EQ(ds.imu[i].t_ns, folder.imu[i].t_ns);
        EXPECT_EQ(ds.imu[i].gyro_radps, folder.imu[i].gyro_radps);
        EXPECT_EQ(ds.imu[i].accel_mps2, folder.imu[i].accel_mps2);
      }
      ASSERT_EQ(ds.scans.size(), folder.scans.size());
      for (std::size_t i = 0; i < ds.scans.size(); ++i) {
        const LidarScan &a = ds.scans[i], &b = folder.scans[i];
        EXPECT_EQ(a.t_ns, b.t_ns);
        EXPECT_EQ(a.angle_min_rad, b.angle_min_rad);
        EXPECT_EQ(a.angle_increment_rad, b.angle_increment_rad);
        EXPECT_EQ(a.range_max_m, b.range_max_m);
        EXPECT_EQ(a.time_increment_s, static_cast<double>(static_cast<float>(1.0 / 1440.0)));
        ASSERT_EQ(a.ranges_m.size(), 4u);
        EXPECT_EQ(a.ranges_m[0], b.ranges_m[0]);
        EXPECT_TRUE(std::isnan(a.ranges_m[1]));
      }
      EXPECT_EQ(ds.groundtruth.size(), 6u);
      EXPECT_TRUE(ds.rig.has_rig_file);
      EXPECT_EQ(ds.rig.T_B_L.translation(), Vec3(0.2, 0, 0.3));
      EXPECT_EQ(ds.rig.camera_height_m, 0.7);
      EXPECT_EQ(ds.camera_file, out / "cam0" / "sensor.yaml");
      ASSERT_TRUE(ds.camera);
      EXPECT_EQ(camera::width(*ds.camera), 64);
    }
  }
}

// A bag with two image topics, a gyro and a scan topic.
fs::path twoCameraBag(const fs::path& dir) {
  const fs::path bag = dir / "two.mcap";
  auto w = BagWriter::create(BagFormat::kMcap, bag);
  cv::Mat img(48, 64, CV_8UC1, cv::Scalar(9));
  for (int k = 0; k < 3; ++k) {
    w->write("/left", ros::imageMessage(img, kT0 + k * 50'000'000LL, "l"));
    w->write("/right", ros::imageMessage(img, kT0 + k * 50'000'000LL, "r"));
    w->write("/imu", ros::imuMessage({kT0 + k * 50'000'000LL, Vec3::Zero(), Vec3::Zero()}, "i"));
  }
  w->close();
  writeSmallDataset(dir / "rigdir", std::nullopt);  // rig.yaml + cam0/sensor.yaml for --rig
  return bag;
}

TEST(BagDataset, TopicsByTypeOrByName) {
  const fs::path dir = test::tempDir();
  const fs::path bag = twoCameraBag(dir);
  const fs::path rig = dir / "rigdir" / "rig.yaml";
  const std::string several = errorOf([&] { loadDataset(bag, {rig, ""}); });
  EXPECT_CONTAINS(several, bag.string());
  EXPECT_CONTAINS(several, "2 topics of type sensor_msgs/Image or sensor_msgs/CompressedImage");
  EXPECT_CONTAINS(several, "/left (sensor_msgs/msg/Image)");
  EXPECT_CONTAINS(several, "--topics camera=NAME");
  const Dataset right = loadDataset(bag, {rig, "camera=/right"});
  EXPECT_EQ(right.images.size(), 3u);
  EXPECT_EQ(right.imu.size(), 3u);
  EXPECT_TRUE(right.scans.empty());
  EXPECT_CONTAINS(right.images[0].path.string(), "/right#0");
  const Dataset no_imu = loadDataset(bag, {rig, "camera=/left,imu=none"});
  EXPECT_TRUE(no_imu.imu.empty());
  EXPECT_CONTAINS(errorOf([&] {
                    loadDataset(bag, {rig, "camera=/imu"});
                  }),
                  "topic /imu is sensor_msgs/msg/Imu; camera expects sensor_msgs/Image or "
                  "sensor_msgs/CompressedImage");
  EXPECT_CONTAINS(errorOf([&] {
                    loadDataset(bag, {rig, "camera=/left,lidar=/imu"});
                  }),
                  "lidar expects sensor_msgs/LaserScan");
  const std::string missing = errorOf([&] { loadDataset(bag, {rig, "camera=/nope"}); });
  EXPECT_CONTAINS(missing, "--topics camera=/nope: no such topic in the bag");
  EXPECT_CONTAINS(missing, "/imu [sensor_msgs/msg/Imu, 3 messages]");
  EXPECT_CONTAINS(errorOf([&] { loadDataset(bag, {rig, "cam=/left"}); }), "unknown key 'cam'");
  EXPECT_CONTAINS(errorOf([&] { loadDataset(bag, {rig, "camera"}); }), "expected key=topic");
  EXPECT_CONTAINS(errorOf([&] {
                    loadDataset(bag, {rig, "camera=/left,camera=/right"});
                  }),
                  "given twice");
  EXPECT_CONTAINS(errorOf([&] { loadDataset(bag, {rig, "camera=none"}); }), "needs a camera");
  // --topics and --rig belong to bags.
  EXPECT_CONTAINS(errorOf([&] {
                    loadDataset(dir / "rigdir", {rig, ""});
                  }),
                  "--rig and --topics apply to bags");
}

TEST(BagDataset, RigAndCalibrationAreFoundOrNamed) {
  const fs::path dir = test::tempDir();
  const fs::path bag = twoCameraBag(dir);
  const std::string no_rig = errorOf([&] { loadDataset(bag, {"", "camera=/left"}); });
  EXPECT_CONTAINS(no_rig, "a bag carries no camera calibration: give --rig rig.yaml");
  EXPECT_CONTAINS(no_rig, (dir / "rig.yaml").string());
  EXPECT_CONTAINS(errorOf([&] {
                    loadDataset(bag, {dir / "x.yaml", "camera=/left"});
                  }),
                  "--rig " + (dir / "x.yaml").string() + ": file not found");
  // camera.calibration names the file, relative to the rig file.
  fs::create_directories(dir / "calib");
  fs::copy_file(dir / "rigdir" / "cam0" / "sensor.yaml", dir / "calib" / "cam.yaml");
  test::writeTextFile(dir / "rig.yaml", "camera: {calibration: calib/cam.yaml, rate_hz: 20}\n");
  const Dataset ds = loadDataset(bag, {"", "camera=/left"});  // rig.yaml beside the bag
  EXPECT_EQ(ds.camera_file, dir / "calib" / "cam.yaml");
  test::writeTextFile(dir / "rig.yaml", "camera: {calibration: calib/none.yaml}\n");
  EXPECT_CONTAINS(
      errorOf([&] {
        loadDataset(bag, {"", "camera=/left"});
      }),
      "camera.calibration: " + (dir / "calib" / "none.yaml").string() + " does not exist");
  test::writeTextFile(dir / "rig.yaml", "camera: {rate_hz: 20}\n");
  EXPECT_CONTAINS(errorOf([&] {
                    loadDataset(bag, {"", "camera=/left"});
                  }),
                  "no camera calibration: expected a key camera.calibration");
}

TEST(BagDataset, RepeatedStampsAreLeftOutWithANote) {
  OVO_REQUIRE_ROS1();
  const fs::path dir = test::tempDir();
  writeSmallDataset(dir / "rigdir", std::nullopt);
  const fs::path bag = dir / "rep.bag";
  auto w = BagWriter::create(BagFormat::kRos1, bag);
  cv::Mat img(48, 64, CV_8UC1, cv::Scalar(1));
  for (int k : {2, 0, 1, 1})  // out of order, one stamp twice
    w->write("/cam", ros::imageMessage(img, kT0 + k * 50'000'000LL, "c"));
  w->close();
  const Dataset ds = loadDataset(bag, {dir / "rigdir" / "rig.yaml", ""});
  ASSERT_EQ(ds.images.size(), 3u);
  EXPECT_EQ(ds.images[0].t_ns, kT0);
  EXPECT_EQ(ds.images[2].t_ns, kT0 + 100'000'000LL);
  ASSERT_EQ(ds.notes.size(), 1u);
  EXPECT_CONTAINS(ds.notes[0], "topic /cam: 1 messages repeat an earlier time stamp");
}

// Replaces every occurrence of `from` in the file by `to` (same length); returns how many.
int patchFile(const fs::path& file, const std::string& from, const std::string& to) {
  std::ifstream in(file, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), {});
  in.close();
  int n = 0;
  for (std::size_t at = bytes.find(from); at != std::string::npos; at = bytes.find(from, at + 1)) {
    bytes.replace(at, from.size(), to);
    ++n;
  }
  std::ofstream(file, std::ios::binary) << bytes;
  return n;
}

TEST(BagDataset, Ros1TopicOfAnotherDefinitionOrCompressionIsRefused) {
  OVO_REQUIRE_ROS1();
  const fs::path dir = test::tempDir();
  writeSmallDataset(dir, BagFormat::kRos1);
  const fs::path bag = dir / "run.bag";
  // Another version of LaserScan (its MD5 sum changed in the connection records).
  const std::string md5 = bag::ros1Md5Sum(ros::MsgType::kLaserScan);
  ASSERT_GE(patchFile(bag, "md5sum=" + md5, "md5sum=" + std::string(32, 'f')), 1);
  const std::string e = errorOf([&] { loadDataset(bag); });
  EXPECT_CONTAINS(e, bag.string());
  EXPECT_CONTAINS(e, "topic /scan: sensor_msgs/LaserScan with MD5 sum ffff");
  EXPECT_CONTAINS(e, "but the sensor_msgs definition ovo decodes has " + md5);
  // An unknown chunk compression.
  writeSmallDataset(dir, BagFormat::kRos1);
  ASSERT_GE(patchFile(bag, "compression=none", "compression=zzzz"), 1);
  EXPECT_CONTAINS(errorOf([&] { loadDataset(bag); }),
                  "chunk compression 'zzzz' is not supported (expected none, bz2 or lz4)");
}

TEST(BagDataset, RealRos1BagsAsDatasets) {
  OVO_REQUIRE_ROS1();
  OVO_REQUIRE_DATA("rosbag-fixtures/ros1_image_ros_numpy/test.bag");
  const fs::path dir = test::tempDir();
  // ros_numpy's bag: two camera topics, all header stamps 0 (record times used, with a note).
  test::writeTextFile(dir / "rig.yaml", "camera: {calibration: cam.yaml}\n");
  camera::writeSensorYaml(dir / "cam.yaml",
                          camera::PinholeRadtanCamera(200, 200, 180, 120, 360, 240),
                          SE3::Identity(), 20.0);
  const fs::path numpy = test::sharedData("rosbag-fixtures/ros1_image_ros_numpy/test.bag");
  const std::string two = errorOf([&] { loadDataset(numpy, {dir / "rig.yaml", ""}); });
  EXPECT_CONTAINS(two, "/compressedimage (sensor_msgs/CompressedImage)");
  EXPECT_CONTAINS(two, "/image (sensor_msgs/Image)");
  const Dataset ds = loadDataset(numpy, {dir / "rig.yaml", "camera=/image"});
  ASSERT_EQ(ds.images.size(), 1u);
  EXPECT_EQ(ds.images[0].t_ns, 1519728624724574089LL);
  ASSERT_EQ(ds.notes.size(), 1u);
  EXPECT_CONTAINS(ds.notes[0], "header.stamp 0");
  const cv::Mat grey = loadDatasetImage(ds, 0);
  EXPECT_EQ(grey.cols, 360);
  // The 2x2 PNG does not fit the 360x240 calibration: an error naming the image and calibration.
  const Dataset png = loadDataset(numpy, {dir / "rig.yaml", "camera=/compressedimage"});
  EXPECT_CONTAINS(errorOf([&] { loadDatasetImage(png, 0); }),
                  "the image is 2x2, but the camera calibration");
  // The hokuyo bag has no camera.
  const fs::path hokuyo = test::sharedData("rosbag-fixtures/ros1_laserscan_hokuyo/demo.bag");
  EXPECT_CONTAINS(errorOf([&] {
                    loadDataset(hokuyo, {dir / "rig.yaml", ""});
                  }),
                  "no camera topic (sensor_msgs/Image or sensor_msgs/CompressedImage with "
                  "messages); topics in the bag: /scan [sensor_msgs/LaserScan, 360 messages]");
  // robot_localization's gyro with a camera topic that is not there.
  const fs::path imu = test::sharedData("rosbag-fixtures/ros1_imu_robot_localization/test2.bag");
  EXPECT_CONTAINS(errorOf([&] {
                    loadDataset(imu, {dir / "rig.yaml", "camera=/camera"});
                  }),
                  "--topics camera=/camera: no such topic in the bag");
}

}  // namespace
}  // namespace ovo::io
