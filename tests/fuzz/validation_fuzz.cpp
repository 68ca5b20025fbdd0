// Fuzz target: validation.json (validate/validation_file.cpp) as the report reads it, byte level JSON.
#include "fuzz_support.hpp"
#include "graintwin/validate/validation_file.hpp"

GRAINTWIN_FUZZ_TARGET(validation) {
  const auto path = graintwin::fuzz::write_scratch("validation.json", data, size);
  graintwin::fuzz::expect_clean("read_validation", [&] { graintwin::validate::read_validation(path); });
}
