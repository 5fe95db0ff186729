// Helpers for the apps tests that run the built programs: their paths and a short KITTI folder
// made from the shared kitti07-first160 sequence (first n frames, symlinked).
#pragma once

#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "tests/test_support.hpp"

namespace ovo::test {

inline std::filesystem::path ovoBinaryPath() {
  const char* bin = std::getenv("OVO_BIN");
  return bin ? std::filesystem::path(bin) : std::filesystem::path(OVO_BINARY_DIR) / "ovo";
}

inline std::filesystem::path liveCameraBinaryPath() {
  return ovoBinaryPath().parent_path() / "ovo_live_camera";
}

/// A KITTI odometry folder with the first n frames of kitti07-first160 (images symlinked),
/// its calib.txt, times and ground-truth poses.
inline std::filesystem::path makeMiniKitti(const std::filesystem::path& dir, int n) {
  namespace fs = std::filesystem;
  const fs::path src = sharedData("kitti07-first160");
  fs::create_directories(dir / "image_0");
  fs::copy_file(src / "calib.txt", dir / "calib.txt", fs::copy_options::overwrite_existing);
  for (const char* name : {"times.txt", "poses_07_time_prefixed.txt"}) {
    std::ifstream in(src / name);
    std::ofstream out(dir / name);
    std::string line;
    for (int i = 0; i < n && std::getline(in, line); ++i) out << line << "\n";
  }
  for (int i = 0; i < n; ++i) {
    char name[16];
    std::snprintf(name, sizeof name, "%06d.png", i);
    fs::create_symlink(src / "image_0" / name, dir / "image_0" / name);
  }
  return dir;
}

/// Runs a shell command; stdout+stderr go to *output (through <dir>/shell_output.txt: unlike
/// tempDir(), this does not wipe the test's folder). Returns the exit code.
inline int runShell(const std::string& cmd, const std::filesystem::path& dir, std::string* output) {
  const std::filesystem::path log = dir / "shell_output.txt";
  const int status = std::system((cmd + " > '" + log.string() + "' 2>&1").c_str());
  std::ifstream in(log);
  output->assign((std::istreambuf_iterator<char>(in)), {});
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace ovo::test
