#include "io/cdr.hpp"

#include <fmt/format.h>

#include <bit>
#include <cstring>

#include "common/error.hpp"

namespace ovo::io::ros {

namespace {

template <typename T>
T byteSwap(T v) {
  std::uint8_t b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
  std::memcpy(&v, b, sizeof(T));
  return v;
}

constexpr bool kHostBig = std::endian::native == std::endian::big;

// Time stamps: ROS 1 uint32 sec + uint32 nsec, ROS 2 int32 sec + uint32 nanosec.
Timestamp stampNs(std::int64_t sec, std::uint32_t nsec) {
  return sec * 1'000'000'000LL + static_cast<std::int64_t>(nsec);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// WireReader

WireReader::WireReader(std::span<const std::uint8_t> bytes, Wire wire, std::string where)
    : bytes_(bytes), wire_(wire), where_(std::move(where)) {
  if (wire_ != Wire::kCdr) return;
  if (bytes_.size() < 4)
    ::ovo::fail("{}: {} bytes: expected at least the 4-byte CDR encapsulation header", where_,
                bytes_.size());
  const unsigned id = (unsigned{bytes_[0]} << 8) | bytes_[1];
  switch (id) {
    case 0x0000:
      big_endian_ = true;
      break;  // CDR_BE
    case 0x0001:
      big_endian_ = false;
      break;  // CDR_LE
    case 0x0006:
      big_endian_ = true;
      max_align_ = 4;
      break;  // PLAIN_CDR2_BE
    case 0x0007:
      big_endian_ = false;
      max_align_ = 4;
      break;  // PLAIN_CDR2_LE
    default:
      ::ovo::fail(
          "{}: CDR representation 0x{:04x} is not supported (expected 0x0000/0x0001 plain CDR "
          "or 0x0006/0x0007 plain XCDR2, big/little endian)",
          where_, id);
  }
  pos_ = origin_ = 4;
}

void WireReader::fail(const char* field, const std::string& what) const {
  ::ovo::fail("{}: byte {} ({}): {}", where_, pos_, field, what);
}

void WireReader::align(std::size_t size) {
  if (wire_ != Wire::kCdr) return;
  const std::size_t a = std::min(size, max_align_);
  const std::size_t rel = pos_ - origin_;
  const std::size_t pad = (a - rel % a) % a;
  pos_ = std::min(bytes_.size(), pos_ + pad);  // take() reports running out
}

const std::uint8_t* WireReader::take(std::size_t n, const char* field) {
  if (n > remaining())
    fail(field, fmt::format("needs {} bytes, only {} left (a truncated message, or not the type "
                            "expected)",
                            n, remaining()));
  const std::uint8_t* p = bytes_.data() + pos_;
  pos_ += n;
  return p;
}

template <typename T>
T WireReader::scalar(const char* field) {
  align(sizeof(T));
  T v;
  std::memcpy(&v, take(sizeof(T), field), sizeof(T));
  if (big_endian_ != kHostBig) v = byteSwap(v);
  return v;
}

std::uint8_t WireReader::u8(const char* field) { return *take(1, field); }
std::uint16_t WireReader::u16(const char* field) { return scalar<std::uint16_t>(field); }
std::uint32_t WireReader::u32(const char* field) { return scalar<std::uint32_t>(field); }
std::uint64_t WireReader::u64(const char* field) { return scalar<std::uint64_t>(field); }
float WireReader::f32(const char* field) { return std::bit_cast<float>(u32(field)); }
double WireReader::f64(const char* field) { return std::bit_cast<double>(u64(field)); }

std::string WireReader::string(const char* field) {
  const std::uint32_t n = u32(field);
  if (n > remaining()) fail(field, fmt::format("string of {} bytes, only {} left", n, remaining()));
  const char* p = reinterpret_cast<const char*>(take(n, field));
  if (wire_ == Wire::kCdr && n > 0) {
    if (p[n - 1] != '\0') fail(field, "CDR string without its terminating NUL");
    return std::string(p, n - 1);
  }
  return std::string(p, n);
}

std::uint32_t WireReader::sequenceLength(const char* field, std::size_t element_size) {
  const std::uint32_t n = u32(field);
  if (element_size > 0 && n > remaining() / element_size)
    fail(field, fmt::format("sequence of {} elements of {} bytes, only {} bytes left", n,
                            element_size, remaining()));
  return n;
}

std::vector<std::uint8_t> WireReader::byteSequence(const char* field) {
  const std::uint32_t n = sequenceLength(field, 1);
  const std::uint8_t* p = take(n, field);
  return std::vector<std::uint8_t>(p, p + n);
}

std::vector<float> WireReader::floatSequence(const char* field) {
  const std::uint32_t n = sequenceLength(field, 4);
  align(4);
  if (n > remaining() / 4)  // alignment may have used up to 3 more bytes
    fail(field, fmt::format("sequence of {} float32, only {} bytes left", n, remaining()));
  std::vector<float> v(n);
  const std::uint8_t* p = take(std::size_t{n} * 4, field);
  for (std::uint32_t i = 0; i < n; ++i) {
    std::uint32_t u;
    std::memcpy(&u, p + 4 * i, 4);
    if (big_endian_ != kHostBig) u = byteSwap(u);
    v[i] = std::bit_cast<float>(u);
  }
  return v;
}

Header WireReader::header() {
  Header h;
  if (wire_ == Wire::kRos1) {
    h.seq = u32("header.seq");
    const std::uint32_t sec = u32("header.stamp.sec");
    const std::uint32_t nsec = u32("header.stamp.nsec");
    h.stamp_ns = stampNs(sec, nsec);
  } else {
    const std::int32_t sec = i32("header.stamp.sec");
    const std::uint32_t nsec = u32("header.stamp.nanosec");
    h.stamp_ns = stampNs(sec, nsec);
  }
  h.frame_id = string("header.frame_id");
  return h;
}

void WireReader::expectEnd(const char* type) {
  const std::size_t left = remaining();
  if (left == 0 || (wire_ == Wire::kCdr && left < 8)) return;
  ::ovo::fail("{}: {} bytes left after the end of a {} (expected {}): not that type", where_, left,
              type, wire_ == Wire::kCdr ? "less than 8 bytes of padding" : "none");
}

// ---------------------------------------------------------------------------------------------
// WireWriter

WireWriter::WireWriter(Wire wire, bool big_endian) : wire_(wire), big_endian_(big_endian) {
  if (wire_ == Wire::kCdr) {
    out_ = {0x00, static_cast<std::uint8_t>(big_endian_ ? 0x00 : 0x01), 0x00, 0x00};
    origin_ = 4;
  } else {
    big_endian_ = false;
  }
}

void WireWriter::align(std::size_t size) {
  if (wire_ != Wire::kCdr) return;
  while ((out_.size() - origin_) % size != 0) out_.push_back(0);
}

template <typename T>
void WireWriter::scalar(T v) {
  align(sizeof(T));
  if (big_endian_ != kHostBig) v = byteSwap(v);
  const auto* p = reinterpret_cast<const std::uint8_t*>(&v);
  out_.insert(out_.end(), p, p + sizeof(T));
}

void WireWriter::u8(std::uint8_t v) { out_.push_back(v); }
void WireWriter::u16(std::uint16_t v) { scalar(v); }
void WireWriter::u32(std::uint32_t v) { scalar(v); }
void WireWriter::u64(std::uint64_t v) { scalar(v); }
void WireWriter::f32(float v) { scalar(std::bit_cast<std::uint32_t>(v)); }
void WireWriter::f64(double v) { scalar(std::bit_cast<std::uint64_t>(v)); }

void WireWriter::string(const std::string& s) {
  const bool cdr = wire_ == Wire::kCdr;
  u32(static_cast<std::uint32_t>(s.size() + (cdr ? 1 : 0)));
  out_.insert(out_.end(), s.begin(), s.end());
  if (cdr) out_.push_back(0);
}

void WireWriter::byteSequence(const std::vector<std::uint8_t>& v) {
  u32(static_cast<std::uint32_t>(v.size()));
  out_.insert(out_.end(), v.begin(), v.end());
}

void WireWriter::floatSequence(const std::vector<float>& v) {
  u32(static_cast<std::uint32_t>(v.size()));
  for (float f : v) f32(f);
}

void WireWriter::header(const Header& h) {
  const std::int64_t sec =
      h.stamp_ns >= 0 ? h.stamp_ns / 1'000'000'000 : -((-h.stamp_ns + 999'999'999) / 1'000'000'000);
  const auto nsec = static_cast<std::uint32_t>(h.stamp_ns - sec * 1'000'000'000);
  if (wire_ == Wire::kRos1) {
    if (sec < 0 || sec > 0xffffffffLL)
      fail("cannot write time stamp {} ns as ROS 1 time (expected 0 to 2^32 s)", h.stamp_ns);
    u32(h.seq);
    u32(static_cast<std::uint32_t>(sec));
  } else {
    if (sec < INT32_MIN || sec > INT32_MAX)
      fail("cannot write time stamp {} ns as ROS 2 time (int32 seconds)", h.stamp_ns);
    i32(static_cast<std::int32_t>(sec));
  }
  u32(nsec);
  string(h.frame_id);
}

// ---------------------------------------------------------------------------------------------
// sensor_msgs

Header decodeHeader(std::span<const std::uint8_t> bytes, Wire wire, const std::string& where) {
  WireReader r(bytes, wire, where);
  return r.header();
}

Image decodeImage(std::span<const std::uint8_t> bytes, Wire wire, const std::string& where) {
  WireReader r(bytes, wire, where);
  Image m;
  m.header = r.header();
  m.height = r.u32("height");
  m.width = r.u32("width");
  m.encoding = r.string("encoding");
  m.is_bigendian = r.u8("is_bigendian");
  m.step = r.u32("step");
  m.data = r.byteSequence("data");
  r.expectEnd("sensor_msgs/Image");
  return m;
}

CompressedImage decodeCompressedImage(std::span<const std::uint8_t> bytes, Wire wire,
                                      const std::string& where) {
  WireReader r(bytes, wire, where);
  CompressedImage m;
  m.header = r.header();
  m.format = r.string("format");
  m.data = r.byteSequence("data");
  r.expectEnd("sensor_msgs/CompressedImage");
  return m;
}

Imu decodeImu(std::span<const std::uint8_t> bytes, Wire wire, const std::string& where) {
  WireReader r(bytes, wire, where);
  Imu m;
  m.header = r.header();
  for (double& q : m.orientation_xyzw) q = r.f64("orientation");
  for (double& c : m.orientation_covariance) c = r.f64("orientation_covariance");
  for (int k = 0; k < 3; ++k) m.angular_velocity[k] = r.f64("angular_velocity");
  for (double& c : m.angular_velocity_covariance) c = r.f64("angular_velocity_covariance");
  for (int k = 0; k < 3; ++k) m.linear_acceleration[k] = r.f64("linear_acceleration");
  for (double& c : m.linear_acceleration_covariance) c = r.f64("linear_acceleration_covariance");
  r.expectEnd("sensor_msgs/Imu");
  return m;
}

LaserScan decodeLaserScan(std::span<const std::uint8_t> bytes, Wire wire,
                          const std::string& where) {
  WireReader r(bytes, wire, where);
  LaserScan m;
  m.header = r.header();
  m.angle_min = r.f32("angle_min");
  m.angle_max = r.f32("angle_max");
  m.angle_increment = r.f32("angle_increment");
  m.time_increment = r.f32("time_increment");
  m.scan_time = r.f32("scan_time");
  m.range_min = r.f32("range_min");
  m.range_max = r.f32("range_max");
  m.ranges = r.floatSequence("ranges");
  m.intensities = r.floatSequence("intensities");
  r.expectEnd("sensor_msgs/LaserScan");
  return m;
}

std::vector<std::uint8_t> encode(const Image& m, Wire wire, bool big_endian) {
  WireWriter w(wire, big_endian);
  w.header(m.header);
  w.u32(m.height);
  w.u32(m.width);
  w.string(m.encoding);
  w.u8(m.is_bigendian);
  w.u32(m.step);
  w.byteSequence(m.data);
  return w.take();
}

std::vector<std::uint8_t> encode(const CompressedImage& m, Wire wire, bool big_endian) {
  WireWriter w(wire, big_endian);
  w.header(m.header);
  w.string(m.format);
  w.byteSequence(m.data);
  return w.take();
}

std::vector<std::uint8_t> encode(const Imu& m, Wire wire, bool big_endian) {
  WireWriter w(wire, big_endian);
  w.header(m.header);
  for (double q : m.orientation_xyzw) w.f64(q);
  for (double c : m.orientation_covariance) w.f64(c);
  for (int k = 0; k < 3; ++k) w.f64(m.angular_velocity[k]);
  for (double c : m.angular_velocity_covariance) w.f64(c);
  for (int k = 0; k < 3; ++k) w.f64(m.linear_acceleration[k]);
  for (double c : m.linear_acceleration_covariance) w.f64(c);
  return w.take();
}

std::vector<std::uint8_t> encode(const LaserScan& m, Wire wire, bool big_endian) {
  WireWriter w(wire, big_endian);
  w.header(m.header);
  for (double v : {m.angle_min, m.angle_max, m.angle_increment, m.time_increment, m.scan_time,
                   m.range_min, m.range_max})
    w.f32(static_cast<float>(v));
  w.floatSequence(m.ranges);
  w.floatSequence(m.intensities);
  return w.take();
}

// ---------------------------------------------------------------------------------------------
// ROS 2 message definitions (ros2msg), as rosbag2 stores them: the type, then its nested types.

namespace {

constexpr const char* kSeparator =
    "\n================================================================================\n";

constexpr const char* kHeaderDef =
    "MSG: std_msgs/Header\n"
    "builtin_interfaces/Time stamp\n"
    "string frame_id";
constexpr const char* kTimeDef =
    "MSG: builtin_interfaces/Time\n"
    "int32 sec\n"
    "uint32 nanosec";
constexpr const char* kQuaternionDef =
    "MSG: geometry_msgs/Quaternion\n"
    "float64 x 0\n"
    "float64 y 0\n"
    "float64 z 0\n"
    "float64 w 1";
constexpr const char* kVector3Def =
    "MSG: geometry_msgs/Vector3\n"
    "float64 x\n"
    "float64 y\n"
    "float64 z";

}  // namespace

std::string ros2TypeName(MsgType type) {
  switch (type) {
    case MsgType::kImage:
      return "sensor_msgs/msg/Image";
    case MsgType::kCompressedImage:
      return "sensor_msgs/msg/CompressedImage";
    case MsgType::kImu:
      return "sensor_msgs/msg/Imu";
    case MsgType::kLaserScan:
      return "sensor_msgs/msg/LaserScan";
    case MsgType::kOther:
      break;
  }
  fail("ros2TypeName: not a sensor_msgs type ovo writes");
}

std::string ros2MessageDefinition(MsgType type) {
  std::string head;
  switch (type) {
    case MsgType::kImage:
      head =
          "std_msgs/Header header\n"
          "uint32 height\n"
          "uint32 width\n"
          "string encoding\n"
          "uint8 is_bigendian\n"
          "uint32 step\n"
          "uint8[] data";
      break;
    case MsgType::kCompressedImage:
      head =
          "std_msgs/Header header\n"
          "string format\n"
          "uint8[] data";
      break;
    case MsgType::kImu:
      head =
          "std_msgs/Header header\n"
          "geometry_msgs/Quaternion orientation\n"
          "float64[9] orientation_covariance\n"
          "geometry_msgs/Vector3 angular_velocity\n"
          "float64[9] angular_velocity_covariance\n"
          "geometry_msgs/Vector3 linear_acceleration\n"
          "float64[9] linear_acceleration_covariance";
      return head + kSeparator + kHeaderDef + kSeparator + kTimeDef + kSeparator + kQuaternionDef +
             kSeparator + kVector3Def;
    case MsgType::kLaserScan:
      head =
          "std_msgs/Header header\n"
          "float32 angle_min\n"
          "float32 angle_max\n"
          "float32 angle_increment\n"
          "float32 time_increment\n"
          "float32 scan_time\n"
          "float32 range_min\n"
          "float32 range_max\n"
          "float32[] ranges\n"
          "float32[] intensities";
      break;
    case MsgType::kOther:
      fail("ros2MessageDefinition: not a sensor_msgs type ovo writes");
  }
  return head + kSeparator + kHeaderDef + kSeparator + kTimeDef;
}

}  // namespace ovo::io::ros
