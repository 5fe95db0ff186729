// The `ovo` command: dispatches to the registered subcommands (apps/cmd_*.cpp).
#include <spdlog/spdlog.h>

#include <algorithm>
#include <exception>
#include <iostream>
#include <map>

#include "apps/command.hpp"
#include "common/error.hpp"

namespace ovo::app {

std::vector<CommandEntry>& commandRegistry() {
  static std::vector<CommandEntry> registry;
  return registry;
}

bool registerCommand(std::string name, std::string description, CommandSetup setup) {
  commandRegistry().push_back({std::move(name), std::move(description), std::move(setup)});
  return true;
}

}  // namespace ovo::app

int main(int argc, char** argv) {
  using namespace ovo::app;
  CLI::App app{"ovo: fisheye + gyro + planar LiDAR odometry for ground robots"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "ovo 0.1.0");
  bool verbose = false;
  app.add_flag("-v,--verbose", verbose, "Debug logging");

  auto& registry = commandRegistry();
  std::sort(registry.begin(), registry.end(),
            [](const auto& a, const auto& b) { return a.name < b.name; });
  std::map<CLI::App*, CommandRunner> runners;
  for (const auto& entry : registry) {
    CLI::App* sub = app.add_subcommand(entry.name, entry.description);
    runners[sub] = entry.setup(*sub);
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  spdlog::set_level(verbose ? spdlog::level::debug : spdlog::level::info);
  spdlog::set_pattern("[%^%l%$] %v");

  try {
    for (const auto& [sub, run] : runners)
      if (sub->parsed()) return run();
  } catch (const ovo::Error& e) {
    std::cerr << "ovo: error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "ovo: internal error: " << e.what() << "\n";
    return 3;
  }
  return 1;
}
