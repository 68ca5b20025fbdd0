// Fuzz target: kind=labels files (segment/labels_file.cpp), structure-aware (h5_mutator.hpp).
#include "fuzz_support.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "h5_mutator.hpp"

GRAINTWIN_FUZZ_TARGET(labels) {
  graintwin::fuzz::fuzz_h5_reader("labels readers", graintwin::fuzz::base_file("labels.h5"), data, size,
                                  [](const std::filesystem::path& p) {
                                    graintwin::segment::read_void_ratio(p);
                                    graintwin::segment::read_labels_file(p);
                                  });
}
