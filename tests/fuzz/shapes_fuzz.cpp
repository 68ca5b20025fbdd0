// Fuzz target: kind=shapes files (shape/shapes_file.cpp), structure-aware (h5_mutator.hpp).
#include "fuzz_support.hpp"
#include "graintwin/shape/shapes_file.hpp"
#include "h5_mutator.hpp"

GRAINTWIN_FUZZ_TARGET(shapes) {
  graintwin::fuzz::fuzz_h5_reader("read_shapes_file", graintwin::fuzz::base_file("shapes.h5"), data, size,
                                  [](const std::filesystem::path& p) { graintwin::shape::read_shapes_file(p); });
}
