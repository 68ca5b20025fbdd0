// Fuzz target: kind=contacts files as report reads them with their scan's labels file
// (report/run_data.cpp), structure-aware (h5_mutator.hpp).
#include "fuzz_support.hpp"
#include "graintwin/report/run_data.hpp"
#include "h5_mutator.hpp"

GRAINTWIN_FUZZ_TARGET(contacts) {
  graintwin::fuzz::fuzz_h5_reader("read_experiment (contacts)", graintwin::fuzz::base_file("contacts.h5"), data, size,
                                  [](const std::filesystem::path& p) {
                                    graintwin::report::RunFiles files;
                                    files.labels = {graintwin::fuzz::base_file("labels.h5")};
                                    files.scan_names = {"scan_000"};
                                    files.contacts = {p};
                                    files.shapes = {""};
                                    graintwin::report::read_experiment(files);
                                  });
}
