// Serialized ROS messages, both wire formats in one place: ROS 1's (little endian, packed, no
// header) and ROS 2's CDR (OMG CDR / XCDR1, and XCDR2's plain form, little or big endian, after
// a 4-byte encapsulation header; every primitive aligned to its size relative to the end of that
// header, at most 4 in XCDR2). WireReader checks every length against the bytes left, so a
// truncated or mistyped message is an ovo::Error naming the message, the field and the offset,
// never an out-of-bounds read or a giant allocation. The four sensor_msgs types are decoded and
// encoded here; other types can be walked field by field with WireReader.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "io/ros_messages.hpp"

namespace ovo::io::ros {

/// ROS 1 serialization or ROS 2 CDR (with its encapsulation header).
enum class Wire { kRos1, kCdr };

class WireReader {
 public:
  /// kCdr: reads and checks the encapsulation header (00 00 CDR_BE, 00 01 CDR_LE, 00 06/00 07
  /// PLAIN_CDR2 BE/LE); others (parameter lists, delimited XCDR2) are an error. `where` starts
  /// every error message (e.g. "run.db3: topic /imu, message 12").
  WireReader(std::span<const std::uint8_t> bytes, Wire wire, std::string where);
  /// The reader keeps a view of the bytes: a temporary would leave it dangling.
  WireReader(std::vector<std::uint8_t>&&, Wire, std::string) = delete;

  std::uint8_t u8(const char* field);
  std::uint16_t u16(const char* field);
  std::uint32_t u32(const char* field);
  std::uint64_t u64(const char* field);
  std::int8_t i8(const char* field) { return static_cast<std::int8_t>(u8(field)); }
  std::int16_t i16(const char* field) { return static_cast<std::int16_t>(u16(field)); }
  std::int32_t i32(const char* field) { return static_cast<std::int32_t>(u32(field)); }
  std::int64_t i64(const char* field) { return static_cast<std::int64_t>(u64(field)); }
  float f32(const char* field);
  double f64(const char* field);
  /// ROS 1: uint32 length + bytes. CDR: uint32 length including the terminating NUL + bytes.
  std::string string(const char* field);
  /// A sequence's element count, checked: count * element_size bytes must be left.
  std::uint32_t sequenceLength(const char* field, std::size_t element_size);
  std::vector<std::uint8_t> byteSequence(const char* field);
  std::vector<float> floatSequence(const char* field);
  /// std_msgs/Header of either wire (ROS 1: seq, stamp, frame_id; ROS 2: stamp, frame_id).
  Header header();

  std::size_t offset() const { return pos_; }  // from the start of the bytes
  std::size_t remaining() const { return bytes_.size() - pos_; }
  bool bigEndian() const { return big_endian_; }
  const std::string& where() const { return where_; }
  /// ROS 1 messages must be consumed exactly, CDR ones up to their final padding (< 8 bytes).
  void expectEnd(const char* type);
  [[noreturn]] void fail(const char* field, const std::string& what) const;

 private:
  void align(std::size_t size);
  const std::uint8_t* take(std::size_t n, const char* field);
  template <typename T>
  T scalar(const char* field);

  std::span<const std::uint8_t> bytes_;
  Wire wire_;
  std::string where_;
  std::size_t pos_ = 0;
  std::size_t origin_ = 0;     // alignment origin (after the CDR encapsulation header)
  std::size_t max_align_ = 8;  // 4 in XCDR2
  bool big_endian_ = false;
};

/// Writes ROS 1 messages or CDR (XCDR1, little endian unless big_endian) with its header.
class WireWriter {
 public:
  explicit WireWriter(Wire wire, bool big_endian = false);
  void u8(std::uint8_t v);
  void u16(std::uint16_t v);
  void u32(std::uint32_t v);
  void u64(std::uint64_t v);
  void i32(std::int32_t v) { u32(static_cast<std::uint32_t>(v)); }
  void f32(float v);
  void f64(double v);
  void string(const std::string& s);
  void byteSequence(const std::vector<std::uint8_t>& v);
  void floatSequence(const std::vector<float>& v);
  void header(const Header& h);
  std::vector<std::uint8_t> take() { return std::move(out_); }

 private:
  void align(std::size_t size);
  template <typename T>
  void scalar(T v);

  Wire wire_;
  bool big_endian_;
  std::vector<std::uint8_t> out_;
  std::size_t origin_ = 0;
};

/// Decoders: throw ovo::Error naming `where`, the field and the offset on malformed bytes.
Image decodeImage(std::span<const std::uint8_t> bytes, Wire wire, const std::string& where);
CompressedImage decodeCompressedImage(std::span<const std::uint8_t> bytes, Wire wire,
                                      const std::string& where);
Imu decodeImu(std::span<const std::uint8_t> bytes, Wire wire, const std::string& where);
LaserScan decodeLaserScan(std::span<const std::uint8_t> bytes, Wire wire, const std::string& where);
/// Only the header (the first field of all four types): cheap for images.
Header decodeHeader(std::span<const std::uint8_t> bytes, Wire wire, const std::string& where);

std::vector<std::uint8_t> encode(const Image& m, Wire wire, bool big_endian = false);
std::vector<std::uint8_t> encode(const CompressedImage& m, Wire wire, bool big_endian = false);
std::vector<std::uint8_t> encode(const Imu& m, Wire wire, bool big_endian = false);
std::vector<std::uint8_t> encode(const LaserScan& m, Wire wire, bool big_endian = false);

/// The ROS 2 message definitions (the ros2msg schema text: the type, then each nested type after
/// a line of '=' and "MSG: pkg/msg/Type") that ovo writes into MCAP schemas and db3 files.
std::string ros2MessageDefinition(MsgType type);
/// "sensor_msgs/msg/Imu" etc.
std::string ros2TypeName(MsgType type);

}  // namespace ovo::io::ros
