#include "graintwin/report/clusters_3d.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <unordered_map>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/results_file.hpp"
#include "graintwin/micro/simulation.hpp"
#include "graintwin/report/sections.hpp"
#include "graintwin/shape/shapes_file.hpp"
#include "graintwin/track/tracks_file.hpp"

namespace graintwin::report {

std::array<double, 6> sphere_bounds(const std::vector<double>& centre, const std::vector<double>& radius, std::array<double, 6> b) {
  for (std::size_t i = 0; i < radius.size(); ++i)
    for (int a = 0; a < 3; ++a) {
      b[2 * a] = std::min(b[2 * a], centre[3 * i + a] - radius[i]);
      b[2 * a + 1] = std::max(b[2 * a + 1], centre[3 * i + a] + radius[i]);
    }
  return b;
}

namespace {

double equivalent_radius(double volume) { return 0.5 * std::cbrt(6.0 * volume / std::numbers::pi); }

/// Each grain (row) of a micro file's increment k: its value and whether it belongs to a cluster.
void paint(GrainsView& v, const MicroData& m, std::size_t n, std::size_t k) {
  v.value.push_back(m.grain_d2min[n * m.increments.size() + k]);
  v.highlighted.push_back(m.grain_cluster[n * m.increments.size() + k] >= 0 ? 1 : 0);
}

GrainsView experiment_view(const RunFiles& files, const MicroData& m, const track::TrackedCentroids& tracks, std::size_t k) {
  const std::size_t t = m.increments[k].from, states = m.states.size();
  std::unordered_map<std::uint32_t, double> diameter;
  if (!files.shapes[t].empty())
    for (const shape::GrainShape& g : shape::read_shapes_file(files.shapes[t]).grains) diameter[g.label] = g.equivalent_diameter;
  GrainsView v;
  for (std::size_t n = 0; n < m.grains; ++n) {
    const std::uint32_t label = m.grain_label[n * states + t];
    const double* c = &tracks.centroid[3 * (n * tracks.scans + t)];
    if (label == 0 || !std::isfinite(c[0])) continue;
    v.centre.insert(v.centre.end(), {c[0], c[1], c[2]});
    const auto it = diameter.find(label);
    v.radius.push_back(0.5 * (it != diameter.end() ? it->second : m.increments[k].d50));
    paint(v, m, n, k);
  }
  return v;
}

GrainsView simulation_view(const RunFiles& files, const MicroData& m, const micro::SimulationGrains& grains, std::size_t k) {
  const std::size_t frame = m.increments[k].from;
  const fdem::ResultsFrame f = fdem::read_results_frame(files.simulation, frame);
  const std::vector<Eigen::Vector3d> centroid = micro::frame_centroids(f, grains, files.simulation, frame);
  if (m.grains != centroid.size())
    throw DataError(files.simulation_micro.string() + " holds " + std::to_string(m.grains) + " grains but " + files.simulation.string() +
                    " " + std::to_string(centroid.size()) + "; rerun tracks2micro on this simulation");
  GrainsView v;
  for (std::size_t n = 0; n < m.grains; ++n) {
    v.centre.insert(v.centre.end(), {centroid[n].x(), centroid[n].y(), centroid[n].z()});
    v.radius.push_back(equivalent_radius(grains.volume[n]));
    paint(v, m, n, k);
  }
  v.membrane = f.membrane_position;
  return v;
}

}  // namespace

std::vector<Panel> cluster_3d_panels(const RunFiles& files, const ExperimentData& e, const SimulationData& s, const PanelOptions& options) {
  const char* description =
      "D2min of every grain at the increment's first state (micro.h5 for the scans, simulation_micro.h5 for the twin), each grain "
      "a sphere of its volume-equivalent diameter at its centroid: the members of the high-D2min clusters (tracks2micro's top "
      "fraction of D2min, linked by contact; /grains/cluster) opaque and painted on one logarithmic colour scale (1st to 99th "
      "percentile of the members' D2min) for both sides and every increment shown, every other grain a grey point, the twin's membrane balls pale blue points; one fixed "
      "camera along +y from 20 degrees above. Spheres, not the grains' shapes: the picture shows where the clusters are.";
  const std::size_t exp_increments = e.micro && !files.tracks.empty() ? e.micro->increments.size() : 0;
  const std::size_t sim_increments = s.present && s.micro ? s.micro->increments.size() : 0;
  std::optional<track::TrackedCentroids> tracks;
  if (exp_increments > 0) {
    tracks = track::read_tracked_centroids(files.tracks);
    if (tracks->tracks != e.micro->grains)
      throw DataError(files.micro.string() + " holds " + std::to_string(e.micro->grains) + " grains but " + files.tracks.string() + " " +
                      std::to_string(tracks->tracks) + " tracks; rerun the micro stage on these tracks");
  }
  std::optional<micro::SimulationGrains> grains;
  if (sim_increments > 0) grains = micro::read_simulation_grains(files.simulation);

  std::vector<Panel> panels;
  std::vector<GrainsView*> views;
  for (std::size_t k : pick_evenly(std::max(exp_increments, sim_increments), options.max_series)) {
    const std::string id = fmt::format("clusters_3d_{}", k);
    Panel p{id, fmt::format("D2min clusters in 3D, increment {}", k), description, {}, {}};
    if (!e.micro) p.experiment = Side{std::nullopt, kNoMicro, {}};
    else if (files.tracks.empty()) p.experiment = Side{std::nullopt, "This run has no tracks (tracks.h5): the track stage (shapes2tracks) makes the grains' positions.", {}};
    else if (k >= exp_increments) p.experiment = Side{std::nullopt, fmt::format("The scans have {} increments; this one exists in the simulation only.", exp_increments), {}};
    else {
      Chart c;
      c.kind = "grains", c.panel = id, c.file = id + "_experiment.png";
      const MicroIncrement& inc = e.micro->increments[k];
      c.title = fmt::format("{} -> {}", e.scans[inc.from].name, e.scans[inc.to].name);
      c.grains = experiment_view(files, *e.micro, *tracks, k);
      p.experiment = Side{std::move(c), {}, {}};
    }
    if (!s.present) p.simulation = Side{std::nullopt, kNoSimulation, {}};
    else if (!s.micro) p.simulation = Side{std::nullopt, kNoSimulationMicro, {}};
    else if (k >= sim_increments) p.simulation = Side{std::nullopt, fmt::format("The simulation has {} increments; this one exists in the scans only.", sim_increments), {}};
    else {
      Chart c;
      c.kind = "grains", c.panel = id, c.file = id + "_simulation.png";
      const MicroIncrement& inc = s.micro->increments[k];
      c.title = fmt::format("frame {} -> {}", inc.from, inc.to);
      c.grains = simulation_view(files, *s.micro, *grains, k);
      p.simulation = Side{std::move(c), {}, {}};
    }
    panels.push_back(std::move(p));
  }
  // One colour scale (over the painted grains, the clusters' members) and one camera box for every picture.
  std::vector<double> values;
  const double inf = std::numeric_limits<double>::infinity();
  std::array<double, 6> bounds{inf, -inf, inf, -inf, inf, -inf};
  for (Panel& p : panels)
    for (Side* side : {&p.experiment, &p.simulation})
      if (side->chart) {
        GrainsView& v = *side->chart->grains;
        for (std::size_t i = 0; i < v.value.size(); ++i)
          if (v.highlighted[i]) values.push_back(v.value[i]);
        bounds = sphere_bounds(v.centre, v.radius, bounds);
        views.push_back(&v);
      }
  const auto [lo, hi] = colour_range(values, true);
  for (GrainsView* v : views) v->quantity = "D2min / d50^2", v->colour_log = true, v->colour_min = lo, v->colour_max = hi, v->bounds = bounds;
  return panels;
}

}  // namespace graintwin::report
