#include "common/yaml_keys.hpp"

#include <unordered_map>

#include "common/error.hpp"

namespace ovo {

void rejectDuplicateKeys(const YAML::Node& node, const std::string& source) {
  if (node.IsSequence()) {
    for (const auto& item : node) rejectDuplicateKeys(item, source);
    return;
  }
  if (!node.IsMap()) return;
  std::unordered_map<std::string, int> first_line;
  for (const auto& kv : node) {
    if (kv.first.IsScalar()) {
      const int line = kv.first.Mark().line + 1;
      const auto [it, fresh] = first_line.emplace(kv.first.Scalar(), line);
      if (!fresh)
        failAt(source, line, "key '{}' given twice (first on line {}); remove one", it->first,
               it->second);
    }
    rejectDuplicateKeys(kv.second, source);
  }
}

}  // namespace ovo
