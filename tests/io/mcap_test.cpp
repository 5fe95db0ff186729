// MCAP files (io/mcap.hpp): the real fixtures written by rosbag2 and the MCAP Go CLI read with the
// counts, channels, times and CRCs their manifest gives; files ovo writes (zstd, lz4, none) read
// back; every kind of damage (truncation, a bad chunk CRC or length, an unknown compression, no
// magic) is an ovo::Error naming the file, never a crash.
#include "io/mcap.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "tests/test_support.hpp"

namespace ovo::io::mcap {
namespace {

namespace fs = std::filesystem;
using test::errorOf;

const char* kTalker = "rosbag-fixtures/ros2_talker_mcap_zstd/talker.mcap";
const char* kCdrTest = "rosbag-fixtures/ros2_cdr_test_mcap/cdr_test_0.mcap";
const char* kServices =
    "rosbag-fixtures/ros2_service_events_mcap/bag_with_topics_and_service_events.mcap";

std::vector<std::uint8_t> readAll(const fs::path& f) {
  std::ifstream in(f, std::ios::binary);
  return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(in), {});
}
void writeAll(const fs::path& f, const std::vector<std::uint8_t>& b) {
  std::ofstream out(f, std::ios::binary);
  out.write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
}

TEST(Mcap, Crc32MatchesTheStandardCheckValue) {
  const std::string s = "123456789";
  EXPECT_EQ(crc32({reinterpret_cast<const std::uint8_t*>(s.data()), s.size()}), 0xCBF43926u);
  // Continuing a CRC over two pieces gives the CRC of the whole.
  const auto* p = reinterpret_cast<const std::uint8_t*>(s.data());
  EXPECT_EQ(crc32({p + 4, 5}, crc32({p, 4})), 0xCBF43926u);
}

TEST(Mcap, TalkerFixtureWithAZstdChunk) {
  OVO_REQUIRE_DATA(kTalker);
  const Reader r(test::sharedData(kTalker));
  EXPECT_EQ(r.profile(), "ros2");
  EXPECT_EQ(r.library(), "mcap go #(devel)");
  ASSERT_EQ(r.chunks().size(), 1u);
  EXPECT_EQ(r.chunks()[0].compression, "zstd");
  EXPECT_EQ(r.chunks()[0].compressed_size, 2912u);
  EXPECT_EQ(r.chunks()[0].uncompressed_size, 11814u);
  EXPECT_EQ(r.chunks()[0].uncompressed_crc, 1458760412u);  // checked while reading
  ASSERT_EQ(r.schemas().size(), 3u);
  EXPECT_EQ(r.schemas().at(3).name, "std_msgs/msg/String");
  EXPECT_EQ(r.schemas().at(1).encoding, "ros2msg");
  ASSERT_EQ(r.channels().size(), 3u);
  EXPECT_EQ(r.channels().at(1).topic, "/rosout");
  EXPECT_EQ(r.channels().at(3).topic, "/topic");
  EXPECT_EQ(r.channels().at(3).message_encoding, "cdr");
  EXPECT_TRUE(r.channels().at(3).metadata.count("offered_qos_profiles"));
  ASSERT_TRUE(r.statistics());
  EXPECT_EQ(r.statistics()->message_count, 20u);
  EXPECT_EQ(r.statistics()->chunk_count, 1u);
  EXPECT_EQ(r.statistics()->message_start_time, 1585866235112411371u);
  EXPECT_EQ(r.statistics()->message_end_time, 1585866239643508139u);
  ASSERT_EQ(r.messages().size(), 20u);
  // /topic: sequence 0..9, publish_time == log_time, "Hello, world! i" in order.
  int i = 0;
  for (const MessageLocation& m : r.messages()) {
    EXPECT_EQ(m.publish_time, m.log_time);
    if (m.channel_id != 3) continue;
    EXPECT_EQ(m.sequence, static_cast<std::uint32_t>(i));
    const auto data = r.messageData(m);
    ASSERT_EQ(data.size(), 24u);
    const std::string text(data.begin() + 8, data.end() - 1);
    EXPECT_EQ(text, "Hello, world! " + std::to_string(i));
    ++i;
  }
  EXPECT_EQ(i, 10);
}

TEST(Mcap, UncompressedFixturesWithZeroCrcsAndSummaryOnlyChannels) {
  OVO_REQUIRE_DATA(kCdrTest);
  const Reader cdr(test::sharedData(kCdrTest));
  EXPECT_EQ(cdr.library(), "libmcap 0.8.0");
  ASSERT_EQ(cdr.chunks().size(), 1u);
  EXPECT_EQ(cdr.chunks()[0].compression, "");
  EXPECT_EQ(cdr.chunks()[0].uncompressed_crc, 0u);  // not computed: accepted
  EXPECT_EQ(cdr.messages().size(), 7u);
  EXPECT_EQ(cdr.statistics()->schema_count, 2u);
  EXPECT_TRUE(cdr.metadata().empty());

  OVO_REQUIRE_DATA(kServices);
  const Reader svc(test::sharedData(kServices));
  EXPECT_EQ(svc.library(), "libmcap 1.1.0");
  EXPECT_EQ(svc.messages().size(), 10u);
  // The Statistics record undercounts: the summary holds 3 schemas and 5 channels.
  EXPECT_EQ(svc.statistics()->schema_count, 2u);
  EXPECT_EQ(svc.statistics()->channel_count, 4u);
  EXPECT_EQ(svc.schemas().size(), 3u);
  EXPECT_EQ(svc.channels().size(), 5u);
  bool split_event = false;
  for (const auto& [id, ch] : svc.channels()) split_event |= ch.topic == "/events/write_split";
  EXPECT_TRUE(split_event);
  ASSERT_EQ(svc.metadata().size(), 2u);
  EXPECT_EQ(svc.metadata()[0].first, "rosbag2");
  EXPECT_EQ(svc.metadata()[1].second.at("serialized_metadata").size(), 3450u);
  EXPECT_EQ(svc.messages().front().log_time, 1699345836270074454u);
}

void writeSample(const fs::path& file, const std::string& compression, std::size_t chunk_size) {
  Writer w(file, "ros2", compression, chunk_size);
  const auto schema = w.addSchema("pkg/msg/Thing", "ros2msg", "int32 a");
  const auto a = w.addChannel(schema, "/a", "cdr", {{"k", "v"}});
  const auto b = w.addChannel(schema, "/b", "cdr", {});
  for (std::uint64_t t = 0; t < 300; ++t) {
    std::vector<std::uint8_t> data(50 + t % 7, static_cast<std::uint8_t>(t));
    w.write(t % 3 == 0 ? b : a, 1000 + t, 1000 + t, data);
  }
  w.addMetadata("note", {{"x", "y"}});
  w.close();
}

TEST(Mcap, WrittenFilesReadBackInEveryCompression) {
  for (const std::string compression : {"", "zstd", "lz4"}) {
    const fs::path file = test::tempDir() / ("w_" + compression + ".mcap");
    writeSample(file, compression, 4000);
    const Reader r(file);
    EXPECT_EQ(r.library(), "ovo");
    EXPECT_GT(r.chunks().size(), 3u) << compression;
    for (const ChunkInfo& c : r.chunks()) {
      EXPECT_EQ(c.compression, compression);
      EXPECT_NE(c.uncompressed_crc, 0u);
    }
    ASSERT_EQ(r.messages().size(), 300u);
    ASSERT_TRUE(r.statistics());
    EXPECT_EQ(r.statistics()->message_count, 300u);
    EXPECT_EQ(r.statistics()->channel_message_counts.at(2), 100u);
    EXPECT_EQ(r.channels().at(1).metadata.at("k"), "v");
    ASSERT_EQ(r.metadata().size(), 1u);
    for (std::size_t t = 0; t < 300; ++t) {
      const MessageLocation& m = r.messages()[t];
      EXPECT_EQ(m.log_time, 1000 + t);
      const auto data = r.messageData(m);
      ASSERT_EQ(data.size(), 50 + t % 7);
      EXPECT_EQ(data.front(), static_cast<std::uint8_t>(t));
    }
  }
}

// Records built byte by byte from the specification (little endian, <op><u64 length><content>).
class RecordBytes {
 public:
  explicit RecordBytes(std::uint8_t op) : op_(op) {}
  template <typename T>
  RecordBytes& num(T v) {
    for (std::size_t i = 0; i < sizeof(T); ++i)
      body_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
    return *this;
  }
  RecordBytes& str(const std::string& s) {
    num<std::uint32_t>(static_cast<std::uint32_t>(s.size()));
    body_.insert(body_.end(), s.begin(), s.end());
    return *this;
  }
  void appendTo(std::vector<std::uint8_t>& out) const {
    out.push_back(op_);
    for (int i = 0; i < 8; ++i) out.push_back(static_cast<std::uint8_t>(body_.size() >> (8 * i)));
    out.insert(out.end(), body_.begin(), body_.end());
  }

