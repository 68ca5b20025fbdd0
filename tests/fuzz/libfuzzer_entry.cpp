// libFuzzer's entry for a program built from one target file (GRAINTWIN_FUZZ=ON).
#include <cstdio>
#include <cstdlib>

#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const graintwin::fuzz::TargetFn target = [] {
    if (graintwin::fuzz::targets().size() != 1) {
      std::fprintf(stderr, "a libFuzzer program links exactly one fuzz target\n");
      std::abort();
    }
    return graintwin::fuzz::targets().begin()->second;
  }();
  target(data, size);
  return 0;
}
