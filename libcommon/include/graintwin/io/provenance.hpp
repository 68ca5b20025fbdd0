#pragma once
// Provenance: every output carries /provenance/history, one line per tool run (command line,
// version, UTC time), copied from its inputs and appended by the run that wrote it.
#include <string>
#include <vector>

#include "graintwin/io/h5file.hpp"

namespace graintwin::io {

/// Lines of /provenance/history of an open file (empty when the file has none).
std::vector<std::string> read_history(const H5File& file);
/// Writes /provenance/history (replacing it).
void write_history(H5File& file, const std::vector<std::string>& lines);
/// Appends `more` to `lines`, skipping lines already present (inputs sharing an ancestor).
void merge_history(std::vector<std::string>& lines, const std::vector<std::string>& more);

}  // namespace graintwin::io
