#include "io/rosbag2_reader.hpp"

#include <sqlite3.h>
#include <yaml-cpp/yaml.h>

#include <map>
#include <mutex>

#include "common/error.hpp"
#include "io/mcap.hpp"

namespace ovo::io::bag {

namespace fs = std::filesystem;

namespace {

// Topics merged by name over files/channels; a name seen with two types is an error.
std::uint32_t topicIndex(std::vector<Topic>& topics, std::map<std::string, std::uint32_t>& by_name,
                         const std::string& name, const std::string& type,
                         const std::string& encoding, const std::string& where) {
  auto it = by_name.find(name);
  if (it != by_name.end()) {
    const Topic& t = topics[it->second];
    if (t.type != type)
      fail("{}: topic {} has two types, {} and {}: expected one type a topic", where, name, t.type,
           type);
    return it->second;
  }
  topics.push_back({name, type, encoding, "", 0});
  const auto index = static_cast<std::uint32_t>(topics.size() - 1);
  by_name.emplace(name, index);
  return index;
}

// --- sqlite3 ---------------------------------------------------------------------------------

class Sqlite3File {
 public:
  explicit Sqlite3File(const fs::path& file) : file_(file) {
    if (!fs::is_regular_file(file)) fail("{}: rosbag2 sqlite3 file not found", file.string());
    // Read-only; a folder that cannot be written to (no -shm/-wal can be made) needs immutable.
    for (const bool immutable : {false, true}) {
      const std::string uri = "file:" + file.string() + (immutable ? "?immutable=1" : "");
      if (sqlite3_open_v2(uri.c_str(), &db_, SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, nullptr) ==
              SQLITE_OK &&
          sqlite3_exec(db_, "SELECT count(*) FROM sqlite_master", nullptr, nullptr, nullptr) ==
              SQLITE_OK)
        return;
      last_error_ = db_ ? sqlite3_errmsg(db_) : "cannot open";
      sqlite3_close(db_);
      db_ = nullptr;
    }
    fail("{}: cannot read it as an SQLite database ({}): expected a rosbag2 .db3 file",
         file.string(), last_error_);
  }
  ~Sqlite3File() {
    if (payload_) sqlite3_finalize(payload_);
    if (db_) sqlite3_close(db_);
  }
  Sqlite3File(const Sqlite3File&) = delete;
  Sqlite3File& operator=(const Sqlite3File&) = delete;

  [[noreturn]] void failSql(const std::string& what) const {
    fail("{}: {}: {} (a corrupt or truncated rosbag2 .db3 file?)", file_.string(), what,
         sqlite3_errmsg(db_));
  }

  sqlite3_stmt* prepare(const char* sql) const {
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(db_, sql, -1, &st, nullptr) != SQLITE_OK)
      failSql(fmt::format("'{}'", sql));
    return st;
  }

  // Calls row(statement) for each row of `sql`.
  template <typename Row>
  void query(const char* sql, Row row) const {
    sqlite3_stmt* st = prepare(sql);
    int rc;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
      try {
        row(st);
      } catch (...) {
        sqlite3_finalize(st);
        throw;
      }
    }
    sqlite3_finalize(st);
    if (rc != SQLITE_DONE) failSql(fmt::format("reading '{}'", sql));
  }

  std::vector<std::uint8_t> payload(std::int64_t row_id) const {
    std::lock_guard lock(mutex_);
    if (!payload_) payload_ = prepare("SELECT data FROM messages WHERE id = ?");
    sqlite3_reset(payload_);
    sqlite3_bind_int64(payload_, 1, row_id);
    const int rc = sqlite3_step(payload_);
    if (rc != SQLITE_ROW) {
      if (rc == SQLITE_DONE) fail("{}: message row {} is gone", file_.string(), row_id);
      failSql(fmt::format("reading message row {}", row_id));
    }
    const auto* p = static_cast<const std::uint8_t*>(sqlite3_column_blob(payload_, 0));
    const int n = sqlite3_column_bytes(payload_, 0);
    std::vector<std::uint8_t> data(p, p + n);
    sqlite3_reset(payload_);
    return data;
  }

  const fs::path& file() const { return file_; }

 private:
  fs::path file_;
  sqlite3* db_ = nullptr;
  std::string last_error_;
  mutable std::mutex mutex_;
  mutable sqlite3_stmt* payload_ = nullptr;
};

std::string text(sqlite3_stmt* st, int col) {
  const auto* p = sqlite3_column_text(st, col);
  return p ? std::string(reinterpret_cast<const char*>(p)) : std::string();
}

