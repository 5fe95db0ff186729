// Reading a sensor stream's rows (gyro, LiDAR, image list) under the bad-record policy
// (io/skipped_records.hpp): each row parses into one time-stamped record or is a bad record;
// stamps must increase.
#pragma once

#include <fmt/format.h>

#include <optional>
#include <string_view>
#include <vector>

#include "io/skipped_records.hpp"
#include "io/text_reader.hpp"

namespace ovo::io {

/// Reads every row of `in` with parse(tokens), which returns a record with a t_ns member or throws
/// a RecordError (TextReader::reject). Strict: the first bad record is the error. Otherwise bad
/// records are skipped and counted under `sensor`, including a record whose stamp is not after the
/// last one kept ("stamp_duplicate", "stamp_backwards"); when that stamp is before the last one
/// kept but after the one before, the last one kept is taken for what was wrong (a single stamp
/// ahead of the stream around it, "stamp_ahead": one corrupt stamp far in the future would
/// otherwise make every later record look backwards) and it goes instead.
/// A stream left without any record is an error naming the file and its first bad record.
template <typename Parse>
auto readRecordStream(TextReader& in, const char* sensor, const RecordPolicy& policy,
                      SkippedRecords& skipped, Parse&& parse) {
  using Record = decltype(parse(std::declval<const std::vector<std::string_view>&>()));
  std::vector<Record> records;
  long last_line = 0;  // of records.back()
  std::optional<std::string> first_bad;
  std::vector<std::string_view> tok;
  while (in.next(tok)) {
    try {
      Record r = parse(tok);
      if (!records.empty() && r.t_ns <= records.back().t_ns) {
        const bool ahead = r.t_ns < records.back().t_ns && records.size() >= 2 &&
                           r.t_ns > records[records.size() - 2].t_ns;
        if (!ahead || policy.strict)
          checkIncreasing(in, records.back().t_ns, r.t_ns, false);  // rejects
        const std::string message = fmt::format(
            "{}:{}: time stamp {} ns is ahead of the records before and after it ({} and {} ns)",
            in.fileName(), last_line, records.back().t_ns, records[records.size() - 2].t_ns,
            r.t_ns);
        if (!first_bad) first_bad = message;
        skipped.add(sensor, "stamp_ahead", message);
        records.pop_back();
      }
      records.push_back(std::move(r));
      last_line = in.lineNumber();
    } catch (const RecordError& e) {
      if (policy.strict) throw;
      if (!first_bad) first_bad = e.what();
      skipped.add(sensor, e.reason(), e.what());
    }
  }
  if (records.empty() && first_bad)
    fail("{}: no usable record (every one is bad; the first: {})", in.fileName(), *first_bad);
  return records;
}

}  // namespace ovo::io
