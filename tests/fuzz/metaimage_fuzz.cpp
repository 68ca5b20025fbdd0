// Fuzz target: MetaImage headers (io/metaimage.cpp), byte level. The input is the header (.mha
// with LOCAL data inline, or .mhd naming a data file); data.raw beside it holds 64 bytes.
#include "fuzz_support.hpp"
#include "graintwin/io/metaimage.hpp"

GRAINTWIN_FUZZ_TARGET(metaimage) {
  static const auto raw = [] {
    const std::vector<std::uint8_t> bytes(64, 7);
    return graintwin::fuzz::write_scratch("data.raw", bytes.data(), bytes.size());
  }();
  const auto path = graintwin::fuzz::write_scratch("input.mha", data, size);
  graintwin::fuzz::expect_clean("read_metaimage", [&] {
    graintwin::fuzz::check_volume("read_metaimage", graintwin::io::read_metaimage(path));
  });
}
