#include "io/mcap.hpp"

#include <lz4frame.h>
#include <zstd.h>

#include <array>
#include <cstring>

#include "common/error.hpp"
#include "io/mapped_file.hpp"

namespace ovo::io::mcap {

namespace fs = std::filesystem;

namespace {

constexpr std::array<std::uint8_t, 8> kMagic = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};

enum Op : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kAttachment = 0x09,
  kAttachmentIndex = 0x0A,
  kStatistics = 0x0B,
  kMetadata = 0x0C,
  kMetadataIndex = 0x0D,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

// A chunk's records decompress to at most this much (a corrupt size must not allocate more).
constexpr std::uint64_t kMaxChunkBytes = std::uint64_t{1} << 30;

std::array<std::uint32_t, 256> makeCrcTable() {
  std::array<std::uint32_t, 256> t{};
  for (std::uint32_t n = 0; n < 256; ++n) {
    std::uint32_t c = n;
    for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
    t[n] = c;
  }
  return t;
}

// Bounds-checked little-endian reading of one record's content; errors name the file and the
// absolute offset.
class Cursor {
 public:
  Cursor(std::span<const std::uint8_t> bytes, const std::string& where, std::uint64_t base,
         const char* record)
      : bytes_(bytes), where_(where), base_(base), record_(record) {}

  template <typename T>
  T scalar(const char* field) {
    T v = 0;
    const std::uint8_t* p = take(sizeof(T), field);
    for (std::size_t i = 0; i < sizeof(T); ++i) v |= static_cast<T>(T{p[i]} << (8 * i));
    return v;
  }
  std::uint8_t u8(const char* f) { return scalar<std::uint8_t>(f); }
  std::uint16_t u16(const char* f) { return scalar<std::uint16_t>(f); }
  std::uint32_t u32(const char* f) { return scalar<std::uint32_t>(f); }
  std::uint64_t u64(const char* f) { return scalar<std::uint64_t>(f); }
  std::string string(const char* field) {
    const std::uint32_t n = u32(field);
    const auto* p = reinterpret_cast<const char*>(take(n, field));
    return std::string(p, n);
  }
  std::span<const std::uint8_t> bytes(std::uint64_t n, const char* field) {
    const std::uint8_t* p = take(n, field);
    return {p, static_cast<std::size_t>(n)};
  }
  std::map<std::string, std::string> stringMap(const char* field) {
    const std::uint32_t n = u32(field);
    Cursor inner(bytes(n, field), where_, base_ + pos_ - n, record_);
    std::map<std::string, std::string> m;
    while (inner.remaining() > 0) {
      std::string key = inner.string(field);
      m[std::move(key)] = inner.string(field);
    }
    return m;
  }
  std::span<const std::uint8_t> rest() { return bytes(remaining(), "data"); }
  std::size_t remaining() const { return bytes_.size() - pos_; }
  std::uint64_t absolute() const { return base_ + pos_; }

  const std::uint8_t* take(std::uint64_t n, const char* field) {
    if (n > remaining())
      fail("{}: byte {}: {} record field '{}' needs {} bytes, only {} left in the record", where_,
           base_ + pos_, record_, field, n, remaining());
    const std::uint8_t* p = bytes_.data() + pos_;
    pos_ += static_cast<std::size_t>(n);
    return p;
  }

