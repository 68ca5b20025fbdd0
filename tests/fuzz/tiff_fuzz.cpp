// Fuzz target: TIFF stacks and slices (io/tiff.cpp), byte level.
#include "fuzz_support.hpp"
#include "graintwin/io/tiff.hpp"

GRAINTWIN_FUZZ_TARGET(tiff) {
  const auto path = graintwin::fuzz::write_scratch("input.tif", data, size);
  graintwin::fuzz::expect_clean("read_tiff", [&] { graintwin::fuzz::check_volume("read_tiff", graintwin::io::read_tiff(path)); });
}
