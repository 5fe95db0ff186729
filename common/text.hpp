// Small text helpers shared by the file readers.
#pragma once

#include <string>
#include <string_view>

namespace ovo {

/// Removes a UTF-8 byte-order mark from the start of `text` (the first line or the whole file),
/// as some Windows editors save one: it is not part of the data.
inline void eraseUtf8Bom(std::string& text) {
  constexpr std::string_view kBom = "\xEF\xBB\xBF";
  if (text.starts_with(kBom)) text.erase(0, kBom.size());
}

}  // namespace ovo
