// The fuzz targets in the normal suite: every seed (tests/fuzz/seeds/<target>/) and every input
// a fuzzer found a problem with (tests/fuzz/regressions/<target>/, each fixed since) goes through
// its target: bad input must end in an ovo::Error, never a crash, another exception or (under
// scripts/check.sh sanitize) a sanitizer report.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <vector>

#include "tests/fuzz/fuzz_target.hpp"
#include "tests/test_support.hpp"

namespace ovo::fuzz {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> targetNames() {
  std::vector<std::string> names;
  for (const auto& [name, fn] : registry()) names.push_back(name);
  return names;
}

std::vector<fs::path> inputsOf(const std::string& kind, const std::string& name) {
  std::vector<fs::path> files;
  const fs::path dir = test::sourcePath("tests/fuzz/" + kind + "/" + name);
  if (fs::is_directory(dir))
    for (const auto& e : fs::directory_iterator(dir))
      if (e.is_regular_file()) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return files;
}

class FuzzRegression : public ::testing::TestWithParam<std::string> {};

TEST_P(FuzzRegression, SeedsAndFoundInputsGiveOnlyOvoErrors) {
  const TargetFn target = registry().at(GetParam());
  const auto seeds = inputsOf("seeds", GetParam());
  EXPECT_FALSE(seeds.empty()) << "no seed for target " << GetParam();
  auto found = inputsOf("regressions", GetParam());
  std::vector<fs::path> inputs = seeds;
  inputs.insert(inputs.end(), found.begin(), found.end());
  for (const fs::path& file : inputs) {
    SCOPED_TRACE(file.string());
    std::ifstream in(file, std::ios::binary);
    const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), {});
    EXPECT_NO_THROW(target(Bytes(bytes.data(), bytes.size())));
  }
}

INSTANTIATE_TEST_SUITE_P(Targets, FuzzRegression, ::testing::ValuesIn(targetNames()),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace ovo::fuzz
