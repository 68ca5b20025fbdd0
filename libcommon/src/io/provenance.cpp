#include "graintwin/io/provenance.hpp"

#include <algorithm>

#include "graintwin/io/schema.hpp"

namespace graintwin::io {

std::vector<std::string> read_history(const H5File& file) {
  if (!file.exists(schema::path::history)) return {};
  return file.read_strings(schema::path::history);
}

void write_history(H5File& file, const std::vector<std::string>& lines) {
  file.write_strings(schema::path::history, lines);
}

void merge_history(std::vector<std::string>& lines, const std::vector<std::string>& more) {
  for (const auto& l : more)
    if (std::find(lines.begin(), lines.end(), l) == lines.end()) lines.push_back(l);
}

}  // namespace graintwin::io
