#include "io/rosbag1_check.hpp"

#include <bzlib.h>
#include <fmt/format.h>
#include <lz4frame.h>

#include <cstring>
#include <map>
#include <optional>
#include <set>
#include <string_view>

#include "common/error.hpp"
#include "io/mapped_file.hpp"

namespace ovo::io::bag {

namespace fs = std::filesystem;

namespace {

constexpr std::string_view kMagic = "#ROSBAG V2.0\n";
constexpr std::uint8_t kOpMessage = 0x02, kOpBagHeader = 0x03, kOpIndex = 0x04, kOpChunk = 0x05,
                       kOpChunkInfo = 0x06, kOpConnection = 0x07;
// A chunk may decompress to at most this much (librosbag keeps chunks in memory).
constexpr std::uint64_t kMaxChunkBytes = std::uint64_t{1} << 31;

std::uint32_t le32(const std::uint8_t* p) {
  return std::uint32_t{p[0]} | std::uint32_t{p[1]} << 8 | std::uint32_t{p[2]} << 16 |
         std::uint32_t{p[3]} << 24;
}
std::uint64_t le64(const std::uint8_t* p) { return le32(p) | std::uint64_t{le32(p + 4)} << 32; }

// One record: header fields (name -> raw value) and its data, inside `bytes`.
struct Record {
  std::uint64_t offset = 0;  // of header_len, in the enclosing bytes
  std::uint64_t end = 0;     // one past its data
  std::map<std::string, std::string_view> fields;
  std::span<const std::uint8_t> data;
  std::uint8_t op = 0;
};

class Walker {
 public:
  Walker(std::span<const std::uint8_t> bytes, std::string where)
      : bytes_(bytes), where_(std::move(where)) {}

  // The record at `pos`; errors name `where_` and the offset.
  Record recordAt(std::uint64_t pos) const {
    Record r;
    r.offset = pos;
    const std::uint64_t header_len = u32At(pos, "header_len");
    std::uint64_t p = pos + 4;
    if (header_len > bytes_.size() - p)
      failAt(pos, fmt::format("record header of {} bytes runs past the end ({} bytes left): "
                              "truncated or corrupt",
                              header_len, bytes_.size() - p));
    const std::uint64_t header_end = p + header_len;
    while (p < header_end) {
      if (header_end - p < 4) failAt(p, "a header field's length runs past the record header");
      const std::uint32_t field_len = le32(bytes_.data() + p);
      p += 4;
      if (field_len > header_end - p)
        failAt(p, fmt::format("header field of {} bytes runs past the record header", field_len));
      const std::string_view field(reinterpret_cast<const char*>(bytes_.data() + p), field_len);
      const auto eq = field.find('=');
      if (eq == std::string_view::npos) failAt(p, "header field without '=' (expected name=value)");
      r.fields[std::string(field.substr(0, eq))] = field.substr(eq + 1);
      p += field_len;
    }
    const auto op = r.fields.find("op");
    if (op == r.fields.end() || op->second.size() != 1)
      failAt(pos, "record without a one-byte 'op' header field");
    r.op = static_cast<std::uint8_t>(op->second[0]);
    std::uint64_t data_len = u32At(p, "data_len");
    p += 4;
    // Index data: librosbag (and Python's rosbag) read `count` entries of 12 bytes after the data
    // length and go on from there, whatever the length says (old writers put other values in it).
    const auto count = r.fields.find("count");
    if (r.op == 0x04 && count != r.fields.end() && count->second.size() == 4)
      data_len =
          std::uint64_t{le32(reinterpret_cast<const std::uint8_t*>(count->second.data()))} * 12;
    if (data_len > bytes_.size() - p)
      failAt(p - 4, fmt::format("record data of {} bytes runs past the end ({} bytes left): "
                                "truncated or corrupt",
                                data_len, bytes_.size() - p));
    r.data = bytes_.subspan(p, data_len);
    r.end = p + data_len;
    return r;
  }

  std::uint64_t u32At(std::uint64_t pos, const char* what) const {
    if (pos > bytes_.size() || bytes_.size() - pos < 4)
      failAt(pos, fmt::format("{} runs past the end: truncated", what));
    return le32(bytes_.data() + pos);
  }

  [[noreturn]] void failAt(std::uint64_t pos, const std::string& what) const {
    fail("{}: byte {}: {}", where_, pos, what);
  }

  std::span<const std::uint8_t> bytes() const { return bytes_; }
  const std::string& where() const { return where_; }

