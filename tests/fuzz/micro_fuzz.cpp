// Fuzz target: kind=micro files as their reader gives them to report and fdem2forces
// (micro/micro_file.cpp), structure-aware.
#include "fuzz_support.hpp"
#include "graintwin/micro/micro_file.hpp"
#include "h5_mutator.hpp"

GRAINTWIN_FUZZ_TARGET(micro) {
  graintwin::fuzz::fuzz_h5_reader("read_micro_tables", graintwin::fuzz::base_file("micro.h5"), data, size,
                                  [](const std::filesystem::path& p) { graintwin::micro::read_micro_tables(p); });
}
