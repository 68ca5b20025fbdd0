// Fuzz target: PNG slices (io/slices.cpp), byte level, read as a one-slice series.
#include "fuzz_support.hpp"
#include "graintwin/io/slices.hpp"

GRAINTWIN_FUZZ_TARGET(png) {
  const auto path = graintwin::fuzz::write_scratch("input.png", data, size);
  graintwin::fuzz::expect_clean("read_slices (png)", [&] {
    graintwin::fuzz::check_volume("read_slices (png)", graintwin::io::read_slices({path}));
  });
}