 private:
  std::span<const std::uint8_t> bytes_;
  std::string where_;
};

template <typename T>
T fieldValue(const Record& r, const char* name, const Walker& w) {
  const auto it = r.fields.find(name);
  if (it == r.fields.end() || it->second.size() != sizeof(T))
    w.failAt(r.offset,
             fmt::format("op 0x{:02x} record without a {}-byte '{}' field", r.op, sizeof(T), name));
  const auto* p = reinterpret_cast<const std::uint8_t*>(it->second.data());
  if constexpr (sizeof(T) == 4)
    return static_cast<T>(le32(p));
  else
    return static_cast<T>(le64(p));
}

std::string stringField(const Record& r, const char* name, const Walker& w) {
  const auto it = r.fields.find(name);
  if (it == r.fields.end())
    w.failAt(r.offset, fmt::format("op 0x{:02x} record without a '{}' field", r.op, name));
  return std::string(it->second);
}

std::vector<std::uint8_t> decompressChunk(const std::string& compression,
                                          std::span<const std::uint8_t> data, std::uint64_t size,
                                          const std::string& where) {
  if (size > kMaxChunkBytes)
    fail("{}: chunk claims {} uncompressed bytes (at most {}): corrupt", where, size,
         kMaxChunkBytes);
  if (compression == "none") {
    if (data.size() != size)
      fail("{}: uncompressed chunk of {} bytes, its header says {}", where, data.size(), size);
    return {};  // walked in place
  }
  std::vector<std::uint8_t> out(static_cast<std::size_t>(size));
  if (compression == "bz2") {
    unsigned int out_len = static_cast<unsigned int>(out.size());
    const int rc =
        BZ2_bzBuffToBuffDecompress(reinterpret_cast<char*>(out.data()), &out_len,
                                   const_cast<char*>(reinterpret_cast<const char*>(data.data())),
                                   static_cast<unsigned int>(data.size()), 0, 0);
    if (rc != BZ_OK || out_len != size)
      fail("{}: bz2 chunk does not decompress to its {} bytes (bzip2 error {}): corrupt", where,
           size, rc);
    return out;
  }
  if (compression == "lz4") {  // roslz4 writes the LZ4 frame format
    LZ4F_dctx* ctx = nullptr;
    if (LZ4F_isError(LZ4F_createDecompressionContext(&ctx, LZ4F_VERSION)))
      fail("{}: cannot create an lz4 decompression context", where);
    std::size_t in_pos = 0, out_pos = 0, hint = 1;
    bool error = false;
    while (hint != 0 && in_pos < data.size()) {
      std::size_t in_n = data.size() - in_pos, out_n = out.size() - out_pos;
      hint =
          LZ4F_decompress(ctx, out.data() + out_pos, &out_n, data.data() + in_pos, &in_n, nullptr);
      if (LZ4F_isError(hint)) {
        error = true;
        break;
      }
      in_pos += in_n;
      out_pos += out_n;
      if (in_n == 0 && out_n == 0) break;
    }
    LZ4F_freeDecompressionContext(ctx);
    if (error || hint != 0 || out_pos != size)
      fail("{}: lz4 chunk does not decompress to its {} bytes: corrupt", where, size);
    return out;
  }
  fail("{}: chunk compression '{}' is not supported (expected none, bz2 or lz4)", where,
       compression);
}

}  // namespace

Ros1BagLayout checkRos1BagStructure(const fs::path& file) {
  const MappedFile map(file);
  const std::span<const std::uint8_t> all = map.bytes();
  const std::string where = file.string();
  if (all.size() < kMagic.size() || std::memcmp(all.data(), kMagic.data(), kMagic.size()) != 0)
    fail("{}: not a ROS 1 bag of format 2.0 (expected '#ROSBAG V2.0' at its start)", where);
  const Walker w(all, where);

  Ros1BagLayout layout;
  std::uint64_t pos = kMagic.size();
  const Record header = w.recordAt(pos);
  if (header.op != kOpBagHeader)
    w.failAt(pos, fmt::format("the first record has op 0x{:02x}; expected the bag header (0x03)",
                              header.op));
  layout.index_pos = fieldValue<std::uint64_t>(header, "index_pos", w);
  layout.conn_count = fieldValue<std::uint32_t>(header, "conn_count", w);
  layout.chunk_count = fieldValue<std::uint32_t>(header, "chunk_count", w);
  if (layout.index_pos == 0)
    fail("{}: the bag is not indexed (its recording was interrupted): run `rosbag reindex` on it",
         where);
  if (layout.index_pos >= all.size())
    fail(
        "{}: the bag header's index position {} is past the end of the file ({} bytes): the file "
        "is truncated",
        where, layout.index_pos, all.size());

  // Every top-level record, in file order.
  struct ChunkSeen {
    std::set<std::uint64_t> message_offsets;         // message records in the chunk
    std::map<std::uint64_t, std::uint32_t> conn_of;  // their connection
    std::uint32_t index_records = 0;                 // index data records after it
  };
  std::map<std::uint64_t, ChunkSeen> chunks;  // by chunk record position
  std::optional<std::uint64_t> last_chunk;
  std::map<std::uint64_t, std::uint8_t> op_at;
  std::set<std::uint32_t> connections;
  pos = header.end;
  while (pos < all.size()) {
    const Record r = w.recordAt(pos);
    op_at[pos] = r.op;
    switch (r.op) {
      case kOpChunk: {
        const std::string compression = stringField(r, "compression", w);
        const std::uint64_t size = fieldValue<std::uint32_t>(r, "size", w);
        const std::string chunk_where = fmt::format("{}: chunk at byte {}", where, pos);
        const std::vector<std::uint8_t> unpacked =
            decompressChunk(compression, r.data, size, chunk_where);
        const Walker inner(compression == "none" ? r.data : std::span<const std::uint8_t>(unpacked),
                           chunk_where + " (uncompressed)");
        ChunkSeen seen;
        std::uint64_t p = 0;
        while (p < inner.bytes().size()) {
          const Record m = inner.recordAt(p);
          if (m.op == kOpMessage) {
            seen.message_offsets.insert(p);
            seen.conn_of[p] = fieldValue<std::uint32_t>(m, "conn", inner);
            fieldValue<std::uint64_t>(m, "time", inner);
            ++layout.message_records;
          } else if (m.op == kOpConnection) {
            fieldValue<std::uint32_t>(m, "conn", inner);
            stringField(m, "topic", inner);
          } else {
            inner.failAt(p, fmt::format("record op 0x{:02x} inside a chunk (expected message data "
                                        "or connection records)",
                                        m.op));
          }
          p = m.end;
        }
        layout.chunk_compression.push_back(compression);
        layout.chunk_compressed_size.push_back(r.data.size());
        layout.chunk_uncompressed_size.push_back(size);
        chunks[pos] = std::move(seen);
        last_chunk = pos;
        break;
      }
      case kOpIndex: {
        if (!last_chunk) w.failAt(pos, "an index data record before any chunk");
        ChunkSeen& chunk = chunks[*last_chunk];
        const auto ver = fieldValue<std::uint32_t>(r, "ver", w);
        const auto conn = fieldValue<std::uint32_t>(r, "conn", w);
        const auto count = fieldValue<std::uint32_t>(r, "count", w);
        if (ver != 1) w.failAt(pos, fmt::format("index data version {} (expected 1)", ver));
        for (std::uint32_t i = 0; i < count; ++i) {
          const std::uint64_t offset = le32(r.data.data() + 12 * i + 8);
          const auto it = chunk.conn_of.find(offset);
          if (it == chunk.conn_of.end() || it->second != conn)
            w.failAt(pos, fmt::format("index entry {} points at byte {} of the chunk at byte {}, "
                                      "where there is no message of connection {}",
                                      i, offset, *last_chunk, conn));
        }
        ++chunk.index_records;
        break;
      }
      case kOpConnection:
        connections.insert(fieldValue<std::uint32_t>(r, "conn", w));
        stringField(r, "topic", w);
        break;
      case kOpChunkInfo: {
        const auto ver = fieldValue<std::uint32_t>(r, "ver", w);
        const auto chunk_pos = fieldValue<std::uint64_t>(r, "chunk_pos", w);
        const auto count = fieldValue<std::uint32_t>(r, "count", w);
        if (ver != 1) w.failAt(pos, fmt::format("chunk info version {} (expected 1)", ver));
        const auto chunk = chunks.find(chunk_pos);
        if (chunk == chunks.end())
          w.failAt(pos,
                   fmt::format("chunk info points at byte {}, where there is no chunk", chunk_pos));
        if (r.data.size() != std::uint64_t{count} * 8)
          w.failAt(pos, fmt::format("chunk info of {} bytes for {} connections (expected 8 bytes "
                                    "each)",
                                    r.data.size(), count));
        if (chunk->second.index_records < count)
          w.failAt(pos, fmt::format("chunk info lists {} connections, but only {} index data "
                                    "records follow the chunk at byte {}",
                                    count, chunk->second.index_records, chunk_pos));
        for (std::uint32_t i = 0; i < count; ++i) {
          const std::uint32_t conn = le32(r.data.data() + 8 * i);
          if (!connections.count(conn))
            w.failAt(pos, fmt::format("chunk info names connection {}, which no connection record "
                                      "before it defines",
                                      conn));
        }
        break;
      }
      default:
        w.failAt(pos, fmt::format("unexpected record op 0x{:02x} at the top level", r.op));
    }
    pos = r.end;
  }
  // librosbag reads conn_count connection records from index_pos, then chunk_count chunk infos.
  auto it = op_at.find(layout.index_pos);
  if (it == op_at.end())
    fail("{}: the bag header's index position {} is not the start of a record", where,
         layout.index_pos);
  for (std::uint64_t i = 0; i < std::uint64_t{layout.conn_count} + layout.chunk_count; ++i, ++it) {
    const std::uint8_t expected = i < layout.conn_count ? kOpConnection : kOpChunkInfo;
    if (it == op_at.end() || it->second != expected)
      fail(
          "{}: the index section at byte {} does not hold the {} connection and {} chunk info "
          "records the bag header announces: the file is truncated or corrupt",
          where, layout.index_pos, layout.conn_count, layout.chunk_count);
  }
  return layout;
}

}  // namespace ovo::io::bag
