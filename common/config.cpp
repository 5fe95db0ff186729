#include "common/config.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <sstream>

#include "common/error.hpp"
#include "common/yaml_keys.hpp"

namespace ovo {

struct Config::Impl {
  YAML::Node root{YAML::NodeType::Map};
  std::string source = "<defaults>";
  std::set<std::string> overridden;    // keys set by --set (reported as such)
  mutable std::set<std::string> used;  // leaf keys or prefixes read
};

namespace {

std::vector<std::string> splitKey(const std::string& key) {
  std::vector<std::string> parts;
  std::string cur;
  for (char c : key) {
    if (c == '.') {
      parts.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  parts.push_back(cur);
  for (const auto& p : parts)
    if (p.empty()) fail("config key '{}' is malformed (empty component)", key);
  return parts;
}

// Walks without creating nodes (yaml-cpp's non-const operator[] would insert).
std::optional<YAML::Node> findNode(const YAML::Node& root, const std::string& key) {
  const YAML::Node* node = &root;
  YAML::Node holder;
  for (const auto& part : splitKey(key)) {
    if (!node->IsMap()) return std::nullopt;
    const YAML::Node child = (*static_cast<const YAML::Node*>(node))[part];
    if (!child.IsDefined() || child.IsNull()) return std::nullopt;
    holder.reset(child);
    node = &holder;
  }
  return *node;
}

// The key's own node when it is there but holds nothing ("key:" or "key: ~"); nullopt otherwise.
std::optional<YAML::Node> findNullLeaf(const YAML::Node& root, const std::string& key) {
  const std::size_t dot = key.rfind('.');
  const auto section = dot == std::string::npos ? std::optional<YAML::Node>(root)
                                                : findNode(root, key.substr(0, dot));
  if (!section || !section->IsMap()) return std::nullopt;
  const std::string name = dot == std::string::npos ? key : key.substr(dot + 1);
  for (const auto& kv : *section)  // the key's node: an empty value's mark is the next line
    if (kv.first.as<std::string>() == name && kv.second.IsNull()) return kv.first;
  return std::nullopt;
}

void collectLeaves(const YAML::Node& node, const std::string& prefix,
                   std::vector<std::string>& out) {
  if (node.IsMap()) {
    for (const auto& kv : node) {
      const std::string k = kv.first.as<std::string>();
      collectLeaves(kv.second, prefix.empty() ? k : prefix + "." + k, out);
    }
  } else {
    out.push_back(prefix);
  }
}

std::string where(const Config::Impl& impl, const std::string& key, const YAML::Node& node) {
  if (impl.overridden.count(key)) return "--set " + key;
  // "--set a.b.c=1" where a.b is a value: the section a.b was made by that --set.
  const auto below = impl.overridden.lower_bound(key + ".");
  if (below != impl.overridden.end() && below->starts_with(key + ".")) return "--set " + *below;
  const auto mark = node.Mark();
  if (mark.line >= 0) return impl.source + ":" + std::to_string(mark.line + 1);
  return impl.source;
}

template <typename T>
T scalarAs(const Config::Impl& impl, const std::string& key, const YAML::Node& node,
           const char* expected);

double asDouble(const Config::Impl& impl, const std::string& key, const YAML::Node& node) {
  if (!node.IsScalar()) fail("{}: key '{}': expected a number", where(impl, key, node), key);
  const std::string s = node.Scalar();
  double v = 0.0;
  std::size_t pos = 0;
  try {
    v = std::stod(s, &pos);
  } catch (...) {
    pos = 0;
  }
  if (pos == 0 || pos != s.size())
    fail("{}: key '{}': expected a number, got '{}'", where(impl, key, node), key, s);
  if (!std::isfinite(v))
    fail("{}: key '{}': expected a finite number, got '{}'", where(impl, key, node), key, s);
  return v;
}

long long asInt(const Config::Impl& impl, const std::string& key, const YAML::Node& node) {
  if (!node.IsScalar()) fail("{}: key '{}': expected an integer", where(impl, key, node), key);
  const std::string s = node.Scalar();
  long long v = 0;
  std::size_t pos = 0;
  try {
    v = std::stoll(s, &pos);
  } catch (...) {
    pos = 0;
  }
  if (pos == 0 || pos != s.size())
    fail("{}: key '{}': expected an integer, got '{}'", where(impl, key, node), key, s);
  return v;
}

bool asBool(const Config::Impl& impl, const std::string& key, const YAML::Node& node) {
  if (node.IsScalar()) {
    std::string s = node.Scalar();
    std::transform(s.begin(), s.end(), s.begin(), ::tolower);
    if (s == "true" || s == "yes" || s == "on" || s == "1") return true;
    if (s == "false" || s == "no" || s == "off" || s == "0") return false;
    fail("{}: key '{}': expected true or false, got '{}'", where(impl, key, node), key,
         node.Scalar());
  }
  fail("{}: key '{}': expected true or false", where(impl, key, node), key);
}

std::string asString(const Config::Impl& impl, const std::string& key, const YAML::Node& node) {
  if (!node.IsScalar()) fail("{}: key '{}': expected a text value", where(impl, key, node), key);
  return node.Scalar();
}

template <typename T, typename F>
std::vector<T> asVector(const Config::Impl& impl, const std::string& key, const YAML::Node& node,
                        F elem) {
  if (!node.IsSequence())
    fail("{}: key '{}': expected a list like [1, 2, 3]", where(impl, key, node), key);
  std::vector<T> out;
  for (const auto& item : node) out.push_back(elem(impl, key, item));
  return out;
}

}  // namespace

Config::Config() : impl_(std::make_unique<Impl>()) {}
Config::~Config() = default;
Config::Config(const Config& o) : impl_(std::make_unique<Impl>()) {
  impl_->root = YAML::Clone(o.impl_->root);
  impl_->source = o.impl_->source;
  impl_->overridden = o.impl_->overridden;
  impl_->used = o.impl_->used;
}
Config& Config::operator=(const Config& o) {
  if (this != &o) *this = Config(o);
  return *this;
}
Config::Config(Config&&) noexcept = default;
Config& Config::operator=(Config&&) noexcept = default;

Config Config::load(const std::filesystem::path& file) {
  if (!std::filesystem::exists(file)) fail("config file '{}' does not exist", file.string());
  if (std::filesystem::is_directory(file))
    fail("config file '{}' is a folder, expected a YAML file", file.string());
  std::ifstream in(file);
  if (!in) fail("config file '{}' cannot be read", file.string());
  std::stringstream ss;
  ss << in.rdbuf();
  return fromString(ss.str(), file.string());
}

Config Config::fromString(const std::string& yaml, const std::string& source_name) {
  Config c;
  c.impl_->source = source_name;
  try {
    YAML::Node root = YAML::Load(yaml);
    if (root.IsNull()) root = YAML::Node(YAML::NodeType::Map);
    if (!root.IsMap())
      fail("{}: expected a YAML mapping (key: value lines) at the top", source_name);
    checkYamlDocument(root, source_name);
    c.impl_->root = root;
  } catch (const YAML::Exception& e) {
    fail("{}:{}: invalid YAML: {}", source_name, e.mark.line + 1, e.msg);
  }
  return c;
}

void Config::applyOverride(const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) fail("--set '{}': expected key.path=value", assignment);
  const std::string key = assignment.substr(0, eq);
  const std::string value = assignment.substr(eq + 1);
  YAML::Node value_node;
  try {
    value_node = YAML::Load(value);
  } catch (const YAML::Exception& e) {
    fail("--set {}: value '{}' is not valid YAML: {}", key, value, e.msg);
  }
  checkYamlDocument(value_node, "--set " + key);
  const auto parts = splitKey(key);
  YAML::Node node = impl_->root;
  for (std::size_t i = 0; i + 1 < parts.size(); ++i) {
    YAML::Node child = node[parts[i]];
    if (!child.IsDefined() || child.IsNull()) {
      node[parts[i]] = YAML::Node(YAML::NodeType::Map);
      child = node[parts[i]];
    } else if (!child.IsMap()) {
      fail("--set {}: '{}' is a value, not a section", key, parts[i]);
    }
    node.reset(child);
  }
  node[parts.back()] = value_node;
  impl_->overridden.insert(key);
}

void Config::applyOverrides(const std::vector<std::string>& assignments) {
  for (const auto& a : assignments) applyOverride(a);
}

void Config::merge(const Config& other) {
  std::vector<std::string> leaves;
  collectLeaves(other.impl_->root, "", leaves);
  for (const auto& key : leaves) {
    if (key.empty()) continue;
    const auto node = findNode(other.impl_->root, key);
    if (!node) continue;
    const auto parts = splitKey(key);
    YAML::Node cur = impl_->root;
    for (std::size_t i = 0; i + 1 < parts.size(); ++i) {
      YAML::Node child = cur[parts[i]];
      if (!child.IsDefined() || !child.IsMap()) {
        cur[parts[i]] = YAML::Node(YAML::NodeType::Map);
        child = cur[parts[i]];
      }
      cur.reset(child);
    }
    cur[parts.back()] = YAML::Clone(*node);
  }
  for (const auto& k : other.impl_->overridden) impl_->overridden.insert(k);
  if (impl_->source == "<defaults>") impl_->source = other.impl_->source;
}

bool Config::has(const std::string& key) const { return findNode(impl_->root, key).has_value(); }

template <typename T>
T Config::get(const std::string& key, const T& fallback) const {
  impl_->used.insert(key);
  const auto node = findNode(impl_->root, key);
  const Impl& im = *impl_;
  if (!node) {
    // "key:" with nothing after it is a mistake, not a request for the built-in default.
    if (const auto empty = findNullLeaf(impl_->root, key))
      fail("{}: key '{}': no value (give one, or leave the key out for the default)",
           where(im, key, *empty), key);
    return fallback;
  }
  if constexpr (std::is_same_v<T, bool>) {
    return asBool(im, key, *node);
  } else if constexpr (std::is_same_v<T, int>) {
    const long long v = asInt(im, key, *node);
    if (v < INT32_MIN || v > INT32_MAX)
      fail("{}: key '{}': integer out of range", where(im, key, *node), key);
    return static_cast<int>(v);
  } else if constexpr (std::is_same_v<T, std::int64_t>) {
    return static_cast<std::int64_t>(asInt(im, key, *node));
  } else if constexpr (std::is_same_v<T, double>) {
    return asDouble(im, key, *node);
  } else if constexpr (std::is_same_v<T, std::string>) {
    return asString(im, key, *node);
  } else if constexpr (std::is_same_v<T, std::vector<double>>) {
    return asVector<double>(im, key, *node, asDouble);
  } else if constexpr (std::is_same_v<T, std::vector<int>>) {
    return asVector<int>(im, key, *node,
                         [](const Impl& i, const std::string& k, const YAML::Node& n) {
                           return static_cast<int>(asInt(i, k, n));
                         });
  } else if constexpr (std::is_same_v<T, std::vector<std::string>>) {
    return asVector<std::string>(im, key, *node, asString);
  } else if constexpr (std::is_same_v<T, Eigen::Matrix4d>) {
    std::vector<double> flat;
    if (node->IsSequence() && node->size() == 4 && (*node)[0].IsSequence()) {
      for (const auto& row : *node) {
        auto r = asVector<double>(im, key, row, asDouble);
        if (r.size() != 4)
          fail("{}: key '{}': expected 4 rows of 4 numbers", where(im, key, *node), key);
        flat.insert(flat.end(), r.begin(), r.end());
      }
    } else {
      flat = asVector<double>(im, key, *node, asDouble);
    }
    if (flat.size() != 16)
      fail("{}: key '{}': expected a 4x4 matrix (16 numbers, row-major), got {} numbers",
           where(im, key, *node), key, flat.size());
    Eigen::Matrix4d M;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) M(r, c) = flat[4 * r + c];
    return M;
  } else {
    static_assert(sizeof(T) == 0, "unsupported Config type");
  }
}

template <typename T>
T Config::require(const std::string& key) const {
  if (!has(key)) fail("{}: missing required key '{}'", impl_->source, key);
  if constexpr (std::is_same_v<T, Eigen::Matrix4d>) {
    return get<T>(key, Eigen::Matrix4d::Zero());
  } else {
    return get<T>(key, T{});
  }
}

#define OVO_CONFIG_INSTANTIATE(T)                                \
  template T Config::get<T>(const std::string&, const T&) const; \
  template T Config::require<T>(const std::string&) const;
OVO_CONFIG_INSTANTIATE(bool)
OVO_CONFIG_INSTANTIATE(int)
OVO_CONFIG_INSTANTIATE(std::int64_t)
OVO_CONFIG_INSTANTIATE(double)
OVO_CONFIG_INSTANTIATE(std::string)
OVO_CONFIG_INSTANTIATE(std::vector<double>)
OVO_CONFIG_INSTANTIATE(std::vector<int>)
OVO_CONFIG_INSTANTIATE(std::vector<std::string>)
OVO_CONFIG_INSTANTIATE(Eigen::Matrix4d)
#undef OVO_CONFIG_INSTANTIATE

double Config::getInRange(const std::string& key, double fallback, double lo, double hi) const {
  const double v = get<double>(key, fallback);
  if (v < lo || v > hi)
    fail("{}: key '{}': expected a number in [{}, {}], got {}", location(key), key, lo, hi, v);
  return v;
}

namespace {
template <typename T>
T integerInRange(const Config& c, const std::string& key, T fallback, T lo, T hi) {
  const T v = c.get<T>(key, fallback);
  if (v < lo || v > hi)
    fail("{}: key '{}': expected an integer in [{}, {}], got {}", c.location(key), key, lo, hi, v);
  return v;
}
}  // namespace

int Config::getIntInRange(const std::string& key, int fallback, int lo, int hi) const {
  return integerInRange(*this, key, fallback, lo, hi);
}

std::int64_t Config::getInt64InRange(const std::string& key, std::int64_t fallback, std::int64_t lo,
                                     std::int64_t hi) const {
  return integerInRange(*this, key, fallback, lo, hi);
}

std::string Config::getChoice(const std::string& key, const std::string& fallback,
                              const std::vector<std::string>& choices) const {
  const std::string v = get<std::string>(key, fallback);
  if (std::find(choices.begin(), choices.end(), v) == choices.end()) {
    std::string list;
    for (const auto& c : choices) list += (list.empty() ? "" : ", ") + c;
    fail("{}: key '{}': expected one of {}, got '{}'", location(key), key, list, v);
  }
  return v;
}

void Config::markUsed(const std::string& prefix) const { impl_->used.insert(prefix); }

void Config::checkAllUsed() const {
  std::vector<std::string> leaves;
  collectLeaves(impl_->root, "", leaves);
  std::vector<std::string> unknown;
  for (const auto& key : leaves) {
    if (key.empty()) continue;
    bool ok = false;
    for (const auto& u : impl_->used) {
      if (key == u ||
          (key.size() > u.size() && key.compare(0, u.size(), u) == 0 && key[u.size()] == '.')) {
        ok = true;
        break;
      }
    }
    if (!ok) unknown.push_back(key);
  }
  if (unknown.empty()) return;
  std::string msg;
  for (const auto& key : unknown)
    msg += fmt::format("\n  unknown key '{}' ({})", key, location(key));
  fail("{}: {} unknown configuration key(s):{}", impl_->source, unknown.size(), msg);
}

std::vector<std::string> Config::keys() const {
  std::vector<std::string> leaves;
  collectLeaves(impl_->root, "", leaves);
  return leaves;
}

std::string Config::dump() const {
  YAML::Emitter out;
  out << impl_->root;
  return out.c_str();
}

const std::string& Config::source() const { return impl_->source; }

std::string Config::location(const std::string& key) const {
  const auto node = findNode(impl_->root, key);
  return node ? where(*impl_, key, *node) : impl_->source;
}

}  // namespace ovo
