// Subcommands of the `ovo` tool register themselves here: one file apps/cmd_<name>.cpp per
// subcommand, holding `OVO_REGISTER_COMMAND(name, setup)` where setup adds the subcommand's options
// to a CLI::App and returns the function that runs it (returning the process exit code).
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <string>
#include <vector>

namespace ovo::app {

using CommandRunner = std::function<int()>;
using CommandSetup = std::function<CommandRunner(CLI::App& sub)>;

struct CommandEntry {
  std::string name;
  std::string description;
  CommandSetup setup;
};

std::vector<CommandEntry>& commandRegistry();
bool registerCommand(std::string name, std::string description, CommandSetup setup);

}  // namespace ovo::app

#define OVO_REGISTER_COMMAND(name, description, setup) \
  static const bool ovo_registered_##name = ::ovo::app::registerCommand(#name, description, setup)
