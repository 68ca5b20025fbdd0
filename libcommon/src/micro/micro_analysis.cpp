#include "graintwin/micro/micro_analysis.hpp"

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <cmath>
#include <map>

#include "graintwin/contacts/contacts_file.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/micro/simulation.hpp"
#include "graintwin/shape/shapes_file.hpp"

namespace graintwin::micro {

namespace fs = std::filesystem;

namespace {

void check_exists(const fs::path& p, const std::string& what) {
  std::error_code ec;
  if (!fs::exists(p, ec)) throw UsageError(what + " " + p.string() + " does not exist; check the path");
}

/// Per track present in scan t, the row of its label in `labels` (a scan's table): set(track, row).
template <class F>
void by_label(const TrackedGrains& tr, std::size_t t, const std::vector<std::uint32_t>& labels, F&& set) {
  std::map<std::uint32_t, std::size_t> row;
  for (std::size_t k = 0; k < labels.size(); ++k) row[labels[k]] = k;
  for (std::size_t i = 0; i < tr.tracks; ++i) {
    const std::uint32_t l = tr.label[i * tr.scans + t];
    if (l == 0) continue;
    const auto it = row.find(l);
    if (it != row.end()) set(i, it->second);
  }
}

}  // namespace

const char* state_noun(const std::string& source_kind) { return source_kind == schema::kind::fdem_results ? "frame" : "scan"; }

MicroFile tracked_states(const TrackedGrains& tr, const std::string& tracks_name, const std::vector<fs::path>& shapes_override,
                         const std::vector<fs::path>& contacts, const std::function<void(const io::H5File&)>& input_opened) {
  const auto opened = [&](const io::H5File& f) {
    if (input_opened) input_opened(f);
  };
  if (tr.scans < 2)
    throw UsageError(tracks_name + " holds a single scan; micro-mechanics needs two states, so track two scans or more with shapes2tracks");
  std::vector<fs::path> shapes_paths(tr.scan_files.begin(), tr.scan_files.end());
  if (!shapes_override.empty()) {
    if (shapes_override.size() != tr.scans)
      throw UsageError("--shapes lists " + std::to_string(shapes_override.size()) + " files but " + tracks_name + " has " +
                       std::to_string(tr.scans) + " scans; give one per scan");
    shapes_paths = shapes_override;
  }
  for (const fs::path& p : shapes_paths) {
    std::error_code ec;
    if (!fs::exists(p, ec))
      throw UsageError("the shapes file " + p.string() + " listed in " + tracks_name +
                       " does not exist; run from the directory shapes2tracks ran in, or pass --shapes");
  }
  if (!contacts.empty() && contacts.size() != tr.scans)
    throw UsageError("--contacts lists " + std::to_string(contacts.size()) + " files but " + tracks_name + " has " +
                     std::to_string(tr.scans) + " scans; give one per scan");
  for (const fs::path& p : contacts) check_exists(p, "contacts file");

  MicroFile content;
  SeriesStates& s = content.series;
  s.grains = tr.tracks, s.states = tr.scans, s.d50 = tr.scan_d50;
  s.position.resize(tr.tracks * tr.scans);
  for (std::size_t c = 0; c < s.position.size(); ++c)
    s.position[c] = Eigen::Vector3d(tr.centroid[3 * c], tr.centroid[3 * c + 1], tr.centroid[3 * c + 2]);
  s.volume.assign(s.position.size(), std::nan(""));
  for (std::size_t t = 0; t < tr.scans; ++t) {
    opened(io::open_kind(shapes_paths[t], schema::kind::shapes, "pass the labels2shapes output of that scan"));
    const shape::ShapesFile sh = shape::read_shapes_file(shapes_paths[t]);
    std::vector<std::uint32_t> labels;
    for (const auto& g : sh.grains) labels.push_back(g.label);
    std::size_t found = 0;
    by_label(tr, t, labels, [&](std::size_t i, std::size_t k) { s.volume[i * s.states + t] = sh.grains[k].volume, ++found; });
    std::size_t present = 0;
    for (std::size_t i = 0; i < tr.tracks; ++i) present += tr.label[i * tr.scans + t] != 0;
    if (found != present)
      throw DataError(shapes_paths[t].string() + " lacks " + std::to_string(present - found) + " grains the tracks name in scan " +
                      std::to_string(t) + "; pass the shapes files the tracks were made from (--shapes)");
    s.psd.push_back(sh.psd);
    content.state_files.push_back(shapes_paths[t].string());
  }
  if (!contacts.empty()) {
    s.coordination.resize(tr.scans);
    for (std::size_t t = 0; t < tr.scans; ++t) {
      opened(io::open_kind(contacts[t], schema::kind::contacts, "pass the labels2contacts output of that scan"));
      // Only the grains' coordination is used, but the reader refuses a file whose tables disagree (a damaged file).
      const contacts::ContactsFile cf = contacts::read_contacts_file(contacts[t]);
      const auto& z = cf.coordination.per_grain;
      s.coordination[t].assign(tr.tracks, 0);
      by_label(tr, t, cf.grain_label, [&](std::size_t i, std::size_t k) { s.coordination[t][i] = z[k]; });
    }
  }
  content.label = tr.label;
  return content;
}

MicroFile simulated_states(const fs::path& results) {
  const SimulationGrains grains = read_simulation_grains(results);
  MicroFile content;
  content.series = simulation_states(results, grains, nullptr);
  const std::size_t t = content.series.states;
  if (t < 2) throw UsageError(results.string() + " holds a single frame; micro-mechanics needs two states, so save more frames with fdemrun");
  for (std::size_t k = 0; k < t; ++k)
    content.state_files.push_back(results.string() + ":" + schema::fdem_results::frames + "/" + std::to_string(k));
  content.label.resize(grains.label.size() * t);
  for (std::size_t i = 0; i < grains.label.size(); ++i)
    for (std::size_t k = 0; k < t; ++k) content.label[i * t + k] = grains.label[i];
  return content;
}

void analyse_states(MicroFile& content, const std::string& input, const std::string& source_kind, long long from, long long to,
                    const MicroOptions& o, const std::function<std::function<void(double)>(const std::string&)>& progress) {
  const SeriesStates& s = content.series;
  const std::string state = state_noun(source_kind);
  if (to >= static_cast<long long>(s.states) || from >= static_cast<long long>(s.states))
    throw UsageError("--from/--to must name " + state + "s 0.." + std::to_string(s.states - 1) + " of " + input);
  const auto increments = from >= 0 ? std::vector<std::pair<std::size_t, std::size_t>>{{std::size_t(from), std::size_t(to)}}
                                    : consecutive_increments(s.states);
  spdlog::info("{} grains over {} {}s (d50 {:.4g} mm in {} 0), {} increment(s)", s.grains, s.states, state, s.d50[0] * 1e3, state,
               increments.size());
  content.result = analyse_series(s, increments, o, progress ? progress("micro-mechanics") : std::function<void(double)>());
  const nlohmann::json p = {{"source", source_kind},
                            {"increments", increments},
                            {"radius_d50", o.radius_d50},
                            {"min_neighbours", o.min_neighbours},
                            {"top_fraction", o.clusters.top_fraction},
                            {"contact_factor", o.contact_factor},
                            {"cluster_links", "contact distance"},
                            {"coordination", s.coordination.empty() ? "distance" : "contacts"},
                            {"min_tail", o.clusters.min_tail},
                            {"pdf_bins_per_decade", o.pdf_per_decade},
                            {"rdf_max_d50", o.rdf_max_d50},
                            {"rdf_bins", o.rdf_bins},
                            {"region", region_kind_name(o.region)},
                            {"displacement_bins", o.displacement_bins},
                            {"displacement_range_d50", o.displacement_range_d50}};
  content.parameters_json = p.dump();
}

}  // namespace graintwin::micro
