#include "io/text_reader.hpp"

#include <unistd.h>

#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <system_error>

#include "common/text.hpp"

namespace ovo::io {

TextReader::TextReader(const std::filesystem::path& file, std::string_view what)
    : in_(file), file_name_(file.string()) {
  std::error_code ec;
  if (std::filesystem::is_directory(file, ec))
    ovo::fail("{}: is a folder, expected a file ({})", file_name_, what);
  if (!in_) ovo::fail("{}: cannot open file ({})", file_name_, what);
}

bool TextReader::next(std::vector<std::string_view>& tokens) {
  while (std::getline(in_, line_)) {
    ++line_number_;
    if (!line_.empty() && line_.back() == '\r') line_.pop_back();
    if (line_number_ == 1) eraseUtf8Bom(line_);
    std::size_t first = line_.find_first_not_of(" \t");
    if (first == std::string::npos || line_[first] == '#') continue;
    tokens.clear();
    const std::string_view line(line_);
    std::size_t i = first;
    while (i < line.size()) {
      // A comma ends a field (possibly empty); blanks around fields are ignored.
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
      std::size_t j = i;
      while (j < line.size() && line[j] != ',' && line[j] != ' ' && line[j] != '\t') ++j;
      std::size_t k = j;
      while (k < line.size() && (line[k] == ' ' || line[k] == '\t')) ++k;
      if (j > i || (k < line.size() && line[k] == ',')) tokens.push_back(line.substr(i, j - i));
      if (k < line.size() && line[k] == ',') ++k;
      i = k;
    }
    return true;
  }
  return false;
}

namespace {

bool parseDouble(std::string_view token, double& value) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  if (token.empty()) return false;
  const auto [ptr, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  return ec == std::errc() && ptr == token.data() + token.size();
}

}  // namespace

double TextReader::number(std::string_view token, std::string_view what) const {
  double v = 0.0;
  if (!parseDouble(token, v))
    reject("unparsable", "expected a number for {}, got '{}'", what, token);
  if (!std::isfinite(v))
    reject("non_finite", "expected a finite number for {}, got '{}'", what, token);
  return v;
}

double TextReader::numberOrNonFinite(std::string_view token, std::string_view what) const {
  double v = 0.0;
  if (!parseDouble(token, v))
    reject("unparsable", "expected a number (or nan) for {}, got '{}'", what, token);
  return v;
}

std::int64_t TextReader::integer(std::string_view token, std::string_view what) const {
  std::int64_t v = 0;
  std::string_view t = token;
  if (!t.empty() && t.front() == '+') t.remove_prefix(1);
  const auto [ptr, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
  if (t.empty() || ec != std::errc() || ptr != t.data() + t.size())
    reject("unparsable", "expected an integer for {}, got '{}'", what, token);
  return v;
}

Timestamp TextReader::secondsToNs(std::string_view token, std::string_view what) const {
  constexpr std::int64_t kMaxSeconds = 9'000'000'000;  // int64 ns reach 9.2e9 s
  std::string_view t = token;
  bool negative = false;
  if (!t.empty() && (t.front() == '+' || t.front() == '-')) {
    negative = t.front() == '-';
    t.remove_prefix(1);
  }
  // Plain decimal: exact integer arithmetic (nanosecond resolution, digits beyond 9 rounded).
  const std::size_t dot = t.find('.');
  const std::string_view whole = t.substr(0, dot);
  const std::string_view frac =
      dot == std::string_view::npos ? std::string_view() : t.substr(dot + 1);
  auto all_digits = [](std::string_view s) {
    for (char c : s)
      if (c < '0' || c > '9') return false;
    return true;
  };
  if (!t.empty() && all_digits(whole) && all_digits(frac) && whole.size() + frac.size() > 0 &&
      whole.size() <= 10) {
    std::int64_t s = 0, ns = 0;
    for (char c : whole) s = s * 10 + (c - '0');
    // As in the scientific branch: 9e9 s (year 2255) and beyond would overflow int64 ns.
    if (s > kMaxSeconds)
      reject("unparsable", "expected a time in seconds of at most {} for {}, got '{}'", kMaxSeconds,
             what, token);
    std::int64_t scale = 100000000;
    for (std::size_t i = 0; i < frac.size() && i < 9; ++i, scale /= 10)
      ns += (frac[i] - '0') * scale;
    if (frac.size() > 9 && frac[9] >= '5') ns += 1;
    const std::int64_t total = s * 1000000000 + ns;
    return negative ? -total : total;
  }
  // Scientific notation: long double keeps about 19 significant digits.
  const std::string copy(token);
  char* end = nullptr;
  const long double v = std::strtold(copy.c_str(), &end);
  if (copy.empty() || end != copy.c_str() + copy.size())
    reject("unparsable", "expected a time in seconds for {}, got '{}'", what, token);
  if (!std::isfinite(v) || std::fabs(v) > static_cast<long double>(kMaxSeconds))
    reject("unparsable", "expected a finite time in seconds for {}, got '{}'", what, token);
  return static_cast<Timestamp>(std::llround(v * 1.0e9L));
}

void writeFileAtomically(const std::filesystem::path& file, const std::string& content) {
  const std::filesystem::path tmp =
      file.string() + ".tmp" + std::to_string(static_cast<long>(::getpid()));
  {
    std::FILE* f = std::fopen(tmp.c_str(), "wb");
    if (!f) ovo::fail("{}: cannot write (cannot create {})", file.string(), tmp.string());
    const bool ok = std::fwrite(content.data(), 1, content.size(), f) == content.size();
    const bool closed = std::fclose(f) == 0;
    if (!ok || !closed) {
      std::error_code ec;
      std::filesystem::remove(tmp, ec);
      ovo::fail("{}: write failed (disk full?)", file.string());
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, file, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    ovo::fail("{}: cannot replace the file: {}", file.string(), ec.message());
  }
}

std::string formatSeconds(Timestamp t_ns) {
  const bool negative = t_ns < 0;
  const std::uint64_t a =
      negative ? static_cast<std::uint64_t>(-(t_ns + 1)) + 1u : static_cast<std::uint64_t>(t_ns);
  return fmt::format("{}{}.{:09d}", negative ? "-" : "", a / 1000000000u, a % 1000000000u);
}

void checkIncreasing(const TextReader& in, Timestamp previous, Timestamp t_ns, bool first) {
  if (!first && t_ns <= previous)
    in.reject(t_ns == previous ? "stamp_duplicate" : "stamp_backwards",
              "time stamps must increase: {} ns after {} ns", t_ns, previous);
}

}  // namespace ovo::io
