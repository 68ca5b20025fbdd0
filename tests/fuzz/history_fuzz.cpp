// Fuzz target: /provenance/history, which every tool copies from its inputs (io/provenance.cpp),
// read from a mutated volume file.
#include "fuzz_support.hpp"
#include "graintwin/io/provenance.hpp"
#include "h5_mutator.hpp"

GRAINTWIN_FUZZ_TARGET(history) {
  graintwin::fuzz::fuzz_h5_reader("read_history", graintwin::fuzz::base_file("volume.h5"), data, size,
                                  [](const std::filesystem::path& p) {
                                    graintwin::io::read_history(graintwin::io::H5File::open(p));
                                  });
}
