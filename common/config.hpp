// Typed, key-checked configuration: YAML files plus `--set key.path=value` overrides.
// Every read is recorded; keys present in the file that nobody read are reported by
// checkAllUsed() as unknown, with the file and line. Wrong types name the file, line, key and
// what was expected. Modules read their own options (`readXxxOptions(const Config&)`) next to
// the options' definition, with units in the field comments.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace ovo {

class Config {
 public:
  Config();  // empty: every get() returns its default
  ~Config();
  Config(const Config&);
  Config& operator=(const Config&);
  Config(Config&&) noexcept;
  Config& operator=(Config&&) noexcept;

  /// Loads a YAML file (a mapping at the top). Throws ovo::Error naming the file when it is
  /// missing or not valid YAML.
  static Config load(const std::filesystem::path& file);
  /// Parses YAML text; `source_name` stands for the file name in messages.
  static Config fromString(const std::string& yaml, const std::string& source_name = "<string>");

  /// Applies one override "a.b.c=value" (value is YAML: 3, 0.5, true, text, [1, 2, 3]).
  /// Creates the key when absent (whether it is known is decided by checkAllUsed()).
  void applyOverride(const std::string& assignment);
  void applyOverrides(const std::vector<std::string>& assignments);

  /// Merges `other` on top of this config (other's values win), e.g. a preset then a user file.
  void merge(const Config& other);

  bool has(const std::string& key) const;

  /// Reads `key` (dotted path) or returns `fallback` when absent. Supported T: bool, int,
  /// int64_t, double, std::string, std::vector<double>, std::vector<int>,
  /// std::vector<std::string>, Eigen::Matrix4d (16 numbers row-major or 4 rows of 4).
  template <typename T>
  T get(const std::string& key, const T& fallback) const;
  /// Like get() but absent is an error naming the key.
  template <typename T>
  T require(const std::string& key) const;

  /// Reads a number and checks lo <= value <= hi (error names the key and the range).
  double getInRange(const std::string& key, double fallback, double lo, double hi) const;
  int getIntInRange(const std::string& key, int fallback, int lo, int hi) const;
  std::int64_t getInt64InRange(const std::string& key, std::int64_t fallback, std::int64_t lo,
                               std::int64_t hi) const;
  /// Reads a string that must be one of `choices`.
  std::string getChoice(const std::string& key, const std::string& fallback,
                        const std::vector<std::string>& choices) const;
  /// Reads a string naming one of `names`' enum values (e.g. {{"huber", Loss::kHuber}, ...}); an
  /// absent key gives `fallback`, any other string is an error listing the names.
  template <typename E>
  E getEnum(const std::string& key, E fallback,
            const std::vector<std::pair<std::string, E>>& names) const {
    std::string fallback_name;
    std::vector<std::string> choices;
    for (const auto& [name, value] : names) {
      choices.push_back(name);
      if (value == fallback) fallback_name = name;
    }
    const std::string v = getChoice(key, fallback_name, choices);
    for (const auto& [name, value] : names)
      if (name == v) return value;
    return fallback;
  }

  /// Marks every key under `prefix` as used (for blocks read by another component).
  void markUsed(const std::string& prefix) const;
  /// Throws ovo::Error listing keys that were never read ("unknown key 'x.y' in FILE:LINE").
  void checkAllUsed() const;
  /// All leaf keys (dotted).
  std::vector<std::string> keys() const;
  /// The effective configuration as YAML text (after overrides).
  std::string dump() const;
  const std::string& source() const;
  /// Where a key's value came from, for messages: "--set key" when overridden, else "FILE:LINE"
  /// of the key (the file alone when the key is absent).
  std::string location(const std::string& key) const;

  struct Impl;  // opaque (yaml-cpp stays out of the header)

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace ovo
