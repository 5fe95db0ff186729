// The ROS 2 BagWriters (io/bag_writer.hpp): rosbag2 sqlite3 (schema version 4, as rosbag2 Jazzy
// writes it: a folder with metadata.yaml version 8 and one .db3) and MCAP (ros2 profile, ros2msg
// schemas, CDR messages), both from the CDR encoders in io/cdr.hpp.
#include <fmt/format.h>
#include <sqlite3.h>

#include <fstream>
#include <limits>
#include <map>

#include "common/error.hpp"
#include "io/bag_writer.hpp"
#include "io/cdr.hpp"
#include "io/mcap.hpp"

namespace ovo::io {

namespace fs = std::filesystem;
using ros::MsgType;

namespace {

// rosbag2's default QoS profile text for a topic (reliable, volatile, keep last 10).
constexpr const char* kQos =
    "- history: 1\n  depth: 10\n  reliability: 1\n  durability: 2\n  deadline:\n    sec: "
    "2147483647\n    nsec: 4294967295\n  lifespan:\n    sec: 2147483647\n    nsec: 4294967295\n  "
    "liveliness: 1\n  liveliness_lease_duration:\n    sec: 2147483647\n    nsec: 4294967295\n  "
    "avoid_ros_namespace_conventions: false";

// Messages go through encode(), then to the storage with their topic's type.
class CdrWriter : public BagWriter {
 public:
  void write(const std::string& topic, const ros::Image& m) override {
    put(topic, MsgType::kImage, m.header.stamp_ns, ros::encode(m, ros::Wire::kCdr));
  }
  void write(const std::string& topic, const ros::CompressedImage& m) override {
    put(topic, MsgType::kCompressedImage, m.header.stamp_ns, ros::encode(m, ros::Wire::kCdr));
  }
  void write(const std::string& topic, const ros::Imu& m) override {
    put(topic, MsgType::kImu, m.header.stamp_ns, ros::encode(m, ros::Wire::kCdr));
  }
  void write(const std::string& topic, const ros::LaserScan& m) override {
    put(topic, MsgType::kLaserScan, m.header.stamp_ns, ros::encode(m, ros::Wire::kCdr));
  }

 protected:
  virtual void put(const std::string& topic, MsgType type, Timestamp t_ns,
                   const std::vector<std::uint8_t>& cdr) = 0;
};

// --- sqlite3 ---------------------------------------------------------------------------------

std::string yamlQuoted(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    out += c;
  }
  return out + "\"";
}

class Sqlite3Writer : public CdrWriter {
 public:
  explicit Sqlite3Writer(const fs::path& folder) : folder_(folder) {
    std::error_code ec;
    fs::create_directories(folder, ec);
    if (ec) fail("cannot create '{}': {}", folder.string(), ec.message());
    file_name_ = folder.filename().string() + "_0.db3";
    const fs::path db_file = folder / file_name_;
    fs::remove(db_file, ec);
    if (sqlite3_open_v2(db_file.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE,
                        nullptr) != SQLITE_OK)
      fail("cannot create '{}': {}", db_file.string(), db_ ? sqlite3_errmsg(db_) : "?");
    exec("PRAGMA journal_mode = MEMORY");
    exec("PRAGMA synchronous = OFF");
    exec("CREATE TABLE schema(schema_version INTEGER PRIMARY KEY,ros_distro TEXT NOT NULL)");
    exec("INSERT INTO schema VALUES (4, 'jazzy')");
    exec(
        "CREATE TABLE metadata(id INTEGER PRIMARY KEY,metadata_version INTEGER NOT NULL,metadata "
        "TEXT NOT NULL)");
    exec(
        "CREATE TABLE topics(id INTEGER PRIMARY KEY,name TEXT NOT NULL,type TEXT NOT "
        "NULL,serialization_format TEXT NOT NULL,offered_qos_profiles TEXT NOT "
        "NULL,type_description_hash TEXT NOT NULL)");
    exec(
        "CREATE TABLE message_definitions(id INTEGER PRIMARY KEY,topic_type TEXT NOT "
        "NULL,encoding TEXT NOT NULL,encoded_message_definition TEXT NOT "
        "NULL,type_description_hash TEXT NOT NULL)");
    exec(
        "CREATE TABLE messages(id INTEGER PRIMARY KEY,topic_id INTEGER NOT NULL,timestamp "
        "INTEGER NOT NULL, data BLOB NOT NULL)");
    exec("CREATE INDEX timestamp_idx ON messages (timestamp ASC)");
    exec("BEGIN TRANSACTION");
    if (sqlite3_prepare_v2(db_, "INSERT INTO messages (topic_id, timestamp, data) VALUES (?, ?, ?)",
                           -1, &insert_, nullptr) != SQLITE_OK)
      failSql("preparing the message insert");
  }
  ~Sqlite3Writer() override {
    if (insert_) sqlite3_finalize(insert_);
    if (db_) sqlite3_close(db_);
  }

  void close() override {
    if (closed_) return;
    exec("COMMIT");
    const std::string meta = metadataYaml();
    sqlite3_stmt* st = nullptr;
    sqlite3_prepare_v2(db_, "INSERT INTO metadata (metadata_version, metadata) VALUES (8, ?)", -1,
                       &st, nullptr);
    sqlite3_bind_text(st, 1, meta.c_str(), -1, SQLITE_TRANSIENT);
    const int rc = sqlite3_step(st);
    sqlite3_finalize(st);
    if (rc != SQLITE_DONE) failSql("writing the metadata row");
    sqlite3_finalize(insert_);
    insert_ = nullptr;
    if (sqlite3_close(db_) != SQLITE_OK) failSql("closing");
    db_ = nullptr;
    std::ofstream out(folder_ / "metadata.yaml");
    out << meta;
    out.close();
    if (!out) fail("cannot write '{}'", (folder_ / "metadata.yaml").string());
    closed_ = true;
  }

