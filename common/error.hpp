// The exception type for errors a user can act on (files, configs, command line). The numeric
// core returns std::optional / status values instead and never throws for bad geometry.
#pragma once

#include <fmt/format.h>

#include <stdexcept>
#include <string>

namespace ovo {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Throws ovo::Error with a fmt-formatted message.
template <typename... Args>
[[noreturn]] void fail(fmt::format_string<Args...> format, Args&&... args) {
  throw Error(fmt::format(format, std::forward<Args>(args)...));
}

/// "file:line: what" — the form of every parse error ovo reports.
template <typename... Args>
[[noreturn]] void failAt(const std::string& file, long line, fmt::format_string<Args...> format,
                         Args&&... args) {
  throw Error(
      fmt::format("{}:{}: {}", file, line, fmt::format(format, std::forward<Args>(args)...)));
}

}  // namespace ovo
