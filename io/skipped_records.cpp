#include "io/skipped_records.hpp"

#include <fmt/format.h>

namespace ovo::io {

bool SkippedRecords::add(const std::string& sensor, const std::string& reason,
                         const std::string& message) {
  for (Kind& k : kinds_)
    if (k.sensor == sensor && k.reason == reason) {
      ++k.count;
      return false;
    }
  kinds_.push_back({sensor, reason, 1, message});
  return true;
}

void SkippedRecords::merge(const SkippedRecords& other) {
  for (const Kind& o : other.kinds_) {
    bool found = false;
    for (Kind& k : kinds_)
      if (k.sensor == o.sensor && k.reason == o.reason) {
        k.count += o.count;
        found = true;
      }
    if (!found) kinds_.push_back(o);
  }
}

long SkippedRecords::total() const {
  long n = 0;
  for (const Kind& k : kinds_) n += k.count;
  return n;
}

long SkippedRecords::count(const std::string& sensor, const std::string& reason) const {
  for (const Kind& k : kinds_)
    if (k.sensor == sensor && k.reason == reason) return k.count;
  return 0;
}

nlohmann::json SkippedRecords::toJson() const {
  nlohmann::json j = nlohmann::json::object();
  for (const Kind& k : kinds_) j[k.sensor][k.reason] = k.count;
  return j;
}

std::string SkippedRecords::describe(const Kind& kind) {
  return fmt::format("{}: {} bad record{} skipped ({}), the first: {}", kind.sensor, kind.count,
                     kind.count == 1 ? "" : "s", kind.reason, kind.first);
}

}  // namespace ovo::io
