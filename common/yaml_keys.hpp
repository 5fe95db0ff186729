// Checks on a parsed YAML document that yaml-cpp leaves to the reader.
#pragma once

#include <yaml-cpp/yaml.h>

#include <string>

namespace ovo {

/// Throws ovo::Error "source:line: key 'k' given twice (first on line m)" for the first mapping
/// (at any depth) that holds a key twice. yaml-cpp keeps both entries and a lookup returns the
/// first, so a later line that was meant to change a value would be silently ignored.
void rejectDuplicateKeys(const YAML::Node& node, const std::string& source);

}  // namespace ovo
