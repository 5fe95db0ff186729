// A short simulated vineyard row for the apps tests that run whole sequences (faults,
// determinism): `ovo simulate` of configs/sim/vineyard_row.yaml for the given duration. ctest runs
// each test in its own process, so the row is made once per build of `ovo` and shared: in
// <build>/test_cache/, keyed by the binary's modification time, made under a file lock (ctest -j).
#pragma once

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "tests/apps/online_test_data.hpp"

namespace ovo::test {

/// The first duration_s of configs/sim/<scenario>.yaml (vineyard_row: a straight row;
/// headland_turn: a row, then a U-turn from 9 s on).
inline std::filesystem::path simulatedRow(int duration_s,
                                          const std::string& scenario = "vineyard_row") {
  namespace fs = std::filesystem;
  const fs::path bin = ovoBinaryPath();
  const auto stamp = fs::last_write_time(bin).time_since_epoch().count();
  const fs::path cache = bin.parent_path() / "test_cache";
  const std::string name =
      scenario == "vineyard_row" ? "simulated_row_" : "simulated_" + scenario + "_";
  const fs::path row = cache / (name + std::to_string(duration_s) + "s_" + std::to_string(stamp));
  if (fs::exists(row / "done")) return row;
  fs::create_directories(cache);
  const int lock = ::open((cache / "lock").c_str(), O_CREAT | O_RDWR, 0644);
  if (lock >= 0) ::flock(lock, LOCK_EX);
  if (!fs::exists(row / "done")) {
    const fs::path tmp = row.string() + ".tmp" + std::to_string(::getpid());
    std::string output;
    const std::string cmd = "'" + bin.string() + "' simulate --config '" +
                            sourcePath("configs/sim/" + scenario + ".yaml").string() + "' --out '" +
                            tmp.string() +
                            "' --overwrite --set duration_s=" + std::to_string(duration_s);
    if (runShell(cmd, cache, &output) != 0) {
      ADD_FAILURE() << output;
    } else {
      fs::remove_all(row);
      fs::rename(tmp, row);
      std::ofstream(row / "done") << "made by " << cmd << "\n";
    }
  }
  if (lock >= 0) ::close(lock);
  return row;
}

}  // namespace ovo::test