 private:
  std::span<const std::uint8_t> bytes_;
  std::string where_;  // a copy: callers pass temporaries (a reference to one dangled: the bag_mcap
                       // fuzz target's first finding, tests/fuzz/regressions/bag_mcap)
  std::uint64_t base_;
  const char* record_;
  std::size_t pos_ = 0;
};

const char* opName(std::uint8_t op) {
  switch (op) {
    case kHeader:
      return "Header";
    case kFooter:
      return "Footer";
    case kSchema:
      return "Schema";
    case kChannel:
      return "Channel";
    case kMessage:
      return "Message";
    case kChunk:
      return "Chunk";
    case kMessageIndex:
      return "Message Index";
    case kChunkIndex:
      return "Chunk Index";
    case kAttachment:
      return "Attachment";
    case kAttachmentIndex:
      return "Attachment Index";
    case kStatistics:
      return "Statistics";
    case kMetadata:
      return "Metadata";
    case kMetadataIndex:
      return "Metadata Index";
    case kSummaryOffset:
      return "Summary Offset";
    case kDataEnd:
      return "Data End";
    default:
      return "unknown";
  }
}

// One record `<op><u64 length><content>` at `pos` of `bytes`; false at the end.
struct RecordView {
  std::uint8_t op = 0;
  std::uint64_t offset = 0;  // of the opcode, relative to the span
  std::span<const std::uint8_t> content;
};

RecordView recordAt(std::span<const std::uint8_t> bytes, std::uint64_t pos,
                    const std::string& where, std::uint64_t base, const char* container) {
  RecordView r;
  r.offset = pos;
  const std::uint64_t left = bytes.size() - pos;
  if (left < 9)
    fail(
        "{}: byte {}: {} ends inside a record header ({} bytes left, a record needs 9): the file "
        "is truncated",
        where, base + pos, container, left);
  r.op = bytes[pos];
  std::uint64_t len = 0;
  for (int i = 0; i < 8; ++i) len |= std::uint64_t{bytes[pos + 1 + i]} << (8 * i);
  if (len > left - 9)
    fail(
        "{}: byte {}: {} record (opcode 0x{:02x}) of {} bytes runs past the end of the {} ({} "
        "bytes left): the file is truncated or corrupt",
        where, base + pos, opName(r.op), r.op, len, container, left - 9);
  r.content = bytes.subspan(pos + 9, len);
  return r;
}

Schema parseSchema(Cursor& c) {
  Schema s;
  s.id = c.u16("id");
  s.name = c.string("name");
  s.encoding = c.string("encoding");
  const std::uint32_t n = c.u32("data");
  const auto d = c.bytes(n, "data");
  s.data.assign(d.begin(), d.end());
  return s;
}

Channel parseChannel(Cursor& c) {
  Channel ch;
  ch.id = c.u16("id");
  ch.schema_id = c.u16("schema_id");
  ch.topic = c.string("topic");
  ch.message_encoding = c.string("message_encoding");
  ch.metadata = c.stringMap("metadata");
  return ch;
}

}  // namespace

