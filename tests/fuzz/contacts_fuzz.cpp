// Fuzz target: kind=contacts files as their reader gives them to report and tracks2micro
// (contacts/contacts_file.cpp), structure-aware (h5_mutator.hpp).
#include "fuzz_support.hpp"
#include "graintwin/contacts/contacts_file.hpp"
#include "h5_mutator.hpp"

GRAINTWIN_FUZZ_TARGET(contacts) {
  graintwin::fuzz::fuzz_h5_reader("read_contacts_file", graintwin::fuzz::base_file("contacts.h5"), data, size,
                                  [](const std::filesystem::path& p) { graintwin::contacts::read_contacts_file(p); });
}
