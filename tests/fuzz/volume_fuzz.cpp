// Fuzz target: kind=volume files (io/volume_io.cpp), structure-aware (h5_mutator.hpp).
#include "fuzz_support.hpp"
#include "graintwin/io/volume_io.hpp"
#include "h5_mutator.hpp"

GRAINTWIN_FUZZ_TARGET(volume) {
  graintwin::fuzz::fuzz_h5_reader("read_volume_file", graintwin::fuzz::base_file("volume.h5"), data, size,
                                  [](const std::filesystem::path& p) {
                                    graintwin::fuzz::check_volume("read_volume_file", graintwin::io::read_volume_file(p));
                                  });
}
