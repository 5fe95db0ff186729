#include "apps/run_budget.hpp"

#include <map>

#include "common/error.hpp"

namespace ovo::app {
namespace {

// "low": the frontend detects and matches on the 2x2-averaged image (a quarter of the pixels, a
// quarter of the features) and the window solves with fewer iterations.
const std::map<std::string, std::vector<std::pair<std::string, std::string>>>& presets() {
  static const std::map<std::string, std::vector<std::pair<std::string, std::string>>> p = {
      {"full", {}},
      {"low", {{"frontend.half_resolution", "true"}, {"window.max_iterations", "2"}}},
  };
  return p;
}

}  // namespace

const std::vector<std::string>& budgetNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const auto& [name, keys] : presets()) n.push_back(name);
    return n;
  }();
  return names;
}

const std::vector<std::pair<std::string, std::string>>& budgetKeys(const std::string& name) {
  const auto it = presets().find(name);
  if (it == presets().end()) {
    std::string known;
    for (const auto& n : budgetNames()) known += (known.empty() ? "" : ", ") + n;
    fail("budget '{}': unknown compute preset (known: {})", name, known);
  }
  return it->second;
}

void applyBudget(Config& config, const std::string& name, const std::string& estimator) {
  for (const auto& [key, value] : budgetKeys(name)) {
    const std::string section = key.substr(0, key.find('.'));
    const bool read = section == "frontend" || section == "ransac" || section == estimator;
    if (read && !config.has(key)) config.applyOverride(key + "=" + value);
  }
}

}  // namespace ovo::app
