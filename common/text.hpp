// Small text helpers shared by the file readers and the report writers.
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

/// Text with &, <, >, " and ' escaped for XML and HTML (reports, SVG plots).
inline std::string xmlEscape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

}  // namespace ovo