 private:
  std::uint8_t op_;
  std::vector<std::uint8_t> body_;
};

TEST(Mcap, MessagesOutsideChunksWithoutASummary) {
  const std::vector<std::uint8_t> magic = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};
  std::vector<std::uint8_t> b = magic;
  RecordBytes(0x01).str("").str("hand").appendTo(b);                                     // Header
  RecordBytes(0x03).num<std::uint16_t>(1).str("T").str("ros2msg").str("x").appendTo(b);  // Schema
  RecordBytes(0x04)
      .num<std::uint16_t>(7)
      .num<std::uint16_t>(1)
      .str("/t")
      .str("cdr")
      .num<std::uint32_t>(0)
      .appendTo(b);  // Channel, empty metadata map
  for (std::uint64_t t : {30, 10, 20}) {
    RecordBytes m(0x05);
    m.num<std::uint16_t>(7).num<std::uint32_t>(0).num<std::uint64_t>(t).num<std::uint64_t>(t);
    m.num<std::uint8_t>(static_cast<std::uint8_t>(t));  // one byte of data
    m.appendTo(b);
  }
  RecordBytes(0x0F).num<std::uint32_t>(0).appendTo(b);  // Data End
  RecordBytes(0x02).num<std::uint64_t>(0).num<std::uint64_t>(0).num<std::uint32_t>(0).appendTo(b);
  b.insert(b.end(), magic.begin(), magic.end());
  const fs::path file = test::tempDir() / "hand.mcap";
  writeAll(file, b);
  const Reader r(file);
  EXPECT_EQ(r.library(), "hand");
  EXPECT_TRUE(r.chunks().empty());
  EXPECT_FALSE(r.statistics());
  EXPECT_EQ(r.channels().at(7).topic, "/t");
  ASSERT_EQ(r.messages().size(), 3u);
  EXPECT_EQ(r.messages()[0].chunk, MessageLocation::kNoChunk);
  EXPECT_EQ(r.messageData(r.messages()[1]), std::vector<std::uint8_t>{10});
  // A message on a channel never defined.
  std::vector<std::uint8_t> bad = b;
  // Magic 8, Header 9 + 12, Schema 9 + 23, Channel 9 + 21, then the first message's opcode+length.
  const std::size_t channel_id_at = 8 + 21 + 32 + 30 + 9;
  ASSERT_EQ(bad[channel_id_at], 7);
  bad[channel_id_at] = 8;
  writeAll(file, bad);
  EXPECT_CONTAINS(test::errorOf([&] { Reader x(file); }), "a message on channel 8");
}

