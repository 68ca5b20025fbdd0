#include "graintwin/track/tracks_file.hpp"

#include <algorithm>
#include <cmath>

#include "graintwin/core/error.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/table_checks.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/io/vtk.hpp"

namespace graintwin::track {
namespace st = schema::tracks;
using io::units;

namespace {

/// Per-step figures, one column each under /steps (entry t: the step into scan t).
struct StepColumn {
  const char* path;
  const char* unit;  ///< nullptr: an integer count
  std::uint64_t (*count)(const Tracks&, std::size_t t);
  double (*value)(const Tracks&, std::size_t t);
};

double diag_value(const Tracks& tr, std::size_t t, double MatchDiagnostics::*field) {
  return t == 0 ? std::nan("") : tr.diagnostics.at(t - 1).*field;
}

const StepColumn kStepColumns[] = {
    {st::step_grains, nullptr, [](const Tracks& tr, std::size_t t) -> std::uint64_t { return tr.steps[t].grains; }, nullptr},
    {st::step_matched, nullptr, [](const Tracks& tr, std::size_t t) -> std::uint64_t { return tr.steps[t].matched; }, nullptr},
    {st::step_lost, nullptr, [](const Tracks& tr, std::size_t t) -> std::uint64_t { return tr.steps[t].lost; }, nullptr},
    {st::step_found, nullptr, [](const Tracks& tr, std::size_t t) -> std::uint64_t { return tr.steps[t].found; }, nullptr},
    {st::step_started, nullptr, [](const Tracks& tr, std::size_t t) -> std::uint64_t { return tr.steps[t].started; }, nullptr},
    {st::step_mean_confidence, "1", nullptr, [](const Tracks& tr, std::size_t t) { return tr.steps[t].mean_confidence; }},
    {st::step_mean_candidates, "1", nullptr,
     [](const Tracks& tr, std::size_t t) { return diag_value(tr, t, &MatchDiagnostics::mean_candidates); }},
    {st::step_sigma_position, "m", nullptr,
     [](const Tracks& tr, std::size_t t) { return diag_value(tr, t, &MatchDiagnostics::sigma_position); }},
    {st::step_sigma_shape, "1", nullptr,
     [](const Tracks& tr, std::size_t t) { return diag_value(tr, t, &MatchDiagnostics::sigma_shape); }},
    {st::step_sigma_volume, "1", nullptr,
     [](const Tracks& tr, std::size_t t) { return diag_value(tr, t, &MatchDiagnostics::sigma_volume); }},
    {st::step_anchors, nullptr,
     [](const Tracks& tr, std::size_t t) -> std::uint64_t { return t == 0 ? 0 : tr.diagnostics.at(t - 1).anchors; }, nullptr},
    {st::step_backward_disagreements, nullptr,
     [](const Tracks& tr, std::size_t t) -> std::uint64_t { return t == 0 ? 0 : tr.diagnostics.at(t - 1).backward_disagreements; },
     nullptr},
};

}  // namespace

void write_tracks_file(const std::filesystem::path& path, const TracksFile& c, const std::vector<std::string>& history) {
  const Tracks& tr = c.tracks;
  const Kinematics& k = c.kinematics;
  const hsize_t n = tr.size(), t = tr.scans;
  if (c.scans.size() != t || c.d50.size() != t || c.scan_labels.size() != t || k.tracks != n || k.scans != t ||
      tr.steps.size() != t || tr.diagnostics.size() + 1 != t)
    throw UsageError("write_tracks_file: the scans, tracks and kinematics disagree in size");
  std::vector<std::uint32_t> label(n * t, 0);
  std::vector<double> confidence(n * t);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t s = 0; s < t; ++s) {
      const int g = tr.grain[i][s];
      if (g >= 0) label[i * t + s] = c.scan_labels[s].at(static_cast<std::size_t>(g));
      confidence[i * t + s] = tr.confidence[i][s];
    }
  io::H5File f = io::H5File::create(path);
  io::write_root_attrs(f, schema::kind::tracks);
  f.write(st::label, label.data(), {n, t});
  f.write(st::centroid, k.centroid.data(), {n, t, 3}, units("m"));
  f.write(st::displacement, k.displacement.data(), {n, t, 3}, units("m"));
  f.write(st::increment, k.increment.data(), {n, t, 3}, units("m"));
  f.write(st::rotation, k.rotation.data(), {n, t, 4}, units("1"));
  f.write(st::rotation_step, k.rotation_step.data(), {n, t, 4}, units("1"));
  f.write(st::rotation_defined, k.rotation_defined.data(), {n, t});
  f.write(st::rotation_misfit, k.rotation_misfit.data(), {n, t}, units("1"));
  f.write(st::confidence, confidence.data(), {n, t}, units("1"));
  f.write_strings(st::parameters, {c.parameters_json});
  for (const StepColumn& col : kStepColumns) {
    if (col.count) {
      std::vector<std::uint64_t> v(t);
      for (std::size_t s = 0; s < t; ++s) v[s] = col.count(tr, s);
      f.write(col.path, v);
    } else {
      std::vector<double> v(t);
      for (std::size_t s = 0; s < t; ++s) v[s] = col.value(tr, s);
      f.write(col.path, v, col.unit ? units(col.unit) : io::DatasetOptions{});
    }
  }
  f.write_strings(st::scan_file, c.scans);
  f.write(st::scan_d50, c.d50, units("m"));
  io::write_history(f, history);
}

