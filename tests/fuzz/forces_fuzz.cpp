// Fuzz target: kind=forces files as report reads them (report/run_data.cpp), structure-aware.
#include "fuzz_support.hpp"
#include "graintwin/report/run_data.hpp"
#include "h5_mutator.hpp"

GRAINTWIN_FUZZ_TARGET(forces) {
  graintwin::fuzz::fuzz_h5_reader("read_forces_data", graintwin::fuzz::base_file("forces.h5"), data, size,
                                  [](const std::filesystem::path& p) { graintwin::report::read_forces_data(p); });
}
