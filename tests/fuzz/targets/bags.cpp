// Fuzz targets for the bag readers: a ROS 1 .bag (io/rosbag1_reader: records, chunks, bz2 and
// lz4), a rosbag2 sqlite3 .db3 and an MCAP file (io/rosbag2_reader, io/mcap: records, chunks,
// zstd and lz4). Each opens the input as `ovo run --dataset BAG` would, then fetches and decodes
// the first messages of every sensor_msgs type ovo reads (io/cdr: the ROS 1 and CDR wires), the
// images turned grey, so that the listing, the payload reads and the decoders are all reached.
// Seeds: small bags written by ovo's own writers (io/bag_writer) in each format and compression.
#include <cstddef>
#include <string>

#include "io/bag_source.hpp"
#include "io/cdr.hpp"
#include "io/ros_messages.hpp"
#include "io/rosbag1_reader.hpp"
#include "io/rosbag2_reader.hpp"
#include "tests/fuzz/fuzz_target.hpp"

namespace {

namespace bag = ovo::io::bag;
namespace ros = ovo::io::ros;

// Reads and decodes up to 64 messages (a fuzzed index can list millions).
void readMessages(const bag::BagSource& source) {
  const auto& topics = source.topics();
  std::size_t n = 0;
  for (const bag::MessageRef& ref : source.messages()) {
    if (++n > 64) break;
    if (ref.topic >= topics.size()) continue;  // a reader bug the fuzzer would find below
    const bag::Topic& t = topics[ref.topic];
    const ros::Wire wire = t.encoding == "ros1" ? ros::Wire::kRos1 : ros::Wire::kCdr;
    const std::string where = source.describe(ref, n);
    const auto bytes = source.payload(ref);
    switch (ros::msgTypeOf(t.type)) {
      case ros::MsgType::kImage:
        (void)ros::greyImage(ros::decodeImage(bytes, wire, where), where);
        break;
      case ros::MsgType::kCompressedImage:
        (void)ros::greyImage(ros::decodeCompressedImage(bytes, wire, where), where);
        break;
      case ros::MsgType::kImu:
        (void)ros::imuSample(ros::decodeImu(bytes, wire, where), 0);
        break;
      case ros::MsgType::kLaserScan:
        (void)ros::lidarScan(ros::decodeLaserScan(bytes, wire, where), 0, where);
        break;
      case ros::MsgType::kOther:
        (void)ros::decodeHeader(bytes, wire, where);
        break;
    }
  }
}

}  // namespace

OVO_FUZZ_TARGET(bag_ros1) {
  const auto file = ovo::fuzz::writeScratch("input.bag", input);
  ovo::fuzz::expectOnlyOvoErrors([&] { readMessages(*ovo::io::bag::openRos1Bag(file)); });
}

OVO_FUZZ_TARGET(bag_sqlite3) {
  const auto file = ovo::fuzz::writeScratch("input.db3", input);
  ovo::fuzz::expectOnlyOvoErrors([&] { readMessages(*ovo::io::bag::openSqlite3Bag(file)); });
}

OVO_FUZZ_TARGET(bag_mcap) {
  const auto file = ovo::fuzz::writeScratch("input.mcap", input);
  ovo::fuzz::expectOnlyOvoErrors([&] { readMessages(*ovo::io::bag::openMcapBag(file)); });
}
