// Fuzz target: kind=fdem_model files (fdem/model_file.cpp), structure-aware (h5_mutator.hpp).
#include "fuzz_support.hpp"
#include "graintwin/fdem/model_file.hpp"
#include "h5_mutator.hpp"

GRAINTWIN_FUZZ_TARGET(model) {
  graintwin::fuzz::fuzz_h5_reader("read_model_file", graintwin::fuzz::base_file("model.h5"), data, size,
                                  [](const std::filesystem::path& p) { graintwin::fdem::read_model_file(p); });
}
