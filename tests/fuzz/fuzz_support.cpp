#include <unistd.h>

#include <cstdlib>
#include <fstream>

#include "common/error.hpp"
#include "tests/fuzz/fuzz_target.hpp"

namespace ovo::fuzz {

std::map<std::string, TargetFn>& registry() {
  static std::map<std::string, TargetFn> targets;
  return targets;
}

bool registerTarget(const char* name, TargetFn fn) {
  registry()[name] = fn;
  return true;
}

namespace {
struct Scratch {
  std::filesystem::path dir;
  Scratch() {
    dir = std::filesystem::temp_directory_path() / ("ovo_fuzz_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
  }
  ~Scratch() {
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
  }
};
}  // namespace

const std::filesystem::path& scratchDir() {
  static Scratch scratch;
  return scratch.dir;
}

std::filesystem::path writeScratch(const std::string& name, Bytes data) {
  const std::filesystem::path file = scratchDir() / name;
  std::filesystem::create_directories(file.parent_path());
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data.data()), static_cast<std::streamsize>(data.size()));
  if (!out) std::abort();  // the scratch folder itself failed: not a finding in the reader
  return file;
}

std::filesystem::path writeScratch(const std::string& name, const std::string& text) {
  return writeScratch(name, Bytes(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
}

void expectOnlyOvoErrors(const std::function<void()>& f) {
  try {
    f();
  } catch (const ovo::Error&) {
    // the answer to bad input
  }
}

}  // namespace ovo::fuzz
