#pragma once
// `kind=micro` files (docs/formats.md): the micro-mechanics of a series (micro/analysis.hpp) per
// grain, per increment and per state; and the grains as VTK points with D2min and eps_q for
// ParaView. Written by tracks2micro.
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "graintwin/micro/analysis.hpp"
#include "graintwin/micro/distributions.hpp"
#include "graintwin/micro/simulation.hpp"
#include "graintwin/shape/grain_measure.hpp"

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
void write_micro_vtp(const std::filesystem::path& path, const MicroFile& content);

/// What the states of a kind=micro file came from ("tracks" or "fdem_results"): the "source" of its
/// /micro/parameters JSON. DataError naming the file when that is not a JSON object with a string source.
std::string read_micro_source(const io::H5File& file);

/// The histogram written by write_histogram under `group` of an open file. DataError naming the
/// file and the group when its counts, densities and edges do not agree in length.
Histogram read_histogram(const io::H5File& file, const std::string& group);

/// The tables of one state of a kind=micro file.
struct MicroStateTables {
  std::vector<double> rdf_r, rdf_g;        ///< m, 1
  std::vector<std::uint64_t> coordination;  ///< grains with Z = index
  double coordination_mean = 0.0;
  shape::SizeDistribution psd;              ///< empty when the file holds none
};
/// The tables of one increment of a kind=micro file.
struct MicroIncrementTables {
  std::size_t from = 0, to = 0;
  double d50 = 0.0;  ///< m
  Histogram pdf_d2min, pdf_eps_q;
  Histogram displacement[4];  ///< x, y, z, magnitude, over d50
  std::vector<double> cluster_size, cluster_rg;  ///< s, R_g (m)
  std::size_t selected = 0;
  bool size_fit_valid = false;
  double size_alpha = 0.0, size_alpha_error = 0.0, size_s_min = 0.0;
  std::size_t size_tail = 0;
  double fractal_dimension = 0.0, fractal_dimension_error = 0.0;
};
/// The per-state and per-increment tables of a kind=micro file and the grains' labels, D2min, eps_q
/// and clusters.
struct MicroTables {
  std::string source;  ///< "tracks" or "fdem_results" (its /micro/parameters)
  std::vector<double> state_d50;  ///< T, m
  std::vector<MicroStateTables> states;          ///< T
  std::vector<MicroIncrementTables> increments;  ///< K
  std::size_t grains = 0;                        ///< N
  std::vector<std::uint32_t> grain_label;        ///< N x T, 0 = absent
  std::vector<double> grain_d2min;               ///< N x K, D2min / d50^2
  std::vector<double> grain_eps_q;               ///< N x K
  std::vector<std::int32_t> grain_cluster;       ///< N x K, cluster id, -1 = not among the top-fraction D2min grains
  std::string parameters_json;                   ///< /micro/parameters: every option the run used
};

/// The checks read_micro_tables makes on the tables of an open kind=micro file (io/table_checks):
/// /grains, /increments and /states columns agree in length, only d50 is never NaN, no infinity.
void check_micro_tables(const io::H5File& file);

/// Reads the tables of a kind=micro file. UsageError when it is not one; DataError naming the
/// file when its tables disagree in length or hold values tracks2micro never writes.
MicroTables read_micro_tables(const std::filesystem::path& path);

/// D2min / d50^2 of the increment `from` -> `to` of `micro` (made by tracks2micro from simulation
/// frames; `name` is its file) for each grain of `grains` (its row order), looked up by label in
/// state `from`; NaN where undefined. UsageError naming --micro and the fix when the file was made
/// from tracks, has no such increment, or lacks some of the grains.
std::vector<double> d2min_of_increment(const MicroTables& micro, const std::string& name, const SimulationGrains& grains,
                                       std::size_t from, std::size_t to);

/// D2min / d50^2 of each track of `micro` (read from the file `name`) over its increment
/// `increment`, keyed by the track's label in state `state` (e.g. the scan a twin was meshed from);
/// tracks absent from that state or whose D2min is undefined are left out. UsageError naming the
/// file and what it holds when it has no such state or increment (fdemrun's [model.deformable]
/// d2min rule, fdem::D2minByLabel).
std::map<std::uint32_t, double> d2min_by_label(const MicroTables& micro, const std::string& name, std::size_t state,
                                               std::size_t increment);

}  // namespace graintwin::micro
