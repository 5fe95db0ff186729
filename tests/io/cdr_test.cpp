// Serialized ROS messages (io/cdr.hpp, io/ros_messages.hpp): byte buffers built by hand from the
// OMG CDR rules (XCDR1: alignment to the primitive's size from the end of the encapsulation
// header; XCDR2: at most 4; big and little endian) and ROS 1's packed format decode to the values
// put in, the encoders write exactly those bytes, and every malformed buffer is an ovo::Error.
#include "io/cdr.hpp"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <opencv2/imgcodecs.hpp>

#include "tests/test_support.hpp"

namespace ovo::io::ros {
namespace {

using test::errorOf;

// Builds a byte buffer field by field (explicit padding, explicit byte order).
class Bytes {
 public:
  explicit Bytes(bool big_endian = false) : big_(big_endian) {}
  Bytes& raw(std::initializer_list<int> bytes) {
    for (int b : bytes) v.push_back(static_cast<std::uint8_t>(b));
    return *this;
  }
  Bytes& pad(int n) {
    for (int i = 0; i < n; ++i) v.push_back(0);
    return *this;
  }
  template <typename T>
  Bytes& num(T x) {
    std::uint8_t b[sizeof(T)];
    std::memcpy(b, &x, sizeof(T));  // host is little endian (x86)
    if (big_)
      for (int i = static_cast<int>(sizeof(T)) - 1; i >= 0; --i) v.push_back(b[i]);
    else
      for (std::size_t i = 0; i < sizeof(T); ++i) v.push_back(b[i]);
    return *this;
  }
  Bytes& chars(const std::string& s, bool nul) {
    for (char c : s) v.push_back(static_cast<std::uint8_t>(c));
    if (nul) v.push_back(0);
    return *this;
  }
  std::vector<std::uint8_t> v;

