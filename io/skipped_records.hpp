// The policy for a bad record in the middle of a sensor stream (a robot's day-long recording
// always has a few): by default it is skipped and counted here by sensor and reason
// (metrics.json "skipped"), and the caller warns once per kind; with RecordPolicy::strict it is an
// error naming the file and line, as before. Bad files as a whole (calibration, rig, config, a
// stream with no usable record) stay errors either way.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "common/error.hpp"

namespace ovo::io {

/// How stream readers and runners treat a bad record.
struct RecordPolicy {
  bool strict = false;  // true: the first bad record is an error (ovo run --strict)
};

/// A bad record: an ovo::Error ("file:line: what") that also says why, in one word of
/// snake_case ("unparsable", "non_finite", "stamp_backwards", ...), the key of metrics.json.
class RecordError : public Error {
 public:
  RecordError(std::string reason, const std::string& message)
      : Error(message), reason_(std::move(reason)) {}
  const std::string& reason() const { return reason_; }

 private:
  std::string reason_;
};

/// Skipped records counted by sensor ("camera", "gyro", "lidar") and reason.
class SkippedRecords {
 public:
  struct Kind {
    std::string sensor;
    std::string reason;
    long count = 0;
    std::string first;  // the first such record's message ("file:line: what")
  };

  /// Counts one record; true when it is the first of its kind (the caller warns once).
  bool add(const std::string& sensor, const std::string& reason, const std::string& message);
  /// Adds other's counts (kinds new to this one keep other's first message).
  void merge(const SkippedRecords& other);
  long total() const;
  long count(const std::string& sensor, const std::string& reason) const;
  bool empty() const { return kinds_.empty(); }
  /// In the order first seen.
  const std::vector<Kind>& kinds() const { return kinds_; }
  /// {"gyro": {"non_finite": 2}, "camera": {"decode": 1}}; an empty object when none.
  nlohmann::json toJson() const;
  /// The warning for a kind: "gyro: 3 records skipped (non_finite), the first: FILE:LINE: ...".
  static std::string describe(const Kind& kind);

 private:
  std::vector<Kind> kinds_;
};

}  // namespace ovo::io
