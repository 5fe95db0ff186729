// MCAP container files (https://mcap.dev/spec, major version 0), read and written from the
// specification: records `<opcode u8><length u64><content>`, little endian; chunks uncompressed,
// zstd or lz4 (LZ4 frame format), each with a CRC-32 of its records (0: not computed). The reader
// walks the whole file once (data section, then the summary section for Schema/Channel/Statistics
// records that only the summary holds), checking every length against the bytes that are left;
// message payloads are fetched later by location. The writer writes chunks with message indexes,
// a summary (schemas, channels, chunk indexes, statistics) with its offsets, and CRCs.
#pragma once

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace ovo::io {
class MappedFile;
}

namespace ovo::io::mcap {

/// CRC-32 (IEEE 802.3, as zlib's crc32), continuing from `crc` (0 to start).
std::uint32_t crc32(std::span<const std::uint8_t> bytes, std::uint32_t crc = 0);

/// Decompresses one chunk's records: "" (none), "zstd" or "lz4" (frame format) into exactly
/// `uncompressed_size` bytes. Throws ovo::Error naming `where` for another compression, a size
/// that does not match, or corrupt data.
std::vector<std::uint8_t> decompress(const std::string& compression,
                                     std::span<const std::uint8_t> data,
                                     std::uint64_t uncompressed_size, const std::string& where);

struct Schema {
  std::uint16_t id = 0;
  std::string name, encoding;
  std::vector<std::uint8_t> data;
};

struct Channel {
  std::uint16_t id = 0, schema_id = 0;
  std::string topic, message_encoding;
  std::map<std::string, std::string> metadata;
};

struct Statistics {
  std::uint64_t message_count = 0;
  std::uint16_t schema_count = 0;
  std::uint32_t channel_count = 0, attachment_count = 0, metadata_count = 0, chunk_count = 0;
  std::uint64_t message_start_time = 0, message_end_time = 0;
  std::map<std::uint16_t, std::uint64_t> channel_message_counts;
};

/// Where a message is: in chunk `chunk` (an index into Reader::chunks(), kNoChunk: directly in
/// the data section) at `data_offset` (in the chunk's uncompressed records, else in the file).
struct MessageLocation {
  static constexpr std::uint32_t kNoChunk = 0xffffffffu;
  std::uint16_t channel_id = 0;
  std::uint32_t sequence = 0;
  std::uint64_t log_time = 0, publish_time = 0;
  std::uint32_t chunk = kNoChunk;
  std::uint64_t data_offset = 0;
  std::uint64_t data_size = 0;
};

struct ChunkInfo {
  std::uint64_t record_offset = 0;   // the Chunk record's opcode, from the file start
  std::uint64_t records_offset = 0;  // its (compressed) records, from the file start
  std::uint64_t compressed_size = 0, uncompressed_size = 0;
  std::uint32_t uncompressed_crc = 0;
  std::string compression;
};

class Reader {
 public:
  /// Maps the file and walks it. Throws ovo::Error naming the file and the offset on bad magic,
  /// a record running past the end (truncated file), a bad chunk CRC or length, an unsupported
  /// compression, a message on a channel never defined, or a malformed record.
  explicit Reader(const std::filesystem::path& file);
  ~Reader();
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;

  const std::filesystem::path& file() const { return file_; }
  const std::string& profile() const { return profile_; }
  const std::string& library() const { return library_; }
  const std::map<std::uint16_t, Schema>& schemas() const { return schemas_; }
  const std::map<std::uint16_t, Channel>& channels() const { return channels_; }
  /// In file order.
  const std::vector<MessageLocation>& messages() const { return messages_; }
  const std::vector<ChunkInfo>& chunks() const { return chunks_; }
  /// Metadata records: name and key/value pairs, in file order.
  const std::vector<std::pair<std::string, std::map<std::string, std::string>>>& metadata() const {
    return metadata_;
  }
  const std::optional<Statistics>& statistics() const { return statistics_; }

  /// A message's payload. Thread-safe (one decompressed chunk is cached).
  std::vector<std::uint8_t> messageData(const MessageLocation& m) const;

 private:
  void walk();
  void readChunk(std::uint64_t record_offset, std::span<const std::uint8_t> content);
  std::shared_ptr<const std::vector<std::uint8_t>> chunkRecords(std::uint32_t chunk) const;

  std::filesystem::path file_;
  std::unique_ptr<MappedFile> map_;
  const std::uint8_t* data_ = nullptr;
  std::size_t size_ = 0;
  std::string profile_, library_;
  std::map<std::uint16_t, Schema> schemas_;
  std::map<std::uint16_t, Channel> channels_;
  std::vector<MessageLocation> messages_;
  std::vector<ChunkInfo> chunks_;
  std::vector<std::pair<std::string, std::map<std::string, std::string>>> metadata_;
  std::optional<Statistics> statistics_;

  mutable std::mutex cache_mutex_;
  mutable std::uint32_t cached_chunk_ = MessageLocation::kNoChunk;
  mutable std::shared_ptr<const std::vector<std::uint8_t>> cached_records_;
};

/// Writes an MCAP file: Header, then chunks of Schema/Channel/Message records (each chunk followed
/// by its Message Index records), Data End, a summary (Schemas, Channels, Chunk Indexes,
/// Statistics, Metadata Indexes), Summary Offsets and the Footer. Writes to `file` directly;
/// close() must be called (the destructor of an unclosed writer leaves an incomplete file, which
/// the reader refuses).
class Writer {
 public:
  /// compression: "", "zstd" or "lz4"; chunk_size: uncompressed bytes after which a chunk is
  /// closed. Throws ovo::Error when the file cannot be created.
  Writer(const std::filesystem::path& file, std::string profile, std::string compression,
         std::size_t chunk_size = 4u << 20);
  ~Writer();
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  std::uint16_t addSchema(const std::string& name, const std::string& encoding,
                          const std::string& data);
  std::uint16_t addChannel(std::uint16_t schema_id, const std::string& topic,
                           const std::string& message_encoding,
                           const std::map<std::string, std::string>& metadata);
  void addMetadata(const std::string& name, const std::map<std::string, std::string>& values);
  void write(std::uint16_t channel_id, std::uint64_t log_time, std::uint64_t publish_time,
             std::span<const std::uint8_t> data);
  void close();

 private:
  void flushChunk();
  void emit(std::span<const std::uint8_t> bytes);  // to the file, counted in the data CRC

  std::filesystem::path file_;
  std::ofstream out_;
  std::string compression_;
  std::size_t chunk_size_;
  std::uint64_t offset_ = 0;
  std::uint32_t data_crc_ = 0;
  bool in_data_ = true, closed_ = false;

  std::vector<std::vector<std::uint8_t>> schema_records_, channel_records_;
  std::vector<std::vector<std::uint8_t>> chunk_index_records_, metadata_index_records_;
  std::map<std::uint16_t, std::uint32_t> sequences_;
  std::map<std::uint16_t, std::uint64_t> channel_counts_;
  std::uint64_t message_count_ = 0, start_time_ = 0, end_time_ = 0;
  std::uint32_t chunk_count_ = 0, metadata_count_ = 0;
  // The open chunk.
  std::vector<std::uint8_t> chunk_;
  std::map<std::uint16_t, std::vector<std::pair<std::uint64_t, std::uint64_t>>> chunk_index_;
  std::uint64_t chunk_start_ = 0, chunk_end_ = 0;
};

}  // namespace ovo::io::mcap
