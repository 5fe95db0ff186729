// ROS 2 bags (io/rosbag2_reader.hpp): the real rosbag2 fixtures, sqlite3 and MCAP, alone and as
// folders with metadata.yaml, read with the topics, counts and stamps of their manifest, the two
// back-ends give the same payloads, and test_msgs messages decode by hand from their CDR layout;
// damaged or unsupported bags are errors naming the file.
#include <gtest/gtest.h>

#include <fstream>
#include <map>

#include "io/bag_source.hpp"
#include "io/cdr.hpp"
#include "io/rosbag2_reader.hpp"
#include "tests/test_support.hpp"

namespace ovo::io::bag {
namespace {

namespace fs = std::filesystem;
using ros::Wire;
using test::errorOf;

const std::string kDir = "rosbag-fixtures/";

struct TopicCount {
  std::string type;
  std::uint64_t count;
  bool operator==(const TopicCount&) const = default;
};
std::map<std::string, TopicCount> topicsOf(const BagSource& bag) {
  std::map<std::string, TopicCount> m;
  for (const Topic& t : bag.topics()) m[t.name] = {t.type, t.count};
  return m;
}

std::vector<std::pair<std::string, std::vector<std::uint8_t>>> allMessages(const BagSource& bag) {
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> out;
  for (const MessageRef& m : bag.messages())
    out.emplace_back(bag.topics()[m.topic].name, bag.payload(m));
  return out;
}

TEST(Rosbag2, TalkerSqlite3AndMcapHoldTheSameMessages) {
  OVO_REQUIRE_DATA(kDir + "ros2_talker_sqlite3/talker.db3");
  const auto db = openBag(test::sharedData(kDir + "ros2_talker_sqlite3/talker.db3"));
  const auto folder = openBag(test::sharedData(kDir + "ros2_talker_sqlite3"));  // metadata.yaml
  const auto mcap = openBag(test::sharedData(kDir + "ros2_talker_mcap_zstd/talker.mcap"));
  EXPECT_EQ(db->kind(), "rosbag2 sqlite3");
  EXPECT_EQ(mcap->kind(), "MCAP");
  const std::map<std::string, TopicCount> expected = {
      {"/topic", {"std_msgs/msg/String", 10}},
      {"/rosout", {"rcl_interfaces/msg/Log", 10}},
      {"/parameter_events", {"rcl_interfaces/msg/ParameterEvent", 0}}};  // listed without messages
  for (const BagSource* bag : {db.get(), folder.get(), mcap.get()}) {
    SCOPED_TRACE(bag->path().string());
    EXPECT_EQ(topicsOf(*bag), expected);
    ASSERT_EQ(bag->messages().size(), 20u);
    EXPECT_EQ(bag->messages().front().log_time_ns, 1585866235112411371);
    EXPECT_EQ(bag->messages().back().log_time_ns, 1585866239643508139);
    for (const Topic& t : bag->topics()) EXPECT_EQ(t.encoding, "cdr");
  }
  const auto a = allMessages(*db), b = allMessages(*mcap);
  EXPECT_TRUE(a == b);
  // /topic: std_msgs/String "Hello, world! i"; the first is 24 bytes 00 01 00 00 10 00 00 00 ...
  int i = 0;
  for (const auto& [topic, bytes] : a) {
    if (topic != "/topic") continue;
    if (i == 0) {
      ASSERT_EQ(bytes.size(), 24u);
      EXPECT_EQ(std::vector<std::uint8_t>(bytes.begin(), bytes.begin() + 8),
                (std::vector<std::uint8_t>{0, 1, 0, 0, 0x10, 0, 0, 0}));
    }
    ros::WireReader r(bytes, Wire::kCdr, "String");
    EXPECT_EQ(r.string("data"), "Hello, world! " + std::to_string(i++));
  }
  EXPECT_EQ(i, 10);
  // rcl_interfaces/Log: builtin_interfaces/Time stamp, uint8 level, string name, msg, file,
  // function, uint32 line.
  for (const auto& [topic, bytes] : a) {
    if (topic != "/rosout") continue;
    ros::WireReader r(bytes, Wire::kCdr, "Log");
    EXPECT_EQ(r.i32("sec"), 1585866235);
    EXPECT_EQ(r.u32("nanosec"), 112130688u);
    EXPECT_EQ(r.u8("level"), 20);
    EXPECT_EQ(r.string("name"), "minimal_publisher");
    EXPECT_EQ(r.string("msg"), "Publishing: 'Hello, world! 0'");
    r.string("file");
    EXPECT_EQ(r.string("function"), "operator()");
    EXPECT_EQ(r.u32("line"), 38u);
    break;
  }
}

TEST(Rosbag2, CdrTestBasicTypesDecodeByHand) {
  OVO_REQUIRE_DATA(kDir + "ros2_cdr_test_sqlite3/cdr_test_0.db3");
  const auto db = openBag(test::sharedData(kDir + "ros2_cdr_test_sqlite3"));
  const auto mcap = openBag(test::sharedData(kDir + "ros2_cdr_test_mcap"));
  const std::map<std::string, TopicCount> expected = {
      {"/test_topic", {"test_msgs/msg/BasicTypes", 3}},
      {"/array_topic", {"test_msgs/msg/Arrays", 4}}};
  for (const BagSource* bag : {db.get(), mcap.get()}) {
    EXPECT_EQ(topicsOf(*bag), expected);
    ASSERT_EQ(bag->messages().size(), 7u);
    EXPECT_EQ(bag->messages().front().log_time_ns, 1586406456763032325);
    EXPECT_EQ(bag->messages().back().log_time_ns, 1586406456914169506);
  }
  const auto a = allMessages(*db);
  EXPECT_TRUE(a == allMessages(*mcap));
  int basic = 0;
  for (const auto& [topic, bytes] : a) {
    if (topic == "/array_topic") {
      EXPECT_EQ(bytes.size(), 696u);
      continue;
    }
    ++basic;
    ASSERT_EQ(bytes.size(), 52u);
    // BasicTypes in declaration order, each aligned to its size: bool, byte, char, float32,
    // float64, int8, uint8, int16, uint16, int32, uint32, int64, uint64 (48 bytes + header).
    ros::WireReader r(bytes, Wire::kCdr, "BasicTypes");
    EXPECT_EQ(r.u8("bool_value"), 0);
    EXPECT_EQ(r.u8("byte_value"), 0);
    EXPECT_EQ(r.u8("char_value"), 0);
    EXPECT_EQ(r.f32("float32_value"), 0.0f);
    EXPECT_EQ(r.f64("float64_value"), 0.0);
    EXPECT_EQ(r.i8("int8_value"), 0);
    EXPECT_EQ(r.u8("uint8_value"), 0);
    EXPECT_EQ(r.i16("int16_value"), 0);
    EXPECT_EQ(r.u16("uint16_value"), 0);
    EXPECT_EQ(r.offset(), 4u + 22u);
    EXPECT_EQ(r.i32("int32_value"), 123);  // at 24 after 2 bytes of padding
    EXPECT_EQ(r.u32("uint32_value"), 0u);
    EXPECT_EQ(r.i64("int64_value"), 0);
    EXPECT_EQ(r.u64("uint64_value"), 0u);
    EXPECT_EQ(r.remaining(), 0u);
  }
  EXPECT_EQ(basic, 3);
}

TEST(Rosbag2, ServiceEventsAndStringsDecode) {
  OVO_REQUIRE_DATA(kDir + "ros2_service_events_sqlite3/metadata.yaml");
  const auto db = openBag(test::sharedData(kDir + "ros2_service_events_sqlite3"));
  const auto mcap = openBag(test::sharedData(kDir + "ros2_service_events_mcap"));
  for (const BagSource* bag : {db.get(), mcap.get()}) {
    const auto topics = topicsOf(*bag);
    EXPECT_EQ(topics.at("/test_service1/_service_event"),
              (TopicCount{"test_msgs/srv/BasicTypes_Event", 4}));
    EXPECT_EQ(topics.at("/test_service2/_service_event").count, 4u);
    EXPECT_EQ(topics.at("/test_topic1"), (TopicCount{"test_msgs/msg/Strings", 1}));
    EXPECT_EQ(topics.at("/test_topic2").count, 1u);
    EXPECT_EQ(topics.at("/events/write_split"),
              (TopicCount{"rosbag2_interfaces/msg/WriteSplitEvent", 0}));
    EXPECT_EQ(bag->messages().size(), 10u);
  }
  EXPECT_EQ(db->messages().front().log_time_ns, 1699345836023194036);
  EXPECT_EQ(db->messages().back().log_time_ns, 1699345836093827766);
  EXPECT_EQ(mcap->messages().front().log_time_ns, 1699345836270074454);
  EXPECT_EQ(mcap->messages().back().log_time_ns, 1699345836340728398);
  const std::vector<std::string> defaults = {"Hello world!", "Hello'world!", "Hello\"world!",
                                             "Hello'world!", "Hello\"world!"};
  for (const BagSource* bag : {db.get(), mcap.get()}) {
    std::map<int, int> events;  // event_type -> count, per service topic pair
    for (const auto& [topic, bytes] : allMessages(*bag)) {
      if (topic.find("_service_event") != std::string::npos) {
        ros::WireReader r(bytes, Wire::kCdr, "event");
        const int type = r.u8("info.event_type");
        ++events[type];
        EXPECT_EQ(bytes.size(), type == 0 ? 112u : 105u);
        continue;
      }
      ASSERT_EQ(bytes.size(), 217u);
      ros::WireReader r(bytes, Wire::kCdr, "Strings");
      EXPECT_EQ(r.string("string_value"), "");
      for (const auto& d : defaults) EXPECT_EQ(r.string("string_value_default"), d);
      EXPECT_EQ(r.string("bounded_string_value"), "");
      for (const auto& d : defaults) EXPECT_EQ(r.string("bounded_string_value_default"), d);
    }
    EXPECT_EQ(events, (std::map<int, int>{{0, 4}, {3, 4}}));  // REQUEST_SENT, RESPONSE_RECEIVED
  }
}

TEST(Rosbag2, BadBagsAreErrorsNamingTheFile) {
  const fs::path dir = test::tempDir();
  test::writeTextFile(dir / "junk.db3", "this is not an sqlite database, but long enough....");
  EXPECT_CONTAINS(errorOf([&] { openBag(dir / "junk.db3"); }), "junk.db3");
  test::writeTextFile(dir / "b" / "metadata.yaml",
                      "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: sqlite3\n"
                      "  relative_file_paths: [b_0.db3]\n  compression_format: zstd\n"
                      "  compression_mode: FILE\n");
  EXPECT_CONTAINS(errorOf([&] { openBag(dir / "b"); }), "compression 'zstd' (mode 'FILE')");
  test::writeTextFile(dir / "c" / "metadata.yaml",
                      "rosbag2_bagfile_information:\n  storage_identifier: sqlite3\n"
                      "  relative_file_paths: [c_0.db3]\n");
  EXPECT_CONTAINS(errorOf([&] { openBag(dir / "c"); }), "c_0.db3, which does not exist");
  test::writeTextFile(dir / "d" / "metadata.yaml", "something: else\n");
  EXPECT_CONTAINS(errorOf([&] { openBag(dir / "d"); }), "rosbag2_bagfile_information");
  EXPECT_CONTAINS(errorOf([&] { openBag(dir / "none.mcap"); }), "not found");
  EXPECT_CONTAINS(errorOf([&] { openBag(dir / "x.txt"); }), "not found");

  OVO_REQUIRE_DATA(kDir + "ros2_talker_sqlite3/talker.db3");
  // A truncated .db3: sqlite reports it, the error names the file.
  std::ifstream in(test::sharedData(kDir + "ros2_talker_sqlite3/talker.db3"), std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), {});
  for (std::size_t n : {std::size_t{100}, bytes.size() / 2, bytes.size() - 4096}) {
    test::writeTextFile(dir / "cut.db3", bytes.substr(0, n));
    EXPECT_CONTAINS(errorOf([&] {
                      const auto bag = openBag(dir / "cut.db3");
                      for (const MessageRef& m : bag->messages()) bag->payload(m);
                    }),
                    "cut.db3");
  }
}

}  // namespace
}  // namespace ovo::io::bag