class Sqlite3Bag : public BagSource {
 public:
  Sqlite3Bag(const fs::path& path, const std::vector<fs::path>& files)
      : BagSource(path, "rosbag2 sqlite3") {
    std::map<std::string, std::uint32_t> by_name;
    for (std::size_t f = 0; f < files.size(); ++f) {
      files_.push_back(std::make_unique<Sqlite3File>(files[f]));
      const Sqlite3File& db = *files_.back();
      const std::string where = files[f].string();
      std::map<std::int64_t, std::uint32_t> topic_of_id;
      db.query("SELECT id, name, type, serialization_format FROM topics ORDER BY id",
               [&](sqlite3_stmt* st) {
                 const std::string format = text(st, 3);
                 topic_of_id[sqlite3_column_int64(st, 0)] =
                     topicIndex(topics_, by_name, text(st, 1), text(st, 2), format, where);
               });
      db.query("SELECT id, topic_id, timestamp FROM messages ORDER BY timestamp, id",
               [&](sqlite3_stmt* st) {
                 const std::int64_t topic_id = sqlite3_column_int64(st, 1);
                 const auto it = topic_of_id.find(topic_id);
                 if (it == topic_of_id.end())
                   fail("{}: message row {} has topic_id {}, which the topics table does not hold",
                        where, sqlite3_column_int64(st, 0), topic_id);
                 MessageRef ref;
                 ref.topic = it->second;
                 ref.log_time_ns = sqlite3_column_int64(st, 2);
                 ref.offset = static_cast<std::uint64_t>(sqlite3_column_int64(st, 0));
                 ref.block = static_cast<std::uint32_t>(f);
                 messages_.push_back(ref);
               });
    }
    finishListing();
  }

  std::vector<std::uint8_t> payload(const MessageRef& ref) const override {
    return files_.at(ref.block)->payload(static_cast<std::int64_t>(ref.offset));
  }

 private:
  std::vector<std::unique_ptr<Sqlite3File>> files_;
};

// --- MCAP ------------------------------------------------------------------------------------

class McapBag : public BagSource {
 public:
  McapBag(const fs::path& path, const std::vector<fs::path>& files) : BagSource(path, "MCAP") {
    std::map<std::string, std::uint32_t> by_name;
    for (std::size_t f = 0; f < files.size(); ++f) {
      readers_.push_back(std::make_unique<mcap::Reader>(files[f]));
      const mcap::Reader& r = *readers_.back();
      const std::string where = files[f].string();
      std::map<std::uint16_t, std::uint32_t> topic_of_channel;
      for (const auto& [id, ch] : r.channels()) {
        std::string type;
        if (ch.schema_id != 0) {
          const auto s = r.schemas().find(ch.schema_id);
          if (s == r.schemas().end())
            fail("{}: channel {} ({}) refers to schema {}, which the file does not define", where,
                 id, ch.topic, ch.schema_id);
          type = s->second.name;
        }
        topic_of_channel[id] =
            topicIndex(topics_, by_name, ch.topic, type, ch.message_encoding, where);
      }
      for (std::size_t i = 0; i < r.messages().size(); ++i) {
        const mcap::MessageLocation& m = r.messages()[i];
        MessageRef ref;
        ref.topic = topic_of_channel.at(m.channel_id);
        ref.log_time_ns = static_cast<Timestamp>(m.log_time);
        ref.offset = i;
        ref.block = static_cast<std::uint32_t>(f);
        messages_.push_back(ref);
      }
    }
    finishListing();
  }

  std::vector<std::uint8_t> payload(const MessageRef& ref) const override {
    const mcap::Reader& r = *readers_.at(ref.block);
    return r.messageData(r.messages().at(ref.offset));
  }

 private:
  std::vector<std::unique_ptr<mcap::Reader>> readers_;
};

}  // namespace

std::unique_ptr<BagSource> openSqlite3Bag(const fs::path& db3) {
  return std::make_unique<Sqlite3Bag>(db3, std::vector<fs::path>{db3});
}

std::unique_ptr<BagSource> openMcapBag(const fs::path& file) {
  return std::make_unique<McapBag>(file, std::vector<fs::path>{file});
}

std::unique_ptr<BagSource> openRosbag2Folder(const fs::path& folder) {
  const fs::path meta_file = folder / "metadata.yaml";
  const std::string where = meta_file.string();
  YAML::Node root;
  try {
    root = YAML::LoadFile(meta_file.string());
  } catch (const YAML::Exception& e) {
    fail("{}: not readable as YAML ({})", where, e.what());
  }
  const YAML::Node info = root["rosbag2_bagfile_information"];
  if (!info || !info.IsMap())
    fail("{}: expected a rosbag2 metadata file (a map 'rosbag2_bagfile_information')", where);
  std::string storage, compression, mode;
  std::vector<fs::path> files;
  try {
    storage = info["storage_identifier"] ? info["storage_identifier"].as<std::string>() : "";
    compression = info["compression_format"] ? info["compression_format"].as<std::string>() : "";
    mode = info["compression_mode"] ? info["compression_mode"].as<std::string>() : "";
    if (const YAML::Node paths = info["relative_file_paths"]; paths && paths.IsSequence())
      for (const auto& p : paths) files.push_back(folder / p.as<std::string>());
  } catch (const YAML::Exception& e) {
    fail("{}: rosbag2_bagfile_information: {}", where, e.what());
  }
  if (!compression.empty() || (!mode.empty() && mode != "NONE"))
    fail(
        "{}: rosbag2 compression '{}' (mode '{}') is not supported: expected an uncompressed "
        "bag (MCAP's own chunk compression is fine); decompress it with `ros2 bag convert`",
        where, compression, mode);
  if (files.empty()) fail("{}: relative_file_paths lists no files", where);
  for (const fs::path& f : files)
    if (!fs::is_regular_file(f)) fail("{}: lists {}, which does not exist", where, f.string());
  if (storage == "sqlite3") return std::make_unique<Sqlite3Bag>(folder, files);
  if (storage == "mcap") return std::make_unique<McapBag>(folder, files);
  fail("{}: storage_identifier '{}': expected sqlite3 or mcap", where, storage);
}

}  // namespace ovo::io::bag
