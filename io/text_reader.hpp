// Line-oriented reading of the text formats ovo loads (csv, TUM, KITTI): numbered lines, tokens,
// and number parsing whose errors name the file, the line and what was expected.
#pragma once

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

#include "common/error.hpp"
#include "common/types.hpp"
#include "io/skipped_records.hpp"

namespace ovo::io {

/// Reads a text file line by line, skipping blank lines and lines starting with '#'.
class TextReader {
 public:
  /// Throws ovo::Error when the file cannot be opened (names the file and what it should hold).
  TextReader(const std::filesystem::path& file, std::string_view what);

  /// Next data line split into tokens (separators: commas and white space); false at the end.
  bool next(std::vector<std::string_view>& tokens);
  long lineNumber() const { return line_number_; }
  /// The current line as read.
  const std::string& line() const { return line_; }
  const std::string& fileName() const { return file_name_; }

  /// Throws "file:line: message" for the current line.
  template <typename... Args>
  [[noreturn]] void fail(fmt::format_string<Args...> format, Args&&... args) const {
    failAt(file_name_, line_number_, format, std::forward<Args>(args)...);
  }

  /// Throws a RecordError "file:line: message" for the current line: a bad record, which a stream
  /// reader may skip (io/skipped_records.hpp); `reason` is its metrics.json key.
  template <typename... Args>
  [[noreturn]] void reject(const char* reason, fmt::format_string<Args...> format,
                           Args&&... args) const {
    throw RecordError(reason, fmt::format("{}:{}: {}", file_name_, line_number_,
                                          fmt::format(format, std::forward<Args>(args)...)));
  }

  // The number readers reject a bad token as a bad record (reason "unparsable", or "non_finite"
  // for nan/inf where a finite number is expected).
  /// A finite number; `what` names the column in the message.
  double number(std::string_view token, std::string_view what) const;
  /// A number that may be NaN or infinite (e.g. a LiDAR range with no return).
  double numberOrNonFinite(std::string_view token, std::string_view what) const;
  /// An integer (e.g. a time stamp in nanoseconds).
  std::int64_t integer(std::string_view token, std::string_view what) const;
  /// A time in seconds ("1305031102.160407" read exactly, "1.4037e+09" via long double) in ns.
  Timestamp secondsToNs(std::string_view token, std::string_view what) const;

 private:
  std::ifstream in_;
  std::string file_name_;
  std::string line_;
  long line_number_ = 0;
};

/// Rejects the record (naming in's file and line; reason "stamp_duplicate" or "stamp_backwards")
/// unless t_ns comes after previous; the first stamp of a file (first) may be anything.
void checkIncreasing(const TextReader& in, Timestamp previous, Timestamp t_ns, bool first);

/// Writes `content` to a temporary file beside `file` and renames it over `file`, so that a
/// reader never sees a half-written file. Throws ovo::Error naming the file on failure.
void writeFileAtomically(const std::filesystem::path& file, const std::string& content);

/// "12.000000001" for 12000000001 ns: exact, 9 decimals.
std::string formatSeconds(Timestamp t_ns);

}  // namespace ovo::io
