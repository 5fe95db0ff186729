#include "common/yaml_keys.hpp"

#include <unordered_map>

#include "common/error.hpp"

namespace ovo {
namespace {

void check(const YAML::Node& node, const std::string& source, int depth, long& nodes) {
  if (++nodes > kYamlMaxNodes)
    failAt(source, node.Mark().line + 1,
           "the YAML expands to more than {} values (aliases of aliases?); expected a plain "
           "document",
           kYamlMaxNodes);
  if (depth > kYamlMaxDepth)
    failAt(source, node.Mark().line + 1,
           "the YAML nests more than {} levels deep (an alias inside the node it names?)",
           kYamlMaxDepth);
  if (node.IsSequence()) {
    for (const auto& item : node) check(item, source, depth + 1, nodes);
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
    } else {
      check(kv.first, source, depth + 1, nodes);  // a complex key can hold an alias too
    }
    check(kv.second, source, depth + 1, nodes);
  }
}

}  // namespace

void checkYamlDocument(const YAML::Node& node, const std::string& source) {
  long nodes = 0;
  check(node, source, 0, nodes);
}

}  // namespace ovo
