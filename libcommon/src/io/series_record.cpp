#include "graintwin/io/series_record.hpp"

#include <nlohmann/json.hpp>

#include <fstream>

#include "graintwin/core/error.hpp"
#include "graintwin/io/schema.hpp"

namespace graintwin::io {

std::vector<double> read_series_axial_strains(const std::filesystem::path& path) {
  namespace sr = schema::series_record;
  std::ifstream in(path);
  if (!in) throw UsageError("cannot read " + path.string() + "; check the path");
  const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  if (j.is_discarded() || !j.is_object() || !j.contains(sr::scans) || !j[sr::scans].is_array())
    throw UsageError(path.string() + " is not a JSON object with a \"" + sr::scans + "\" array; pass a " + sr::file_name +
                     " as ctsynth writes it");
  std::vector<double> strains;
  for (const nlohmann::json& scan : j[sr::scans]) {
    if (!scan.is_object() || !scan.contains(sr::axial_strain) || !scan[sr::axial_strain].is_number())
      throw UsageError(path.string() + ": every entry of \"" + sr::scans + "\" needs a number \"" + sr::axial_strain + "\"");
    strains.push_back(scan[sr::axial_strain].get<double>());
  }
  return strains;
}

}  // namespace graintwin::io