TracksTable read_tracks_file(const std::filesystem::path& path) {
  const io::H5File f = io::open_kind(path, schema::kind::tracks, "pass the output of shapes2tracks");
  TracksTable r;
  std::vector<hsize_t> dims;
  r.label = f.read<std::uint32_t>(st::label, &dims);
  if (dims.size() != 2) throw DataError(path.string() + ": " + st::label + " is not a 2-D table; rewrite it with shapes2tracks");
  r.tracks = dims[0], r.scans = dims[1];
  const std::size_t cells = r.tracks * r.scans;
  const auto need = [&](const char* name, std::size_t per) {
    auto v = f.read<double>(name);
    if (v.size() != cells * per)
      throw DataError(path.string() + ": " + name + " does not match " + st::label + "; rewrite it with shapes2tracks");
    return v;
  };
  r.centroid = need(st::centroid, 3);
  r.displacement = need(st::displacement, 3);
  r.increment = need(st::increment, 3);
  r.rotation = need(st::rotation, 4);
  r.rotation_step = need(st::rotation_step, 4);
  r.confidence = need(st::confidence, 1);
  r.rotation_defined = f.read<std::uint8_t>(st::rotation_defined);
  // NaN is a track's "not in this scan"; infinity is no value any tool writes.
  io::require_finite_table(f, st::group, {}, "rewrite it with shapes2tracks");
  for (auto [out, column] : {std::pair{&r.grains, st::step_grains}, {&r.matched, st::step_matched}, {&r.lost, st::step_lost},
                             {&r.found, st::step_found}, {&r.started, st::step_started}}) {
    *out = f.read<std::uint64_t>(column);
    if (out->size() != r.scans) throw DataError(path.string() + ": " + column + " does not have one entry per scan");
  }
  r.scan_files = f.read_strings(st::scan_file);
  r.scan_d50 = f.read<double>(st::scan_d50);
  if (r.scan_d50.size() != r.scans)
    throw DataError(path.string() + ": " + st::scan_d50 + " does not have one entry per scan; rewrite it with shapes2tracks");
  r.parameters_json = f.read_string(st::parameters);
  if (r.rotation_defined.size() != cells || r.scan_files.size() != r.scans)
    throw DataError(path.string() + " has tables of different sizes; rewrite it with shapes2tracks");
  // A grain is in at most one track per scan: readers look tracks up by (scan, label).
  for (std::size_t t = 0; t < r.scans; ++t) {
    std::vector<std::uint32_t> present;
    for (std::size_t i = 0; i < r.tracks; ++i)
      if (r.label[i * r.scans + t] != 0) present.push_back(r.label[i * r.scans + t]);
    std::sort(present.begin(), present.end());
    if (const auto twice = std::adjacent_find(present.begin(), present.end()); twice != present.end())
      throw DataError(path.string() + ": grain " + std::to_string(*twice) + " of scan " + std::to_string(t) +
                      " is in two tracks; rewrite it with shapes2tracks");
  }
  return r;
}

