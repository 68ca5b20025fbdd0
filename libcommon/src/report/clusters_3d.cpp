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

void cut_front_quarter(GrainsView& v, const FrontQuarter& cut) {
  GrainsView kept;
  for (std::size_t i = 0; i < v.radius.size(); ++i) {
    if (cut.holds(v.centre[3 * i], v.centre[3 * i + 1])) continue;
    kept.centre.insert(kept.centre.end(), {v.centre[3 * i], v.centre[3 * i + 1], v.centre[3 * i + 2]});
    kept.radius.push_back(v.radius[i]), kept.value.push_back(v.value[i]), kept.highlighted.push_back(v.highlighted[i]);
  }
  for (std::size_t b = 0; b + 2 < v.membrane.size(); b += 3)
    if (!cut.holds(v.membrane[b], v.membrane[b + 1])) kept.membrane.insert(kept.membrane.end(), {v.membrane[b], v.membrane[b + 1], v.membrane[b + 2]});
  v.centre = std::move(kept.centre), v.radius = std::move(kept.radius), v.value = std::move(kept.value);
  v.highlighted = std::move(kept.highlighted), v.membrane = std::move(kept.membrane);
}

namespace {

double equivalent_radius(double volume) { return 0.5 * std::cbrt(6.0 * volume / std::numbers::pi); }

/// What a family of 3D grain pictures paints: the D2min clusters (their members painted, the
/// others grey points, the whole sample) or a value of every grain (all painted, a front quarter
/// cut away so the interior shows).
struct Painting {
  const char* id;
  const char* title;
  const char* description;
  const char* quantity;  ///< the colour bar's label
  std::vector<double> MicroData::*values;
  bool log;
  bool clusters_only;
};

/// Each grain (row) of a micro file's increment k: its value and whether it is painted.
void paint(GrainsView& v, const MicroData& m, std::size_t n, std::size_t k, const Painting& what) {
  v.value.push_back((m.*what.values)[n * m.increments.size() + k]);
  v.highlighted.push_back(!what.clusters_only || m.grain_cluster[n * m.increments.size() + k] >= 0 ? 1 : 0);
}

GrainsView experiment_view(const RunFiles& files, const MicroData& m, const track::TrackedCentroids& tracks, std::size_t k,
                           const Painting& what) {
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
    paint(v, m, n, k, what);
  }
  return v;
}

GrainsView simulation_view(const RunFiles& files, const MicroData& m, const micro::SimulationGrains& grains, std::size_t k,
                           const Painting& what) {
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
    paint(v, m, n, k, what);
  }
  v.membrane = f.membrane_position;
  return v;
}

std::vector<Panel> grain_value_panels(const RunFiles& files, const ExperimentData& e, const SimulationData& s, const PanelOptions& options,
                                      const Painting& what) {
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
    const std::string id = fmt::format("{}_{}", what.id, k);
    Panel p{id, fmt::format("{}, increment {}", what.title, k), what.description, {}, {}};
    if (!e.micro) p.experiment = Side{std::nullopt, kNoMicro, {}};
    else if (files.tracks.empty()) p.experiment = Side{std::nullopt, "This run has no tracks (tracks.h5): the track stage (shapes2tracks) makes the grains' positions.", {}};
    else if (k >= exp_increments) p.experiment = Side{std::nullopt, fmt::format("The scans have {} increments; this one exists in the simulation only.", exp_increments), {}};
    else {
      Chart c;
      c.kind = "grains", c.panel = id, c.file = id + "_experiment.png";
      const MicroIncrement& inc = e.micro->increments[k];
      c.title = fmt::format("{} -> {}", e.scans[inc.from].name, e.scans[inc.to].name);
      c.grains = experiment_view(files, *e.micro, *tracks, k, what);
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
      c.grains = simulation_view(files, *s.micro, *grains, k, what);
      p.simulation = Side{std::move(c), {}, {}};
    }
    panels.push_back(std::move(p));
  }
  // One camera box for every picture (the whole sample's), one cut through its middle, and one
  // colour scale over the painted grains shown.
  const double inf = std::numeric_limits<double>::infinity();
  std::array<double, 6> bounds{inf, -inf, inf, -inf, inf, -inf};
  for (Panel& p : panels)
    for (Side* side : {&p.experiment, &p.simulation})
      if (side->chart) {
        bounds = sphere_bounds(side->chart->grains->centre, side->chart->grains->radius, bounds);
        views.push_back(&*side->chart->grains);
      }
  std::vector<double> values;
  for (GrainsView* v : views) {
    if (!what.clusters_only) cut_front_quarter(*v, {0.5 * (bounds[0] + bounds[1]), 0.5 * (bounds[2] + bounds[3])});
    for (std::size_t i = 0; i < v->value.size(); ++i)
      if (v->highlighted[i]) values.push_back(v->value[i]);
  }
  const auto [lo, hi] = colour_range(values, what.log);
  for (GrainsView* v : views) v->quantity = what.quantity, v->colour_log = what.log, v->colour_min = lo, v->colour_max = hi, v->bounds = bounds;
  return panels;
}

}  // namespace

std::vector<Panel> cluster_3d_panels(const RunFiles& files, const ExperimentData& e, const SimulationData& s, const PanelOptions& options) {
  return grain_value_panels(
      files, e, s, options,
      {"clusters_3d", "D2min clusters in 3D",
       "D2min of every grain at the increment's first state (micro.h5 for the scans, simulation_micro.h5 for the twin), each grain "
       "a sphere of its volume-equivalent diameter at its centroid: the members of the high-D2min clusters (tracks2micro's top "
       "fraction of D2min, linked by contact; /grains/cluster) opaque and painted on one logarithmic colour scale (1st to 99th "
       "percentile of the members' D2min) for both sides and every increment shown, every other grain a grey point, the twin's "
       "membrane balls pale blue points; one fixed camera along +y from 20 degrees above. Spheres, not the grains' shapes: the "
       "picture shows where the clusters are.",
       "D2min / d50^2", &MicroData::grain_d2min, true, true});
}

std::vector<Panel> eps_q_3d_panels(const RunFiles& files, const ExperimentData& e, const SimulationData& s, const PanelOptions& options) {
  return grain_value_panels(
      files, e, s, options,
      {"eps_q_3d", "eps_q in 3D",
       "The local deviatoric strain eps_q of every grain over the increment (micro.h5 for the scans, simulation_micro.h5 for the "
       "twin; /grains/eps_q), each grain a sphere of its volume-equivalent diameter at its centroid at the increment's first "
       "state, painted on one linear colour scale (1st to 99th percentile) for both sides and every increment shown, grey where it "
       "is not defined; the quarter in front of the sample's middle cut away so the interior, and a shear band, show; the twin's "
       "membrane balls pale blue points; one fixed camera along +y from 20 degrees above.",
       "eps_q", &MicroData::grain_eps_q, false, false});
}

}  // namespace graintwin::report
