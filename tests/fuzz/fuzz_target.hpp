// One libFuzzer target per reader of outside data (tests/fuzz/targets/*.cpp). A target is
// written once with OVO_FUZZ_TARGET(name) and built two ways: as its own libFuzzer program
// fuzz_<name> (OVO_FUZZ=ON, clang; fuzz_main.cpp's LLVMFuzzerTestOneInput calls the target
// OVO_FUZZ_NAME names) and into the normal test suite, where fuzz_regression_test.cpp runs the
// seeds and every input a fuzzer found (tests/fuzz/regressions/<name>/) through the same function.
// An ovo::Error is the expected answer to bad input; anything else escaping (another exception, a
// crash, a sanitizer report, a hang) is a finding.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <span>
#include <string>

namespace ovo::fuzz {

using Bytes = std::span<const std::uint8_t>;
using TargetFn = void (*)(Bytes);

/// name -> function of every target linked into the program.
std::map<std::string, TargetFn>& registry();
bool registerTarget(const char* name, TargetFn fn);

/// A scratch folder of this process (under $TMPDIR, removed at exit).
const std::filesystem::path& scratchDir();
/// Writes `data` to scratchDir()/name and returns the path.
std::filesystem::path writeScratch(const std::string& name, Bytes data);
std::filesystem::path writeScratch(const std::string& name, const std::string& text);

/// Runs f(), swallowing the ovo::Error that bad input must give.
void expectOnlyOvoErrors(const std::function<void()>& f);

}  // namespace ovo::fuzz

/// Defines and registers the target `name`: OVO_FUZZ_TARGET(ocam_calib) { ... `input` ... }
#define OVO_FUZZ_TARGET(name)                                     \
  static void ovoFuzz_##name(::ovo::fuzz::Bytes input);           \
  [[maybe_unused]] static const bool ovo_fuzz_registered_##name = \
      ::ovo::fuzz::registerTarget(#name, &ovoFuzz_##name);        \
  static void ovoFuzz_##name(::ovo::fuzz::Bytes input)