TEST(Mcap, DamagedFilesAreErrorsNamingTheFile) {
  const fs::path dir = test::tempDir();
  const fs::path good = dir / "good.mcap";
  writeSample(good, "zstd", 1 << 20);  // one chunk
  const std::vector<std::uint8_t> bytes = readAll(good);
  const Reader ok(good);
  ASSERT_EQ(ok.chunks().size(), 1u);
  const ChunkInfo chunk = ok.chunks()[0];
  const fs::path bad = dir / "bad.mcap";

  // Truncated anywhere: an error, never a crash (every 97th length and the last 30).
  for (std::size_t n = 0; n < bytes.size(); n += (n + 30 < bytes.size() ? 97 : 1)) {
    writeAll(bad, std::vector<std::uint8_t>(bytes.begin(), bytes.begin() + n));
    const std::string e = errorOf([&] { Reader r(bad); });
    EXPECT_CONTAINS(e, bad.string());
  }
  writeAll(bad, std::vector<std::uint8_t>(bytes.begin(), bytes.begin() + bytes.size() / 2));
  EXPECT_CONTAINS(errorOf([&] { Reader r(bad); }), "truncated");

  // A flipped byte in the compressed records: zstd or the CRC catches it.
  std::vector<std::uint8_t> b = bytes;
  b[chunk.records_offset + chunk.compressed_size / 2] ^= 0x5A;
  writeAll(bad, b);
  EXPECT_CONTAINS(errorOf([&] { Reader r(bad); }), "chunk 0");

  // The chunk's CRC field itself wrong.
  b = bytes;
  const std::size_t crc_at = chunk.record_offset + 9 + 24;
  b[crc_at] ^= 0x01;
  writeAll(bad, b);
  EXPECT_CONTAINS(errorOf([&] { Reader r(bad); }), "CRC-32");

  // The uncompressed size field wrong.
  b = bytes;
  b[chunk.record_offset + 9 + 16] ^= 0x01;
  writeAll(bad, b);
  EXPECT_CONTAINS(errorOf([&] { Reader r(bad); }), "chunk 0");

  // A compressed length beyond the record.
  b = bytes;
  const std::size_t len_at = chunk.records_offset - 8;
  b[len_at + 3] = 0x7F;
  writeAll(bad, b);
  EXPECT_CONTAINS(errorOf([&] { Reader r(bad); }), "'records' needs");

  // An unknown compression name of the same length ("zstd" -> "brot").
  b = bytes;
  std::memcpy(&b[chunk.records_offset - 8 - 4], "brot", 4);
  writeAll(bad, b);
  EXPECT_CONTAINS(errorOf([&] { Reader r(bad); }),
                  "chunk compression 'brot' is not supported (expected zstd, lz4 or none)");

  // No magic.
  b = bytes;
  b[1] = 'X';
  writeAll(bad, b);
  EXPECT_CONTAINS(errorOf([&] { Reader r(bad); }), "not an MCAP file");
  EXPECT_CONTAINS(errorOf([&] { Reader r(dir / "missing.mcap"); }), "cannot open");
}

}  // namespace
}  // namespace ovo::io::mcap
