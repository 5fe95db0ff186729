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
      // A list, a mapping or nothing as a key: no ovo file has one, and every reader takes keys
      // as text (yaml-cpp threw its own exception, which no message of ovo's caught).
      failAt(source, kv.first.Mark().line + 1,
             "expected a plain key (text) before ':', got {} (a YAML complex key)",
             kv.first.IsNull()  ? "nothing"
             : kv.first.IsMap() ? "a mapping"
                                : "a list");
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