std::set<std::uint32_t> labels_tracked_throughout(const TracksTable& t) {
  std::set<std::uint32_t> out;
  for (std::size_t i = 0; i < t.tracks; ++i)
    if (t.label[i * t.scans] > 0 && t.label[i * t.scans + t.scans - 1] > 0) out.insert(t.label[i * t.scans]);
  return out;
}

void check_tracks_tables(const io::H5File& f) {
  const std::string fix = "rewrite it with shapes2tracks";
  for (const char* g : {st::group, st::steps, st::scans}) io::table_rows(f, g, fix);
  io::require_finite_table(f, st::group, {}, fix);
}

TrackedCentroids read_tracked_centroids(const std::filesystem::path& path) {
  const io::H5File f = io::open_kind(path, schema::kind::tracks, "pass the output of shapes2tracks");
  TrackedCentroids c;
  std::vector<hsize_t> dims;
  c.centroid = f.read<double>(st::centroid, &dims);
  if (dims.size() != 3 || dims[2] != 3)
    throw DataError(path.string() + ": " + st::centroid + " is not N x T x 3; rewrite it with shapes2tracks");
  c.tracks = dims[0], c.scans = dims[1];
  return c;
}

void write_tracks_vtp(const std::filesystem::path& path, const TracksFile& c) {
  const Tracks& tr = c.tracks;
  const Kinematics& k = c.kinematics;
  const std::size_t n = tr.size(), t = tr.scans;
  io::VtkPolyData d;
  std::vector<double> id(n), first_scan(n);
  for (std::size_t i = 0; i < n; ++i) {
    std::size_t s0 = 0;
    while (tr.grain[i][s0] < 0) ++s0;  // every track has a first scan
    first_scan[i] = static_cast<double>(s0);
    id[i] = static_cast<double>(i);
    for (int q = 0; q < 3; ++q) d.points.push_back(k.centroid[3 * (i * t + s0) + static_cast<std::size_t>(q)]);
  }
  d.add_vertices(0, n);
  d.point_data.push_back({"track", 1, std::move(id)});
  d.point_data.push_back({"first_scan", 1, std::move(first_scan)});
  for (std::size_t s = 1; s < t; ++s) {
    io::VtkArray disp{"displacement_" + std::to_string(s), 3, {}}, inc{"increment_" + std::to_string(s), 3, {}};
    io::VtkArray conf{"confidence_" + std::to_string(s), 1, {}}, tracked{"tracked_" + std::to_string(s), 1, {}};
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t cell = i * t + s;
      const bool present = tr.grain[i][s] >= 0;
      for (int q = 0; q < 3; ++q) {
        const double dv = k.displacement[3 * cell + static_cast<std::size_t>(q)];
        const double iv = k.increment[3 * cell + static_cast<std::size_t>(q)];
        disp.values.push_back(std::isfinite(dv) ? dv : 0.0);
        inc.values.push_back(std::isfinite(iv) ? iv : 0.0);
      }
      conf.values.push_back(present && std::isfinite(tr.confidence[i][s]) ? tr.confidence[i][s] : 0.0);
      tracked.values.push_back(present ? 1.0 : 0.0);
    }
    for (auto* a : {&disp, &inc, &conf, &tracked}) d.point_data.push_back(std::move(*a));
  }
  io::write_vtp(path, d);
}

}  // namespace graintwin::track