 private:
  bool big_;
};

// sensor_msgs/Imu in CDR little endian with frame_id "base": the string ends 17 bytes after the
// encapsulation header, so the first float64 is preceded by 7 bytes of padding (to 24).
Bytes imuCdrLe() {
  Bytes b;
  b.raw({0x00, 0x01, 0x00, 0x00});                                // CDR_LE, options 0
  b.num<std::int32_t>(1700000000).num<std::uint32_t>(123456789);  // stamp
  b.num<std::uint32_t>(5).chars("base", true);                    // length includes the NUL
  b.pad(7);                                                       // 17 -> 24
  for (double q : {0.1, 0.2, 0.3, 0.9}) b.num(q);                 // orientation
  for (int i = 0; i < 9; ++i) b.num(i == 0 ? -1.0 : 0.0);
  for (double w : {0.01, -0.02, 0.03}) b.num(w);  // angular_velocity
  for (int i = 0; i < 9; ++i) b.num(0.0);
  for (double a : {0.5, -0.25, 9.81}) b.num(a);  // linear_acceleration
  for (int i = 0; i < 9; ++i) b.num(i == 8 ? 2.5e-5 : 0.0);
  return b;
}

TEST(Cdr, ImuLittleEndianDecodesWithItsPadding) {
  const Bytes b = imuCdrLe();
  ASSERT_EQ(b.v.size(), 4u + 24u + 4 * 8 + 3 * (9 * 8) + 2 * (3 * 8));
  const Imu m = decodeImu(b.v, Wire::kCdr, "imu");
  EXPECT_EQ(m.header.stamp_ns, 1700000000LL * 1'000'000'000 + 123456789);
  EXPECT_EQ(m.header.frame_id, "base");
  EXPECT_EQ(m.orientation_xyzw[3], 0.9);
  EXPECT_EQ(m.orientation_covariance[0], -1.0);
  EXPECT_EQ(m.angular_velocity, Vec3(0.01, -0.02, 0.03));
  EXPECT_EQ(m.linear_acceleration, Vec3(0.5, -0.25, 9.81));
  EXPECT_EQ(m.linear_acceleration_covariance[8], 2.5e-5);
  // The encoder writes exactly these bytes.
  EXPECT_EQ(encode(m, Wire::kCdr), b.v);
}

TEST(Cdr, LaserScanBigEndianDecodes) {
  Bytes b(/*big_endian=*/true);
  b.raw({0x00, 0x00, 0x00, 0x00});                          // CDR_BE
  b.num<std::int32_t>(12).num<std::uint32_t>(500'000'000);  // 12.5 s
  b.num<std::uint32_t>(6).chars("laser", true);             // 8..17
  b.pad(2);                                                 // 18 -> 20 for float32
  for (float f : {-2.0f, 2.0f, 0.5f, 1e-4f, 0.1f, 0.02f, 30.0f}) b.num(f);
  b.num<std::uint32_t>(3);
  for (float r : {1.5f, std::numeric_limits<float>::infinity(), 2.25f}) b.num(r);
  b.num<std::uint32_t>(0);  // no intensities
  const LaserScan m = decodeLaserScan(b.v, Wire::kCdr, "scan");
  EXPECT_EQ(m.header.stamp_ns, 12'500'000'000LL);
  EXPECT_EQ(m.header.frame_id, "laser");
  EXPECT_EQ(m.angle_min, -2.0);
  EXPECT_EQ(m.angle_increment, 0.5);
  EXPECT_EQ(m.time_increment, static_cast<double>(1e-4f));
  EXPECT_EQ(m.range_max, 30.0);
  ASSERT_EQ(m.ranges.size(), 3u);
  EXPECT_EQ(m.ranges[2], 2.25f);
  EXPECT_TRUE(m.intensities.empty());
  EXPECT_EQ(encode(m, Wire::kCdr, /*big_endian=*/true), b.v);
  // As ovo's scan: the infinite range is no return, the beam time kept.
  const LidarScan s = lidarScan(m, m.header.stamp_ns, "scan");
  EXPECT_TRUE(std::isnan(s.ranges_m[1]));
  EXPECT_FALSE(s.valid(1));
  EXPECT_EQ(s.time_increment_s, static_cast<double>(1e-4f));
}

TEST(Cdr, Xcdr2AlignsEightByteValuesToFour) {
  // PLAIN_CDR2_LE: the float64 after frame_id "base" (ending at 17) starts at 20, not 24.
  Bytes b;
  b.raw({0x00, 0x07, 0x00, 0x00});
  b.num<std::int32_t>(1).num<std::uint32_t>(2);
  b.num<std::uint32_t>(5).chars("base", true);
  b.pad(3);
  for (double q : {0.0, 0.0, 0.0, 1.0}) b.num(q);
  for (int i = 0; i < 9 + 3 + 9 + 3 + 9; ++i) b.num(static_cast<double>(i));
  const Imu m = decodeImu(b.v, Wire::kCdr, "imu");
  EXPECT_EQ(m.orientation_xyzw[3], 1.0);
  EXPECT_EQ(m.angular_velocity, Vec3(9, 10, 11));
  EXPECT_EQ(m.linear_acceleration_covariance[8], 32.0);
}

TEST(Cdr, Ros1ImageIsPackedWithoutPadding) {
  Bytes b;
  b.num<std::uint32_t>(7).num<std::uint32_t>(100).num<std::uint32_t>(5);  // seq, sec, nsec
  b.num<std::uint32_t>(3).chars("cam", false);                            // ROS 1 strings: no NUL
  b.num<std::uint32_t>(2).num<std::uint32_t>(3);                          // height, width
  b.num<std::uint32_t>(5).chars("mono8", false);
  b.raw({0});               // is_bigendian
  b.num<std::uint32_t>(3);  // step, right after the byte: no alignment in ROS 1
  b.num<std::uint32_t>(6).raw({1, 2, 3, 4, 5, 6});
  const Image m = decodeImage(b.v, Wire::kRos1, "image");
  EXPECT_EQ(m.header.seq, 7u);
  EXPECT_EQ(m.header.stamp_ns, 100'000'000'005LL);
  EXPECT_EQ(m.header.frame_id, "cam");
  EXPECT_EQ(m.width, 3u);
  EXPECT_EQ(m.encoding, "mono8");
  EXPECT_EQ(m.step, 3u);
  const cv::Mat grey = greyImage(m, "image");
  ASSERT_EQ(grey.rows, 2);
  EXPECT_EQ(grey.at<std::uint8_t>(1, 2), 6);
  EXPECT_EQ(encode(m, Wire::kRos1), b.v);
}

template <typename Msg, typename Decode>
void expectRoundTrip(const Msg& m, Decode decode) {
  for (Wire wire : {Wire::kRos1, Wire::kCdr})
    for (bool big : {false, true}) {
      if (wire == Wire::kRos1 && big) continue;
      const auto bytes = encode(m, wire, big);
      const Msg back = decode(bytes, wire, "m");
      EXPECT_EQ(encode(back, wire, big), bytes);
    }
}

TEST(Cdr, EveryTypeRoundTripsInBothWiresAndByteOrders) {
  cv::Mat grey(5, 7, CV_8UC1);
  cv::randu(grey, 0, 255);
  Image image = imageMessage(grey, 1'234'567'890'123LL, "camera");
  expectRoundTrip(image, decodeImage);
  EXPECT_EQ(cv::norm(greyImage(decodeImage(encode(image, Wire::kCdr), Wire::kCdr, "m"), "m"), grey,
                     cv::NORM_INF),
            0.0);
  CompressedImage compressed;
  compressed.header.frame_id = "c";
  compressed.format = "png";
  cv::imencode(".png", grey, compressed.data);
  expectRoundTrip(compressed, decodeCompressedImage);
  EXPECT_EQ(cv::norm(greyImage(compressed, "c"), grey, cv::NORM_INF), 0.0);
  ImuSample s{42, Vec3(0.1, 0.2, -0.3), Vec3(0, 0, 9.8)};
  const Imu imu = imuMessage(s, "imu");
  expectRoundTrip(imu, decodeImu);
  const ImuSample back = imuSample(decodeImu(encode(imu, Wire::kCdr), Wire::kCdr, "m"), 42);
  EXPECT_EQ(back.gyro_radps, s.gyro_radps);
  EXPECT_EQ(back.accel_mps2, s.accel_mps2);
  LidarScan scan;
  scan.t_ns = 5'000'000'000LL;
  scan.angle_min_rad = -1.0;
  scan.angle_increment_rad = 0.01;
  scan.range_min_m = 0.1;
  scan.range_max_m = 10.0;
  scan.time_increment_s = 1.0 / 3600;
  scan.ranges_m = {1.0, std::nan(""), 3.0};
  const LaserScan ls = laserScanMessage(scan, 0.1, "laser");
  expectRoundTrip(ls, decodeLaserScan);
}

TEST(Cdr, TruncatedMessagesAreErrorsAtEveryLength) {
  LidarScan scan;
  scan.angle_increment_rad = 0.01;
  scan.range_max_m = 5;
  scan.ranges_m.assign(20, 1.0);
  const auto bytes = encode(laserScanMessage(scan, 0.1, "laser"), Wire::kCdr);
  for (std::size_t n = 0; n + 8 <= bytes.size(); ++n) {  // the last < 8 bytes may be padding
    const std::vector<std::uint8_t> cut(bytes.begin(), bytes.begin() + n);
    const std::string e = errorOf([&] { decodeLaserScan(cut, Wire::kCdr, "bag: topic /scan"); });
    EXPECT_CONTAINS(e, "bag: topic /scan");
  }
  const auto ros1 = encode(laserScanMessage(scan, 0.1, "laser"), Wire::kRos1);
  for (std::size_t n = 0; n < ros1.size(); ++n) {
    const std::vector<std::uint8_t> cut(ros1.begin(), ros1.begin() + n);
    EXPECT_NE(errorOf([&] { decodeLaserScan(cut, Wire::kRos1, "s"); }), "<no error>") << n;
  }
}

TEST(Cdr, MalformedLengthsAndHeadersAreErrors) {
  // A sequence claiming 2^32 - 16 floats: refused before any allocation.
  Bytes b;
  b.raw({0x00, 0x01, 0x00, 0x00}).num<std::int32_t>(0).num<std::uint32_t>(0);
  b.num<std::uint32_t>(1).chars("", true).pad(3);
  for (int i = 0; i < 7; ++i) b.num(0.0f);
  b.num<std::uint32_t>(0xFFFFFFF0u);
  EXPECT_CONTAINS(errorOf([&] { decodeLaserScan(b.v, Wire::kCdr, "x"); }),
                  "sequence of 4294967280 elements");
  // A string longer than the message.
  Bytes s;
  s.raw({0x00, 0x01, 0x00, 0x00}).num<std::int32_t>(0).num<std::uint32_t>(0);
  s.num<std::uint32_t>(1000).chars("abc", true);
  EXPECT_CONTAINS(errorOf([&] { decodeHeader(s.v, Wire::kCdr, "x"); }), "header.frame_id");
  // A CDR string without its NUL.
  Bytes n;
  n.raw({0x00, 0x01, 0x00, 0x00}).num<std::int32_t>(0).num<std::uint32_t>(0);
  n.num<std::uint32_t>(3).chars("abc", false);
  EXPECT_CONTAINS(errorOf([&] { decodeHeader(n.v, Wire::kCdr, "x"); }), "NUL");
  // Parameter-list CDR (PL_CDR_LE) is not a plain encoding.
  std::vector<std::uint8_t> pl = imuCdrLe().v;
  pl[1] = 0x03;
  EXPECT_CONTAINS(errorOf([&] { decodeImu(pl, Wire::kCdr, "x"); }), "representation 0x0003");
  // An Imu read as a LaserScan: bytes left over (ROS 1 must be consumed exactly).
  const auto imu_ros1 = encode(imuMessage({1, Vec3::Zero(), Vec3::Zero()}, "i"), Wire::kRos1);
  EXPECT_NE(errorOf([&] { decodeLaserScan(imu_ros1, Wire::kRos1, "x"); }), "<no error>");
  EXPECT_NE(errorOf([&] { decodeImage(imu_ros1, Wire::kRos1, "x"); }), "<no error>");
  EXPECT_CONTAINS(errorOf([&] { decodeImu({}, Wire::kCdr, "x"); }), "encapsulation header");
}

TEST(RosImage, EncodingsConvertToGrey) {
  Image rgb;
  rgb.width = 2;
  rgb.height = 1;
  rgb.encoding = "rgb8";
  rgb.step = 7;  // a padded row
  rgb.data = {255, 0, 0, 0, 0, 255, 99};
  const cv::Mat g = greyImage(rgb, "x");
  // OpenCV's weights: R 0.299, B 0.114.
  EXPECT_NEAR(g.at<std::uint8_t>(0, 0), 76, 1);
  EXPECT_NEAR(g.at<std::uint8_t>(0, 1), 29, 1);
  rgb.encoding = "bgr8";
  EXPECT_NEAR(greyImage(rgb, "x").at<std::uint8_t>(0, 0), 29, 1);
  Image mono16;
  mono16.width = 1;
  mono16.height = 1;
  mono16.encoding = "mono16";
  mono16.step = 2;
  mono16.data = {0x12, 0x34};  // little endian 0x3412
  EXPECT_EQ(greyImage(mono16, "x").at<std::uint8_t>(0, 0), 0x34);
  mono16.is_bigendian = 1;  // big endian 0x1234
  EXPECT_EQ(greyImage(mono16, "x").at<std::uint8_t>(0, 0), 0x12);
  Image bad = rgb;
  bad.encoding = "bayer_rggb8";
  EXPECT_CONTAINS(errorOf([&] { greyImage(bad, "bag: /cam #3"); }), "bag: /cam #3");
  EXPECT_CONTAINS(errorOf([&] { greyImage(bad, "x"); }), "'bayer_rggb8' is not supported");
  bad = rgb;
  bad.data.pop_back();
  bad.data.pop_back();
  EXPECT_CONTAINS(errorOf([&] { greyImage(bad, "x"); }), "expected at least 6");
  bad = rgb;
  bad.step = 5;
  EXPECT_CONTAINS(errorOf([&] { greyImage(bad, "x"); }), "step 5 bytes is less than a row");
  CompressedImage junk;
  junk.format = "jpeg";
  junk.data = {1, 2, 3};
  EXPECT_CONTAINS(errorOf([&] { greyImage(junk, "x"); }), "cannot decode the compressed image");
}

TEST(RosScan, BadScanHeadersAreErrors) {
  LaserScan m;
  m.angle_increment = 0.0;
  m.range_max = 5;
  m.ranges = {1.0f};
  EXPECT_CONTAINS(errorOf([&] { lidarScan(m, 0, "s"); }), "angle_increment");
  m.angle_increment = 0.1;
  m.range_min = 6;
  EXPECT_CONTAINS(errorOf([&] { lidarScan(m, 0, "s"); }), "range_min < range_max");
  m.range_min = 0;
  m.ranges.clear();
  EXPECT_CONTAINS(errorOf([&] { lidarScan(m, 0, "s"); }), "no ranges");
}

}  // namespace
}  // namespace ovo::io::ros
