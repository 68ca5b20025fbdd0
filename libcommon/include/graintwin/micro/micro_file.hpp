#pragma once
// `kind=micro` files (docs/formats.md): the micro-mechanics of a series (micro/analysis.hpp) per
// grain, per increment and per state; and the grains as VTK points with D2min and eps_q for
// ParaView. Written by tracks2micro.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "graintwin/micro/analysis.hpp"

namespace graintwin::io {
class H5File;
}

namespace graintwin::micro {

/// Writes `h` as group `group` with datasets edges (units `unit`), count and density (1/unit) and
/// attributes used and outside; shared by the kind=micro and kind=forces writers.
void write_histogram(io::H5File& file, const std::string& group, const Histogram& h, const std::string& unit);

struct MicroFile {
  std::vector<std::string> state_files;  ///< what each state was read from (the shapes files)
  std::vector<std::uint32_t> label;      ///< N x T, the grain's label in each state, 0 = absent
  SeriesStates series;                   ///< positions, volumes, d50, PSDs the analysis used
  MicroResult result;
  std::string parameters_json;           ///< what the run used (free-form JSON object)
};

/// The `units`-free description of /grains/status codes, stored as its attribute `codes`.
inline constexpr const char* kStatusCodes = "0 ok, 1 too few neighbours, 2 neighbours span no volume (Y singular), 3 absent from a state";

void write_micro_file(const std::filesystem::path& path, const MicroFile& content, const std::vector<std::string>& history);

/// Grain points for ParaView: one point per grain at its position in the first state of the first
/// increment it is present in; point arrays per increment k: `d2min_k`, `eps_q_k`, `cluster_k`
/// and `defined_k` (1 where the local deformation is defined; the values are 0 elsewhere, since
/// ParaView's filters cannot take NaN). Grains present in no increment are left out.
/// What the states of a kind=micro file came from ("tracks" or "fdem_results"): the "source" of its
/// /micro/parameters JSON. DataError naming the file when that is not a JSON object with a string source.
std::string read_micro_source(const io::H5File& file);

void write_micro_vtp(const std::filesystem::path& path, const MicroFile& content);

}  // namespace graintwin::micro
