// A structural check of a ROS 1 bag (format 2.0) before librosbag reads it: librosbag trusts the
// lengths in the file (rosbag::Bag::readHeaderFromBuffer copies header_len bytes wherever it
// points), so a truncated or corrupt bag could make it read out of bounds. This walks every
// record (header_len, fields, data_len), decompresses every chunk (none, bz2, lz4) and walks its
// records, and checks that every index entry points at a message record of its chunk and every
// chunk info at a chunk: after it, librosbag reads only what was checked.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace ovo::io::bag {

/// What the check saw (tests compare it with the fixtures' manifest).
struct Ros1BagLayout {
  std::uint32_t conn_count = 0, chunk_count = 0;  // from the bag header record
  std::uint64_t index_pos = 0;
  std::vector<std::string> chunk_compression;        // per chunk: none, bz2, lz4
  std::vector<std::uint64_t> chunk_compressed_size;  // per chunk
  std::vector<std::uint64_t> chunk_uncompressed_size;
  std::uint64_t message_records = 0;  // message data records in all chunks
};

/// Throws ovo::Error naming the file, the byte offset and what was expected on anything that is
/// not a complete, consistent ROS 1 bag 2.0.
Ros1BagLayout checkRos1BagStructure(const std::filesystem::path& file);

}  // namespace ovo::io::bag
