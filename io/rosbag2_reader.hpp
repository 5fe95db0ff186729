// ROS 2 bags as BagSources (io/bag_source.hpp): rosbag2's sqlite3 storage (.db3: tables topics
// and messages, every schema version since Eloquent) and MCAP files (io/mcap.hpp), alone or as a
// rosbag2 folder whose metadata.yaml lists them (split bags read as one). Messages are CDR
// (io/cdr.hpp). rosbag2's own compression (compression_mode file/message) is refused with a
// message saying so.
#pragma once

#include <filesystem>
#include <memory>

#include "io/bag_source.hpp"

namespace ovo::io::bag {

/// One .db3 file.
std::unique_ptr<BagSource> openSqlite3Bag(const std::filesystem::path& db3);
/// One .mcap file.
std::unique_ptr<BagSource> openMcapBag(const std::filesystem::path& mcap);
/// A rosbag2 folder: metadata.yaml (rosbag2_bagfile_information: storage_identifier sqlite3 or
/// mcap, relative_file_paths) and its files.
std::unique_ptr<BagSource> openRosbag2Folder(const std::filesystem::path& folder);

}  // namespace ovo::io::bag
