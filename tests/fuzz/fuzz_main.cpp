// libFuzzer's entry point for the program fuzz_<OVO_FUZZ_NAME> (tests/fuzz/CMakeLists.txt).
#include <cstdio>
#include <cstdlib>

#include "tests/fuzz/fuzz_target.hpp"

#define OVO_FUZZ_STR2(x) #x
#define OVO_FUZZ_STR(x) OVO_FUZZ_STR2(x)

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const ovo::fuzz::TargetFn target = [] {
    const auto it = ovo::fuzz::registry().find(OVO_FUZZ_STR(OVO_FUZZ_NAME));
    if (it == ovo::fuzz::registry().end()) {
      std::fprintf(stderr, "fuzz target %s is not linked in\n", OVO_FUZZ_STR(OVO_FUZZ_NAME));
      std::abort();
    }
    return it->second;
  }();
  target(ovo::fuzz::Bytes(data, size));
  return 0;
}
