// ROS 1 bags through librosbag (io/rosbag1_reader.hpp): the real fixtures read with the counts,
// record times and decoded values of their manifest (../shared/data/rosbag-fixtures/MANIFEST.md),
// none/bz2/lz4 chunks alike; damaged bags are ovo::Errors from the structure check, never a crash.
#include <gtest/gtest.h>

#include <fstream>
#include <map>

#include "io/bag_source.hpp"
#include "io/bag_writer.hpp"
#include "io/cdr.hpp"
#include "io/rosbag1_check.hpp"
#include "io/rosbag1_reader.hpp"
#include "tests/test_support.hpp"

namespace ovo::io::bag {
namespace {

namespace fs = std::filesystem;
using ros::Wire;
using test::errorOf;

constexpr Timestamp ns(std::int64_t sec, std::int64_t nsec) { return sec * 1'000'000'000 + nsec; }

std::map<std::string, std::uint64_t> countsOf(const BagSource& bag) {
  std::map<std::string, std::uint64_t> counts;
  for (const Topic& t : bag.topics()) counts[t.name] = t.count;
  return counts;
}

// The first and last message of a topic.
std::pair<MessageRef, MessageRef> ends(const BagSource& bag, const std::string& topic) {
  std::vector<MessageRef> refs;
  for (const MessageRef& m : bag.messages())
    if (bag.topics()[m.topic].name == topic) refs.push_back(m);
  EXPECT_FALSE(refs.empty()) << topic;
  return {refs.front(), refs.back()};
}

const std::string kDir = "rosbag-fixtures/";

TEST(Rosbag1, TurtlesimReadsTheSameInEveryChunkCompression) {
  OVO_REQUIRE_ROS1();
  OVO_REQUIRE_DATA(kDir + "ros1_turtlesim/example.bag");
  const std::map<std::string, std::uint64_t> expected = {{"/rosout", 10},
                                                         {"/tf", 2688},
                                                         {"/tf_static", 1},
                                                         {"/turtle1/cmd_vel", 357},
                                                         {"/turtle1/color_sensor", 1351},
                                                         {"/turtle1/pose", 1344},
                                                         {"/turtle2/cmd_vel", 208},
                                                         {"/turtle2/color_sensor", 1344},
                                                         {"/turtle2/pose", 1344}};
  std::vector<std::vector<std::uint8_t>> payloads_none;
  for (const char* name : {"example.bag", "example-bz2.bag", "example-lz4.bag"}) {
    SCOPED_TRACE(name);
    const fs::path file = test::sharedData(kDir + "ros1_turtlesim/" + name);
    const Ros1BagLayout layout = checkRos1BagStructure(file);
    EXPECT_EQ(layout.chunk_count, 1u);
    EXPECT_EQ(layout.conn_count, std::string(name) == "example.bag" ? 12u : 9u);
    const auto bag = openRos1Bag(file);
    EXPECT_EQ(bag->kind(), "ROS 1 bag");
    EXPECT_EQ(countsOf(*bag), expected);
    ASSERT_EQ(bag->messages().size(), 8647u);
    EXPECT_EQ(bag->messages().front().log_time_ns, ns(1396293887, 844783943));
    EXPECT_EQ(bag->messages().back().log_time_ns, ns(1396293909, 544870199));
    for (const Topic& t : bag->topics()) EXPECT_EQ(t.encoding, "ros1");
    // turtlesim/Pose: float32 x, y, theta, linear_velocity, angular_velocity.
    const auto [first, last] = ends(*bag, "/turtle1/pose");
    EXPECT_EQ(first.log_time_ns, ns(1396293888, 56045055));
    const auto first_bytes = bag->payload(first), last_bytes = bag->payload(last);
    ros::WireReader p(first_bytes, Wire::kRos1, "pose");
    EXPECT_EQ(p.f32("x"), 5.544444561004639f);
    EXPECT_EQ(p.f32("y"), 5.544444561004639f);
    EXPECT_EQ(p.f32("theta"), 0.0f);
    ros::WireReader q(last_bytes, Wire::kRos1, "pose");
    EXPECT_EQ(q.f32("x"), 0.9977187514305115f);
    EXPECT_EQ(q.f32("y"), 0.7498267292976379f);
    EXPECT_EQ(q.f32("theta"), 2.0799999237060547f);
    // geometry_msgs/Twist: the last /turtle1/cmd_vel turns at -2 rad/s.
    const auto twist_bytes = bag->payload(ends(*bag, "/turtle1/cmd_vel").second);
    ros::WireReader twist(twist_bytes, Wire::kRos1, "tw");
    for (int i = 0; i < 5; ++i) EXPECT_EQ(twist.f64("v"), 0.0);
    EXPECT_EQ(twist.f64("angular.z"), -2.0);
    // rosgraph_msgs/Log: header, byte level, string name, string msg.
    const auto log_bytes = bag->payload(bag->messages().front());
    ros::WireReader log(log_bytes, Wire::kRos1, "log");
    log.header();
    EXPECT_EQ(log.u8("level"), 2);
    EXPECT_EQ(log.string("name"), "/record_1396293886837508126");
    EXPECT_EQ(log.string("msg"), "Subscribing to /rosout");
    // tf2_msgs/TFMessage: transforms[0] turtle1 -> carrot, (1, 0, 0), identity.
    const auto tf_bytes = bag->payload(ends(*bag, "/tf_static").first);
    ros::WireReader tf(tf_bytes, Wire::kRos1, "tf");
    EXPECT_EQ(tf.u32("transforms"), 1u);
    const ros::Header h = tf.header();
    EXPECT_EQ(h.frame_id, "turtle1");
    EXPECT_EQ(h.stamp_ns, ns(1396293887, 807552910));
    EXPECT_EQ(tf.string("child_frame_id"), "carrot");
    EXPECT_EQ(tf.f64("x"), 1.0);
    // All three files hold the same payloads.
    std::vector<std::uint8_t> all;
    for (const MessageRef& m : bag->messages()) {
      const auto b = bag->payload(m);
      all.insert(all.end(), b.begin(), b.end());
    }
    if (payloads_none.empty())
      payloads_none.push_back(all);
    else
      EXPECT_TRUE(all == payloads_none.front());
  }
}

TEST(Rosbag1, RobotLocalizationImu) {
  OVO_REQUIRE_ROS1();
  OVO_REQUIRE_DATA(kDir + "ros1_imu_robot_localization/test2.bag");
  const fs::path file = test::sharedData(kDir + "ros1_imu_robot_localization/test2.bag");
  const Ros1BagLayout layout = checkRos1BagStructure(file);
  EXPECT_EQ(layout.chunk_count, 5u);
  ASSERT_EQ(layout.chunk_compression.size(), 5u);
  EXPECT_EQ(layout.chunk_compression[0], "bz2");
  EXPECT_EQ(layout.chunk_compressed_size[0], 103922u);
  EXPECT_EQ(layout.chunk_uncompressed_size[0], 787104u);
  const auto bag = openRos1Bag(file);
  EXPECT_EQ(bag->messages().size(), 6121u);
  const auto counts = countsOf(*bag);
  EXPECT_EQ(counts.at("/imu/data"), 3061u);
  EXPECT_EQ(counts.at("/jackal_velocity_controller/odom"), 3060u);
  for (const Topic& t : bag->topics())
    if (t.name == "/imu/data") {
      EXPECT_EQ(t.type, "sensor_msgs/Imu");
      EXPECT_EQ(t.md5, "6a62c6daae103f4ff57a132d6f95cec2");
      EXPECT_EQ(t.md5, ros1Md5Sum(ros::MsgType::kImu));  // libsensor-msgs-dev's definition
    }
  const auto [first, last] = ends(*bag, "/imu/data");
  EXPECT_EQ(first.log_time_ns, ns(47, 580000000));
  EXPECT_EQ(last.log_time_ns, ns(108, 781000000));
  const ros::Imu a = ros::decodeImu(bag->payload(first), Wire::kRos1, "imu");
  EXPECT_EQ(a.header.seq, 2283u);
  EXPECT_EQ(a.header.stamp_ns, ns(47, 580000000));
  EXPECT_EQ(a.header.frame_id, "base_link");
  EXPECT_EQ(a.orientation_xyzw[0], 0.004330256523966678);
  EXPECT_EQ(a.orientation_xyzw[3], 0.9832451613379618);
  EXPECT_EQ(a.angular_velocity,
            Vec3(0.006656444803353631, -0.00236638747633773, 0.04275138193045083));
  EXPECT_EQ(a.linear_acceleration,
            Vec3(-0.5942556862503618, 0.15657528786590588, 9.703827518410009));
  EXPECT_EQ(a.orientation_covariance[0], 2.5977777569955555e-07);
  EXPECT_EQ(a.orientation_covariance[8], 2.5e-05);
  EXPECT_EQ(a.orientation_covariance[1], 0.0);
  EXPECT_EQ(a.angular_velocity_covariance[4], 2.5e-05);
  const ros::Imu z = ros::decodeImu(bag->payload(last), Wire::kRos1, "imu");
  EXPECT_EQ(z.header.seq, 5343u);
  EXPECT_EQ(z.header.stamp_ns, ns(108, 780000000));
  EXPECT_EQ(z.orientation_xyzw[3], -0.8399068744849364);
  EXPECT_EQ(z.angular_velocity,
            Vec3(0.004066151195657548, -0.005366438265441694, 0.03825877566845808));
  EXPECT_EQ(z.linear_acceleration,
            Vec3(-0.3176929969202574, -0.5259286964903248, 9.806229082013386));
}

TEST(Rosbag1, HokuyoLaserScansKeepTheirBeamTime) {
  OVO_REQUIRE_ROS1();
  OVO_REQUIRE_DATA(kDir + "ros1_laserscan_hokuyo/demo.bag");
  const fs::path file = test::sharedData(kDir + "ros1_laserscan_hokuyo/demo.bag");
  const Ros1BagLayout layout = checkRos1BagStructure(file);
  EXPECT_EQ(layout.chunk_count, 2u);
  EXPECT_EQ(layout.chunk_uncompressed_size[0], 788484u);
  EXPECT_EQ(layout.chunk_uncompressed_size[1], 231896u);
  const auto bag = openRos1Bag(file);
  ASSERT_EQ(bag->topics().size(), 1u);
  EXPECT_EQ(bag->topics()[0].name, "/scan");
  EXPECT_EQ(bag->topics()[0].md5, "90c7ef2dc6895d81024acba2ac42f369");
  EXPECT_EQ(bag->topics()[0].md5, ros1Md5Sum(ros::MsgType::kLaserScan));
  ASSERT_EQ(bag->messages().size(), 360u);
  EXPECT_EQ(bag->messages().front().log_time_ns, ns(1282836371, 69930698));
  EXPECT_EQ(bag->messages().back().log_time_ns, ns(1282836406, 881212710));
  std::uint32_t seq = 930;
  for (const MessageRef& m : bag->messages()) {
    const ros::LaserScan s = ros::decodeLaserScan(bag->payload(m), Wire::kRos1, "scan");
    EXPECT_EQ(s.header.seq, ++seq);
  }
  EXPECT_EQ(seq, 1290u);
  const ros::LaserScan s =
      ros::decodeLaserScan(bag->payload(bag->messages().front()), Wire::kRos1, "s");
  EXPECT_EQ(s.header.stamp_ns, ns(1282836370, 970876375));
  EXPECT_EQ(s.header.frame_id, "/laser");
  EXPECT_EQ(s.angle_min, -2.0862138271331787);
  EXPECT_EQ(s.angle_max, 2.0862138271331787);
  EXPECT_EQ(s.angle_increment, 0.006135923322290182);
  EXPECT_EQ(s.time_increment, 9.765625145519152e-05);
  EXPECT_EQ(s.scan_time, 0.10000000149011612);
  EXPECT_EQ(s.range_min, 0.019999999552965164);
  EXPECT_EQ(s.range_max, 5.599999904632568);
  ASSERT_EQ(s.ranges.size(), 681u);
  EXPECT_TRUE(s.intensities.empty());
  EXPECT_EQ(s.ranges[0], 3.002000093460083f);
  EXPECT_EQ(s.ranges[1], 3.009000062942505f);
  EXPECT_EQ(s.ranges[340], 0.9419999718666077f);
  EXPECT_EQ(s.ranges[680], 2.5759999752044678f);
  EXPECT_EQ(std::count(s.ranges.begin(), s.ranges.end(), 0.0f), 47);
  EXPECT_EQ(*std::max_element(s.ranges.begin(), s.ranges.end()), 5.079999923706055f);
  // As ovo's scan: beam i at stamp + i * time_increment; 0.0 is below range_min: no return.
  const LidarScan scan = ros::lidarScan(s, s.header.stamp_ns, "s");
  EXPECT_EQ(scan.time_increment_s, 9.765625145519152e-05);
  EXPECT_NEAR(scan.angle(680), 2.0862138271331787, 1e-6);
  ASSERT_EQ(scan.ranges_m.size(), 681u);
  int in_interval = 0;
  for (std::size_t i = 0; i < scan.ranges_m.size(); ++i) {
    EXPECT_EQ(scan.ranges_m[i], static_cast<double>(s.ranges[i]));
    if (s.ranges[i] == 0.0f) {
      EXPECT_FALSE(scan.valid(i));
    }
    in_interval += s.ranges[i] >= s.range_min && s.ranges[i] <= s.range_max;
    EXPECT_EQ(scan.valid(i), s.ranges[i] >= s.range_min && s.ranges[i] <= s.range_max);
  }
  EXPECT_LE(in_interval, 681 - 47);
  EXPECT_GT(in_interval, 600);
  const ros::LaserScan e =
      ros::decodeLaserScan(bag->payload(bag->messages().back()), Wire::kRos1, "s");
  EXPECT_EQ(e.header.stamp_ns, ns(1282836406, 786728375));
  EXPECT_EQ(e.ranges[0], 2.88100004196167f);
  EXPECT_EQ(e.ranges[340], 0.4359999895095825f);
  EXPECT_EQ(e.ranges[680], 2.117000102996826f);
}

TEST(Rosbag1, RosNumpyImageAndCompressedImage) {
  OVO_REQUIRE_ROS1();
  OVO_REQUIRE_DATA(kDir + "ros1_image_ros_numpy/test.bag");
  const auto bag = openRos1Bag(test::sharedData(kDir + "ros1_image_ros_numpy/test.bag"));
  ASSERT_EQ(bag->messages().size(), 9u);
  EXPECT_EQ(bag->messages().front().log_time_ns, ns(1519728624, 724574089));
  EXPECT_EQ(bag->messages().back().log_time_ns, ns(1519728624, 725740909));
  const ros::Image img =
      ros::decodeImage(bag->payload(ends(*bag, "/image").first), Wire::kRos1, "i");
  EXPECT_EQ(img.header.stamp_ns, 0);
  EXPECT_EQ(img.header.frame_id, "");
  EXPECT_EQ(img.height, 240u);
  EXPECT_EQ(img.width, 360u);
  EXPECT_EQ(img.encoding, "rgb8");
  EXPECT_EQ(img.is_bigendian, 0);
  EXPECT_EQ(img.step, 1080u);
  ASSERT_EQ(img.data.size(), 259200u);
  const std::vector<std::uint8_t> head = {0xa6, 0xa3, 0xaf, 0xc5, 0xb3, 0x45, 0xd4, 0x48,
                                          0x41, 0x73, 0xb1, 0x89, 0x9a, 0x98, 0x4d, 0x5d};
  EXPECT_TRUE(std::equal(head.begin(), head.end(), img.data.begin()));
  const std::vector<std::uint8_t> tail = {0x1f, 0x72, 0x6f, 0x53, 0x64, 0xf8, 0x44, 0x52};
  EXPECT_TRUE(std::equal(tail.begin(), tail.end(), img.data.end() - 8));
  const cv::Mat grey = ros::greyImage(img, "i");
  EXPECT_EQ(grey.cols, 360);
  EXPECT_EQ(grey.rows, 240);
  // Grey of the first pixel (R a6, G a3, B af): 0.299 R + 0.587 G + 0.114 B.
  EXPECT_NEAR(grey.at<std::uint8_t>(0, 0), 0.299 * 0xa6 + 0.587 * 0xa3 + 0.114 * 0xaf, 1.0);

  const ros::CompressedImage c = ros::decodeCompressedImage(
      bag->payload(ends(*bag, "/compressedimage").first), Wire::kRos1, "c");
  EXPECT_EQ(c.format, "png");
  ASSERT_EQ(c.data.size(), 82u);
  EXPECT_EQ(c.data[0], 0x89);
  EXPECT_EQ(c.data[1], 'P');
  const std::vector<std::uint8_t> iend = {0x49, 0x45, 0x4e, 0x44, 0xae, 0x42, 0x60, 0x82};
  EXPECT_TRUE(std::equal(iend.begin(), iend.end(), c.data.end() - 8));
  const cv::Mat png = ros::greyImage(c, "c");
  EXPECT_EQ(png.cols, 2);
  EXPECT_EQ(png.rows, 2);
  // geometry_msgs/Vector3 (1, 2, 3).
  const auto v_bytes = bag->payload(ends(*bag, "/vector3").first);
  ros::WireReader v(v_bytes, Wire::kRos1, "v");
  EXPECT_EQ(v.f64("x"), 1.0);
  EXPECT_EQ(v.f64("y"), 2.0);
  EXPECT_EQ(v.f64("z"), 3.0);
}

std::vector<std::uint8_t> readAll(const fs::path& f) {
  std::ifstream in(f, std::ios::binary);
  return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(in), {});
}
void writeAll(const fs::path& f, const std::vector<std::uint8_t>& b) {
  std::ofstream out(f, std::ios::binary);
  out.write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
}

// Opens the bag and reads every payload: what `ovo run` does with a bag.
void readEverything(const fs::path& f) {
  const auto bag = openRos1Bag(f);
  for (const MessageRef& m : bag->messages()) bag->payload(m);
}

TEST(Rosbag1, TruncatedAndCorruptBagsAreErrors) {
  OVO_REQUIRE_ROS1();
  OVO_REQUIRE_DATA(kDir + "ros1_laserscan_hokuyo/demo.bag");
  const std::vector<std::uint8_t> uncompressed =
      readAll(test::sharedData(kDir + "ros1_laserscan_hokuyo/demo.bag"));
  const std::vector<std::uint8_t> bz2 =
      readAll(test::sharedData(kDir + "ros1_turtlesim/example-bz2.bag"));
  const std::vector<std::uint8_t> lz4 =
      readAll(test::sharedData(kDir + "ros1_turtlesim/example-lz4.bag"));
  const fs::path bad = test::tempDir() / "bad.bag";
  // Truncated at many lengths (the index is at the end: every cut loses it).
  for (const auto* bytes : {&uncompressed, &bz2, &lz4}) {
    for (std::size_t n = 0; n < bytes->size(); n += bytes->size() / 11 + 1) {
      writeAll(bad, std::vector<std::uint8_t>(bytes->begin(), bytes->begin() + n));
      EXPECT_CONTAINS(errorOf([&] { readEverything(bad); }), bad.string()) << n;
    }
  }
  // Bytes changed inside chunks and records: never a crash; an error or (for a change inside a
  // message's data) the same structure. 40 positions across each file.
  int errors = 0;
  for (const auto* bytes : {&uncompressed, &bz2, &lz4}) {
    for (int k = 0; k < 40; ++k) {
      std::vector<std::uint8_t> b = *bytes;
      const std::size_t at = 13 + (b.size() - 13) * static_cast<std::size_t>(k) / 40;
      b[at] ^= 0xFF;
      writeAll(bad, b);
      errors += errorOf([&] { readEverything(bad); }) != "<no error>";
    }
  }
  EXPECT_GT(errors, 0);
  // A record length pointing far beyond the file (the first chunk's header_len).
  std::vector<std::uint8_t> b = uncompressed;
  const std::uint32_t header_len = b[13] | b[14] << 8 | b[15] << 16 | b[16] << 24;
  const std::size_t bag_header_data_len_at = 13 + 4 + header_len;
  const std::uint32_t data_len = b[bag_header_data_len_at] | b[bag_header_data_len_at + 1] << 8 |
                                 b[bag_header_data_len_at + 2] << 16 |
                                 b[bag_header_data_len_at + 3] << 24;
  const std::size_t first_chunk = bag_header_data_len_at + 4 + data_len;
  b[first_chunk + 3] = 0x7F;  // header_len of the first chunk record: ~2 GB
  writeAll(bad, b);
  EXPECT_CONTAINS(errorOf([&] { readEverything(bad); }), "runs past the end");
  // Not a bag at all.
  writeAll(bad, {'#', 'R', 'O', 'S', 'B', 'A', 'G', ' ', 'V', '1', '.', '2', '\n'});
  EXPECT_CONTAINS(errorOf([&] { readEverything(bad); }), "not a ROS 1 bag of format 2.0");
}

TEST(Rosbag1, ABuildWithoutRos1RefusesBagsSayingSo) {
  if (ros1BagsBuilt()) GTEST_SKIP() << "this build reads ROS 1 bags (OVO_WITH_ROS1=ON)";
  const fs::path dir = test::tempDir();
  test::writeTextFile(dir / "x.bag", "#ROSBAG V2.0\n");
  const std::string e = test::errorOf([&] { openBag(dir / "x.bag"); });
  EXPECT_CONTAINS(e, (dir / "x.bag").string());
  EXPECT_CONTAINS(e, "built without ROS 1 bags");
  EXPECT_CONTAINS(test::errorOf([&] { BagWriter::create(BagFormat::kRos1, dir / "y.bag"); }),
                  "built without ROS 1 bags");
  EXPECT_FALSE(fs::exists(dir / "y.bag"));
}

}  // namespace
}  // namespace ovo::io::bag
