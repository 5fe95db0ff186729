// Checks on a parsed YAML document that yaml-cpp leaves to the reader.
#pragma once

#include <yaml-cpp/yaml.h>

#include <string>

namespace ovo {

/// Limits of checkYamlDocument: ovo's own files nest a few levels and hold some hundred nodes.
inline constexpr int kYamlMaxDepth = 64;
inline constexpr long kYamlMaxNodes = 100000;

/// Throws ovo::Error "source:line: ..." for
/// - a document nested deeper than kYamlMaxDepth (an alias inside the node it names, `&a [*a]`,
///   is endless: every later walk over it would overflow the stack);
/// - one that expands to more than kYamlMaxNodes nodes (aliases of aliases grow tenfold a line,
///   the "billion laughs");
/// - the first mapping (at any depth) that holds a key twice: yaml-cpp keeps both entries and a
///   lookup returns the first, so a later line that was meant to change a value would be
///   silently ignored;
/// - a key that is not plain text (a list, a mapping or nothing: a YAML complex key).
/// Every YAML reader calls this right after parsing, before anything else walks the document.
void checkYamlDocument(const YAML::Node& node, const std::string& source);

}  // namespace ovo
