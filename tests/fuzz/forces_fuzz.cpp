// Fuzz target: kind=forces files as their reader gives them to report (micro/forces_file.cpp),
// structure-aware.
#include "fuzz_support.hpp"
#include "graintwin/micro/forces_file.hpp"
#include "h5_mutator.hpp"

GRAINTWIN_FUZZ_TARGET(forces) {
  graintwin::fuzz::fuzz_h5_reader("read_forces_tables", graintwin::fuzz::base_file("forces.h5"), data, size,
                                  [](const std::filesystem::path& p) { graintwin::micro::read_forces_tables(p); });
}