 protected:
  void put(const std::string& topic, MsgType type, Timestamp t_ns,
           const std::vector<std::uint8_t>& cdr) override {
    auto it = topic_ids_.find(topic);
    if (it == topic_ids_.end()) {
      const std::string type_name = ros::ros2TypeName(type);
      const auto id = static_cast<std::int64_t>(topic_ids_.size() + 1);
      exec(fmt::format("INSERT INTO topics VALUES ({}, '{}', '{}', 'cdr', '{}', '')", id, topic,
                       type_name, kQos));
      exec(
          fmt::format("INSERT INTO message_definitions (topic_type, encoding, "
                      "encoded_message_definition, type_description_hash) VALUES ('{}', "
                      "'ros2msg', '{}', '')",
                      type_name, ros::ros2MessageDefinition(type)));
      it = topic_ids_.emplace(topic, id).first;
      topic_types_[topic] = type_name;
    }
    sqlite3_reset(insert_);
    sqlite3_bind_int64(insert_, 1, it->second);
    sqlite3_bind_int64(insert_, 2, t_ns);
    sqlite3_bind_blob(insert_, 3, cdr.data(), static_cast<int>(cdr.size()), SQLITE_STATIC);
    if (sqlite3_step(insert_) != SQLITE_DONE) failSql("writing a message");
    ++counts_[topic];
    start_ = std::min(start_, t_ns);
    end_ = std::max(end_, t_ns);
    ++total_;
  }

 private:
  void exec(const std::string& sql) {
    char* err = nullptr;
    if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &err) != SQLITE_OK) {
      const std::string msg = err ? err : "?";
      sqlite3_free(err);
      fail("{}: sqlite: {} ({})", (folder_ / file_name_).string(), msg, sql.substr(0, 60));
    }
  }
  [[noreturn]] void failSql(const std::string& what) {
    fail("{}: {}: {}", (folder_ / file_name_).string(), what, sqlite3_errmsg(db_));
  }

  std::string metadataYaml() const {
    const Timestamp start = total_ ? start_ : 0, duration = total_ ? end_ - start_ : 0;
    std::string y = "rosbag2_bagfile_information:\n  version: 8\n  storage_identifier: sqlite3\n";
    y += fmt::format("  duration:\n    nanoseconds: {}\n", duration);
    y += fmt::format("  starting_time:\n    nanoseconds_since_epoch: {}\n", start);
    y += fmt::format("  message_count: {}\n  topics_with_message_count:\n", total_);
    for (const auto& [topic, n] : counts_)
      y += fmt::format(
          "    - topic_metadata:\n        name: {}\n        type: {}\n        "
          "serialization_format: "
          "cdr\n        offered_qos_profiles: {}\n        type_description_hash: \"\"\n      "
          "message_count: {}\n",
          topic, topic_types_.at(topic), yamlQuoted(kQos), n);
    y += "  compression_format: \"\"\n  compression_mode: \"\"\n  relative_file_paths:\n";
    y += fmt::format("    - {}\n  files:\n    - path: {}\n", file_name_, file_name_);
    y += fmt::format(
        "      starting_time:\n        nanoseconds_since_epoch: {}\n      duration:\n        "
        "nanoseconds: {}\n      message_count: {}\n",
        start, duration, total_);
    y += "  custom_data: ~\n  ros_distro: jazzy\n";
    return y;
  }

  fs::path folder_;
  std::string file_name_;
  sqlite3* db_ = nullptr;
  sqlite3_stmt* insert_ = nullptr;
  std::map<std::string, std::int64_t> topic_ids_;
  std::map<std::string, std::string> topic_types_;
  std::map<std::string, std::uint64_t> counts_;
  Timestamp start_ = std::numeric_limits<Timestamp>::max(),
            end_ = std::numeric_limits<Timestamp>::min();
  std::uint64_t total_ = 0;
  bool closed_ = false;
};

// --- MCAP ------------------------------------------------------------------------------------

class McapWriter : public CdrWriter {
 public:
  McapWriter(const fs::path& file, const std::string& compression)
      : writer_(file, "ros2", compression == "none" ? "" : compression) {}

  void close() override { writer_.close(); }

 protected:
  void put(const std::string& topic, MsgType type, Timestamp t_ns,
           const std::vector<std::uint8_t>& cdr) override {
    auto it = channels_.find(topic);
    if (it == channels_.end()) {
      const std::string type_name = ros::ros2TypeName(type);
      auto schema = schemas_.find(type_name);
      if (schema == schemas_.end())
        schema = schemas_
                     .emplace(type_name, writer_.addSchema(type_name, "ros2msg",
                                                           ros::ros2MessageDefinition(type)))
                     .first;
      it = channels_
               .emplace(topic, writer_.addChannel(schema->second, topic, "cdr",
                                                  {{"offered_qos_profiles", kQos}}))
               .first;
    }
    if (t_ns < 0) fail("MCAP: cannot write a negative time stamp ({} ns)", t_ns);
    writer_.write(it->second, static_cast<std::uint64_t>(t_ns), static_cast<std::uint64_t>(t_ns),
                  cdr);
  }

 private:
  mcap::Writer writer_;
  std::map<std::string, std::uint16_t> schemas_, channels_;
};

}  // namespace

std::unique_ptr<BagWriter> makeSqlite3BagWriter(const fs::path& folder) {
  return std::make_unique<Sqlite3Writer>(folder);
}

std::unique_ptr<BagWriter> makeMcapBagWriter(const fs::path& file, const std::string& compression) {
  return std::make_unique<McapWriter>(file, compression.empty() ? "zstd" : compression);
}

}  // namespace ovo::io