std::uint32_t crc32(std::span<const std::uint8_t> bytes, std::uint32_t crc) {
  static const std::array<std::uint32_t, 256> table = makeCrcTable();
  std::uint32_t c = crc ^ 0xFFFFFFFFu;
  for (std::uint8_t b : bytes) c = table[(c ^ b) & 0xFF] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

std::vector<std::uint8_t> decompress(const std::string& compression,
                                     std::span<const std::uint8_t> data,
                                     std::uint64_t uncompressed_size, const std::string& where) {
  if (uncompressed_size > kMaxChunkBytes)
    fail("{}: chunk claims {} uncompressed bytes (more than the {} a chunk may have): corrupt",
         where, uncompressed_size, kMaxChunkBytes);
  if (compression.empty()) {
    if (data.size() != uncompressed_size)
      fail("{}: uncompressed chunk holds {} bytes of records, its header says {}", where,
           data.size(), uncompressed_size);
    return std::vector<std::uint8_t>(data.begin(), data.end());
  }
  std::vector<std::uint8_t> out(static_cast<std::size_t>(uncompressed_size));
  if (compression == "zstd") {
    const unsigned long long content = ZSTD_getFrameContentSize(data.data(), data.size());
    if (content == ZSTD_CONTENTSIZE_ERROR)
      fail("{}: the zstd chunk is not a zstd frame (corrupt)", where);
    if (content != ZSTD_CONTENTSIZE_UNKNOWN && content != uncompressed_size)
      fail("{}: the zstd chunk decompresses to {} bytes, its header says {}", where, content,
           uncompressed_size);
    const std::size_t n = ZSTD_decompress(out.data(), out.size(), data.data(), data.size());
    if (ZSTD_isError(n))
      fail("{}: zstd decompression failed: {} (corrupt chunk)", where, ZSTD_getErrorName(n));
    if (n != uncompressed_size)
      fail("{}: the zstd chunk decompressed to {} bytes, its header says {}", where, n,
           uncompressed_size);
    return out;
  }
  if (compression == "lz4") {
    LZ4F_dctx* ctx = nullptr;
    if (LZ4F_isError(LZ4F_createDecompressionContext(&ctx, LZ4F_VERSION)))
      fail("{}: cannot create an lz4 decompression context", where);
    std::size_t in_pos = 0, out_pos = 0, hint = 1;
    while (hint != 0 && in_pos < data.size()) {
      std::size_t in_n = data.size() - in_pos, out_n = out.size() - out_pos;
      hint =
          LZ4F_decompress(ctx, out.data() + out_pos, &out_n, data.data() + in_pos, &in_n, nullptr);
      if (LZ4F_isError(hint)) {
        const std::string msg = LZ4F_getErrorName(hint);
        LZ4F_freeDecompressionContext(ctx);
        fail(
            "{}: lz4 decompression failed: {} (corrupt chunk, or larger than its header's {} "
            "bytes)",
            where, msg, uncompressed_size);
      }
      in_pos += in_n;
      out_pos += out_n;
      if (in_n == 0 && out_n == 0) break;  // no progress: output full
    }
    LZ4F_freeDecompressionContext(ctx);
    if (hint != 0 || out_pos != uncompressed_size)
      fail("{}: the lz4 chunk decompressed to {} bytes{}, its header says {}", where, out_pos,
           hint != 0 ? " and the frame is incomplete" : "", uncompressed_size);
    return out;
  }
  fail("{}: chunk compression '{}' is not supported (expected zstd, lz4 or none)", where,
       compression);
}

// ---------------------------------------------------------------------------------------------
// Reader

Reader::Reader(const fs::path& file) : file_(file), map_(std::make_unique<MappedFile>(file)) {
  data_ = map_->bytes().data();
  size_ = map_->size();
  walk();
}

Reader::~Reader() = default;

void Reader::walk() {
  const std::string where = file_.string();
  const std::span<const std::uint8_t> all(data_, size_);
  if (size_ < kMagic.size() || !std::equal(kMagic.begin(), kMagic.end(), all.begin()))
    fail("{}: not an MCAP file (expected the magic bytes 89 4D 43 41 50 30 0D 0A at its start)",
         where);
  std::uint64_t pos = kMagic.size();
  bool first = true, data_end = false, footer = false;
  while (!footer) {
    if (pos == size_)
      fail("{}: the file ends at byte {} without {}: it is truncated", where, pos,
           data_end ? "a Footer record" : "a Data End record");
    const RecordView r = recordAt(all, pos, where, 0, "file");
    Cursor c(r.content, where, pos + 9, opName(r.op));
    if (first && r.op != kHeader)
      fail("{}: byte {}: the first record is {} (opcode 0x{:02x}); expected a Header", where, pos,
           opName(r.op), r.op);
    switch (r.op) {
      case kHeader:
        if (!first) fail("{}: byte {}: a second Header record", where, pos);
        profile_ = c.string("profile");
        library_ = c.string("library");
        break;
      case kSchema: {
        Schema s = parseSchema(c);
        if (s.id != 0) schemas_.try_emplace(s.id, std::move(s));
        break;
      }
      case kChannel: {
        Channel ch = parseChannel(c);
        channels_.try_emplace(ch.id, std::move(ch));
        break;
      }
      case kMessage: {
        if (data_end) fail("{}: byte {}: a Message record after Data End", where, pos);
        MessageLocation m;
        m.channel_id = c.u16("channel_id");
        m.sequence = c.u32("sequence");
        m.log_time = c.u64("log_time");
        m.publish_time = c.u64("publish_time");
        m.data_offset = c.absolute();
        m.data_size = c.remaining();
        if (!channels_.count(m.channel_id))
          fail("{}: byte {}: a message on channel {}, which no Channel record before it defines",
               where, pos, m.channel_id);
        messages_.push_back(m);
        break;
      }
      case kChunk:
        if (data_end) fail("{}: byte {}: a Chunk record after Data End", where, pos);
        readChunk(pos, r.content);
        break;
      case kMetadata: {
        std::string name = c.string("name");
        metadata_.emplace_back(std::move(name), c.stringMap("metadata"));
        break;
      }
      case kStatistics: {
        Statistics s;
        s.message_count = c.u64("message_count");
        s.schema_count = c.u16("schema_count");
        s.channel_count = c.u32("channel_count");
        s.attachment_count = c.u32("attachment_count");
        s.metadata_count = c.u32("metadata_count");
        s.chunk_count = c.u32("chunk_count");
        s.message_start_time = c.u64("message_start_time");
        s.message_end_time = c.u64("message_end_time");
        const std::uint32_t n = c.u32("channel_message_counts");
        Cursor m(c.bytes(n, "channel_message_counts"), where, c.absolute() - n, "Statistics");
        while (m.remaining() > 0) {
          const std::uint16_t id = m.u16("channel_message_counts");
          s.channel_message_counts[id] = m.u64("channel_message_counts");
        }
        statistics_ = std::move(s);
        break;
      }
      case kDataEnd:
        data_end = true;
        break;
      case kFooter: {
        footer = true;
        const std::uint64_t summary_start = c.u64("summary_start");
        c.u64("summary_offset_start");
        const std::uint32_t summary_crc = c.u32("summary_crc");
        if (summary_crc != 0 && summary_start != 0) {
          if (summary_start >= r.offset)
            fail("{}: Footer: summary_start {} is not before the footer at byte {}", where,
                 summary_start, r.offset);
          // From the summary's first byte through the footer's summary_offset_start field.
          const std::uint32_t crc =
              crc32(all.subspan(summary_start, r.offset + 9 + 16 - summary_start));
          if (crc != summary_crc)
            fail(
                "{}: the summary section's CRC-32 is {:08x}, the Footer says {:08x}: the file is "
                "corrupt",
                where, crc, summary_crc);
        }
        break;
      }
      default:  // Message/Chunk indexes, attachments, summary offsets, extensions: not needed
        break;
    }
    first = false;
    pos += 9 + r.content.size();
  }
  if (size_ - pos != kMagic.size() || !std::equal(kMagic.begin(), kMagic.end(), all.begin() + pos))
    fail(
        "{}: byte {}: expected the closing magic bytes right after the Footer record ({} bytes "
        "left)",
        where, pos, size_ - pos);
}

void Reader::readChunk(std::uint64_t record_offset, std::span<const std::uint8_t> content) {
  const std::string where = file_.string();
  Cursor c(content, where, record_offset + 9, "Chunk");
  ChunkInfo info;
  info.record_offset = record_offset;
  c.u64("message_start_time");
  c.u64("message_end_time");
  info.uncompressed_size = c.u64("uncompressed_size");
  info.uncompressed_crc = c.u32("uncompressed_crc");
  info.compression = c.string("compression");
  info.compressed_size = c.u64("records");
  info.records_offset = c.absolute();
  const auto compressed = c.bytes(info.compressed_size, "records");
  const std::uint32_t index = static_cast<std::uint32_t>(chunks_.size());
  const std::string chunk_where =
      fmt::format("{}: chunk {} at byte {}", where, index, record_offset);
  const std::vector<std::uint8_t> records =
      decompress(info.compression, compressed, info.uncompressed_size, chunk_where);
  if (info.uncompressed_crc != 0) {
    const std::uint32_t crc = crc32(records);
    if (crc != info.uncompressed_crc)
      fail("{}: the records' CRC-32 is {:08x}, the chunk says {:08x}: the chunk is corrupt",
           chunk_where, crc, info.uncompressed_crc);
  }
  chunks_.push_back(info);
  const std::span<const std::uint8_t> inner(records);
  std::uint64_t pos = 0;
  const std::string inner_where = chunk_where + " (uncompressed)";
  while (pos < inner.size()) {
    const RecordView r = recordAt(inner, pos, inner_where, 0, "chunk");
    Cursor rc(r.content, inner_where, pos + 9, opName(r.op));
    switch (r.op) {
      case kSchema: {
        Schema s = parseSchema(rc);
        if (s.id != 0) schemas_.try_emplace(s.id, std::move(s));
        break;
      }
      case kChannel: {
        Channel ch = parseChannel(rc);
        channels_.try_emplace(ch.id, std::move(ch));
        break;
      }
      case kMessage: {
        MessageLocation m;
        m.channel_id = rc.u16("channel_id");
        m.sequence = rc.u32("sequence");
        m.log_time = rc.u64("log_time");
        m.publish_time = rc.u64("publish_time");
        m.chunk = index;
        m.data_offset = rc.absolute();
        m.data_size = rc.remaining();
        if (!channels_.count(m.channel_id))
          fail(
              "{}: byte {} of the records: a message on channel {}, which no Channel record "
              "before it defines",
              chunk_where, pos, m.channel_id);
        messages_.push_back(m);
        break;
      }
      default:
        fail(
            "{}: byte {} of the records: a {} record (opcode 0x{:02x}) inside a chunk (expected "
            "Schema, Channel or Message)",
            chunk_where, pos, opName(r.op), r.op);
    }
    pos += 9 + r.content.size();
  }
}

std::shared_ptr<const std::vector<std::uint8_t>> Reader::chunkRecords(std::uint32_t chunk) const {
  if (cached_chunk_ == chunk) return cached_records_;
  const ChunkInfo& info = chunks_.at(chunk);
  auto records = std::make_shared<std::vector<std::uint8_t>>(decompress(
      info.compression,
      std::span<const std::uint8_t>(data_ + info.records_offset, info.compressed_size),
      info.uncompressed_size,
      fmt::format("{}: chunk {} at byte {}", file_.string(), chunk, info.record_offset)));
  cached_chunk_ = chunk;
  cached_records_ = records;
  return records;
}

std::vector<std::uint8_t> Reader::messageData(const MessageLocation& m) const {
  if (m.chunk == MessageLocation::kNoChunk) {
    if (m.data_offset > size_ || m.data_size > size_ - m.data_offset)
      fail("{}: message at byte {} runs past the end of the file", file_.string(), m.data_offset);
    return std::vector<std::uint8_t>(data_ + m.data_offset, data_ + m.data_offset + m.data_size);
  }
  std::lock_guard lock(cache_mutex_);
  const auto records = chunkRecords(m.chunk);
  if (m.data_offset > records->size() || m.data_size > records->size() - m.data_offset)
    fail("{}: message in chunk {} runs past the chunk's end", file_.string(), m.chunk);
  const auto begin = records->begin() + static_cast<std::ptrdiff_t>(m.data_offset);
  return std::vector<std::uint8_t>(begin, begin + static_cast<std::ptrdiff_t>(m.data_size));
}

// ---------------------------------------------------------------------------------------------
// Writer

namespace {

class RecordBuilder {
 public:
  explicit RecordBuilder(std::uint8_t op) { out_.push_back(op), out_.resize(9); }
  template <typename T>
  RecordBuilder& scalar(T v) {
    for (std::size_t i = 0; i < sizeof(T); ++i)
      out_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
    return *this;
  }
  RecordBuilder& u8(std::uint8_t v) { return scalar(v); }
  RecordBuilder& u16(std::uint16_t v) { return scalar(v); }
  RecordBuilder& u32(std::uint32_t v) { return scalar(v); }
  RecordBuilder& u64(std::uint64_t v) { return scalar(v); }
  RecordBuilder& string(const std::string& s) {
    u32(static_cast<std::uint32_t>(s.size()));
    out_.insert(out_.end(), s.begin(), s.end());
    return *this;
  }
  RecordBuilder& bytes(std::span<const std::uint8_t> b) {
    out_.insert(out_.end(), b.begin(), b.end());
    return *this;
  }
  RecordBuilder& stringMap(const std::map<std::string, std::string>& m) {
    std::uint32_t n = 0;
    for (const auto& [k, v] : m) n += static_cast<std::uint32_t>(8 + k.size() + v.size());
    u32(n);
    for (const auto& [k, v] : m) string(k).string(v);
    return *this;
  }
  std::vector<std::uint8_t> finish() {
    const std::uint64_t len = out_.size() - 9;
    for (int i = 0; i < 8; ++i) out_[1 + i] = static_cast<std::uint8_t>(len >> (8 * i));
    return std::move(out_);
  }

 private:
  std::vector<std::uint8_t> out_;
};

}  // namespace

Writer::Writer(const fs::path& file, std::string profile, std::string compression,
               std::size_t chunk_size)
    : file_(file), compression_(std::move(compression)), chunk_size_(chunk_size) {
  if (!compression_.empty() && compression_ != "zstd" && compression_ != "lz4")
    fail("MCAP writer: compression '{}' (expected zstd, lz4 or none)", compression_);
  out_.open(file, std::ios::binary | std::ios::trunc);
  if (!out_) fail("cannot write '{}'", file.string());
  emit(kMagic);
  emit(RecordBuilder(kHeader).string(profile).string("ovo").finish());
}

Writer::~Writer() = default;

void Writer::emit(std::span<const std::uint8_t> bytes) {
  out_.write(reinterpret_cast<const char*>(bytes.data()),
             static_cast<std::streamsize>(bytes.size()));
  if (in_data_) data_crc_ = crc32(bytes, data_crc_);
  offset_ += bytes.size();
}

std::uint16_t Writer::addSchema(const std::string& name, const std::string& encoding,
                                const std::string& data) {
  const auto id = static_cast<std::uint16_t>(schema_records_.size() + 1);
  auto record = RecordBuilder(kSchema)
                    .u16(id)
                    .string(name)
                    .string(encoding)
                    .u32(static_cast<std::uint32_t>(data.size()))
                    .bytes({reinterpret_cast<const std::uint8_t*>(data.data()), data.size()})
                    .finish();
  emit(record);
  schema_records_.push_back(std::move(record));
  return id;
}

std::uint16_t Writer::addChannel(std::uint16_t schema_id, const std::string& topic,
                                 const std::string& message_encoding,
                                 const std::map<std::string, std::string>& metadata) {
  const auto id = static_cast<std::uint16_t>(channel_records_.size() + 1);
  auto record = RecordBuilder(kChannel)
                    .u16(id)
                    .u16(schema_id)
                    .string(topic)
                    .string(message_encoding)
                    .stringMap(metadata)
                    .finish();
  emit(record);
  channel_records_.push_back(std::move(record));
  channel_counts_[id] = 0;
  return id;
}

void Writer::addMetadata(const std::string& name,
                         const std::map<std::string, std::string>& values) {
  flushChunk();
  const auto record = RecordBuilder(kMetadata).string(name).stringMap(values).finish();
  metadata_index_records_.push_back(
      RecordBuilder(kMetadataIndex).u64(offset_).u64(record.size()).string(name).finish());
  emit(record);
  ++metadata_count_;
}

void Writer::write(std::uint16_t channel_id, std::uint64_t log_time, std::uint64_t publish_time,
                   std::span<const std::uint8_t> data) {
  if (chunk_.empty()) chunk_start_ = chunk_end_ = log_time;
  chunk_start_ = std::min(chunk_start_, log_time);
  chunk_end_ = std::max(chunk_end_, log_time);
  if (message_count_ == 0) start_time_ = end_time_ = log_time;
  start_time_ = std::min(start_time_, log_time);
  end_time_ = std::max(end_time_, log_time);
  chunk_index_[channel_id].emplace_back(log_time, chunk_.size());
  const auto record = RecordBuilder(kMessage)
                          .u16(channel_id)
                          .u32(sequences_[channel_id]++)
                          .u64(log_time)
                          .u64(publish_time)
                          .bytes(data)
                          .finish();
  chunk_.insert(chunk_.end(), record.begin(), record.end());
  ++message_count_;
  ++channel_counts_[channel_id];
  if (chunk_.size() >= chunk_size_) flushChunk();
}

void Writer::flushChunk() {
  if (chunk_.empty()) return;
  std::vector<std::uint8_t> compressed;
  if (compression_ == "zstd") {
    compressed.resize(ZSTD_compressBound(chunk_.size()));
    const std::size_t n =
        ZSTD_compress(compressed.data(), compressed.size(), chunk_.data(), chunk_.size(), 3);
    if (ZSTD_isError(n))
      fail("{}: zstd compression failed: {}", file_.string(), ZSTD_getErrorName(n));
    compressed.resize(n);
  } else if (compression_ == "lz4") {
    LZ4F_preferences_t prefs{};
    prefs.frameInfo.contentSize = chunk_.size();
    compressed.resize(LZ4F_compressFrameBound(chunk_.size(), &prefs));
    const std::size_t n = LZ4F_compressFrame(compressed.data(), compressed.size(), chunk_.data(),
                                             chunk_.size(), &prefs);
    if (LZ4F_isError(n))
      fail("{}: lz4 compression failed: {}", file_.string(), LZ4F_getErrorName(n));
    compressed.resize(n);
  } else {
    compressed = chunk_;
  }
  const std::uint64_t chunk_offset = offset_;
  const auto record = RecordBuilder(kChunk)
                          .u64(chunk_start_)
                          .u64(chunk_end_)
                          .u64(chunk_.size())
                          .u32(crc32(chunk_))
                          .string(compression_)
                          .u64(compressed.size())
                          .bytes(compressed)
                          .finish();
  emit(record);
  const std::uint64_t index_start = offset_;
  RecordBuilder chunk_index(kChunkIndex);
  chunk_index.u64(chunk_start_).u64(chunk_end_).u64(chunk_offset).u64(record.size());
  std::vector<std::pair<std::uint16_t, std::uint64_t>> index_offsets;
  for (const auto& [channel, entries] : chunk_index_) {
    index_offsets.emplace_back(channel, offset_);
    RecordBuilder mi(kMessageIndex);
    mi.u16(channel).u32(static_cast<std::uint32_t>(entries.size() * 16));
    for (const auto& [t, off] : entries) mi.u64(t).u64(off);
    emit(mi.finish());
  }
  chunk_index.u32(static_cast<std::uint32_t>(index_offsets.size() * 10));
  for (const auto& [channel, off] : index_offsets) chunk_index.u16(channel).u64(off);
  chunk_index.u64(offset_ - index_start)
      .string(compression_)
      .u64(compressed.size())
      .u64(chunk_.size());
  chunk_index_records_.push_back(chunk_index.finish());
  ++chunk_count_;
  chunk_.clear();
  chunk_index_.clear();
}

void Writer::close() {
  if (closed_) return;
  flushChunk();
  emit(RecordBuilder(kDataEnd).u32(data_crc_).finish());
  in_data_ = false;
  const std::uint64_t summary_start = offset_;
  std::uint32_t summary_crc = 0;
  std::vector<std::vector<std::uint8_t>> offsets;
  auto group = [&](std::uint8_t op, const std::vector<std::vector<std::uint8_t>>& records) {
    if (records.empty()) return;
    const std::uint64_t start = offset_;
    for (const auto& r : records) {
      emit(r);
      summary_crc = crc32(r, summary_crc);
    }
    offsets.push_back(
        RecordBuilder(kSummaryOffset).u8(op).u64(start).u64(offset_ - start).finish());
  };
  group(kSchema, schema_records_);
  group(kChannel, channel_records_);
  group(kChunkIndex, chunk_index_records_);
  group(kMetadataIndex, metadata_index_records_);
  RecordBuilder stats(kStatistics);
  stats.u64(message_count_)
      .u16(static_cast<std::uint16_t>(schema_records_.size()))
      .u32(static_cast<std::uint32_t>(channel_records_.size()))
      .u32(0)
      .u32(metadata_count_)
      .u32(chunk_count_)
      .u64(start_time_)
      .u64(end_time_)
      .u32(static_cast<std::uint32_t>(channel_counts_.size() * 10));
  for (const auto& [id, n] : channel_counts_) stats.u16(id).u64(n);
  group(kStatistics, {stats.finish()});
  const std::uint64_t summary_offset_start = offset_;
  for (const auto& r : offsets) {
    emit(r);
    summary_crc = crc32(r, summary_crc);
  }
  // The footer's CRC covers the summary through its own summary_offset_start field.
  RecordBuilder footer(kFooter);
  footer.u64(summary_start).u64(summary_offset_start);
  std::vector<std::uint8_t> head = footer.finish();  // op, length (20 once complete), 16 bytes
  head[1] = 20;
  summary_crc = crc32(head, summary_crc);
  std::vector<std::uint8_t> full = head;
  for (int i = 0; i < 4; ++i) full.push_back(static_cast<std::uint8_t>(summary_crc >> (8 * i)));
  emit(full);
  emit(kMagic);
  out_.close();
  if (!out_) fail("writing '{}' failed (disk full?)", file_.string());
  closed_ = true;
}

}  // namespace ovo::io::mcap
