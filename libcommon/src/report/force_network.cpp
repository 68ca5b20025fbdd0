#include "graintwin/report/force_network.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "graintwin/fdem/results_file.hpp"

namespace graintwin::report {

ForceNetwork force_network(const std::vector<Eigen::Vector3d>& centroid, const micro::FrameContacts& contacts) {
  ForceNetwork n;
  for (std::size_t i = 0; i < contacts.pair.size(); ++i) {
    if (!(contacts.normal_force[i] > 0.0)) continue;
    n.from.push_back(centroid[contacts.pair[i].first]);
    n.to.push_back(centroid[contacts.pair[i].second]);
    n.force.push_back(contacts.normal_force[i]);
  }
  return n;
}

ForceNetwork strong_network(const ForceNetwork& network) {
  if (network.force.empty()) return {};
  double mean = 0.0;
  for (double f : network.force) mean += f / double(network.force.size());
  ForceNetwork strong;
  for (std::size_t i = 0; i < network.force.size(); ++i)
    if (network.force[i] >= mean) {
      strong.from.push_back(network.from[i]), strong.to.push_back(network.to[i]);
      strong.force.push_back(network.force[i]);
    }
  return strong;
}

std::vector<Panel> force_network_panels(const RunFiles& files, const SimulationData& s, const PanelOptions& options) {
  const char* description =
      "The strong force network of the FDEM twin: every grain-grain contact pushing its grains apart with at least the frame's "
      "mean normal force, as a tube from centroid to centroid, its radius and colour proportional to that force (the frame's "
      "/contacts of simulation.h5); one force scale (0 to the 99th percentile of every frame shown) and one fixed camera, "
      "looking along +y from 20 degrees above, for every frame.";
  if (!s.present) return {Panel{"force_network", "Force-chain network", description, Side{std::nullopt, kCtNoForces, {}},
                                Side{std::nullopt, kNoSimulation, {}}}};
  const micro::SimulationGrains grains = micro::read_simulation_grains(files.simulation);
  std::vector<std::size_t> frames = pick_evenly(s.frames, options.max_series);
  std::vector<ForceNetwork> networks;
  std::vector<double> strains, all;
  const double inf = std::numeric_limits<double>::infinity();
  std::array<double, 6> bounds{inf, -inf, inf, -inf, inf, -inf};
  for (std::size_t k : frames) {
    const fdem::ResultsFrame f = fdem::read_results_frame(files.simulation, k);
    networks.push_back(strong_network(force_network(micro::frame_centroids(f, grains, files.simulation, k),
                                                    micro::frame_contacts(f, grains, files.simulation, k))));
    strains.push_back(f.axial_strain);
    all.insert(all.end(), networks.back().force.begin(), networks.back().force.end());
    for (const auto* ends : {&networks.back().from, &networks.back().to})
      for (const Eigen::Vector3d& p : *ends)
        for (int a = 0; a < 3; ++a) bounds[2 * a] = std::min(bounds[2 * a], p[a]), bounds[2 * a + 1] = std::max(bounds[2 * a + 1], p[a]);
  }
  std::sort(all.begin(), all.end());
  const double force_max = all.empty() ? 1.0 : all[std::size_t(std::llround(0.99 * double(all.size() - 1)))];
  const double radius_max = 0.15 * (s.psd.d50 > 0.0 ? s.psd.d50 : 0.05 * std::max(bounds[1] - bounds[0], bounds[5] - bounds[4]));

  std::vector<Panel> panels;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const std::string id = fmt::format("force_network_{}", frames[i]);
    const std::string strain = std::isfinite(strains[i]) ? fmt::format(", axial strain {:.1f} %", 100.0 * strains[i]) : "";
    Panel p{id, fmt::format("Force-chain network, frame {}{}", frames[i], strain), description, Side{std::nullopt, kCtNoForces, {}}, {}};
    const ForceNetwork& n = networks[i];
    if (n.force.empty()) {
      p.simulation = Side{std::nullopt, fmt::format("Frame {} holds no grain-grain contact pushing its grains apart.", frames[i]), {}};
      panels.push_back(std::move(p));
      continue;
    }
    Chart c;
    c.kind = "network", c.panel = id, c.file = id + "_simulation.png";
    c.title = fmt::format("frame {}{}: {} strong contacts", frames[i], strain, n.force.size());
    NetworkView v;
    for (std::size_t j = 0; j < n.force.size(); ++j)
      for (const Eigen::Vector3d* e : {&n.from[j], &n.to[j]}) v.segments.insert(v.segments.end(), {e->x(), e->y(), e->z()});
    v.force = n.force;
    v.force_max = force_max, v.radius_max = radius_max, v.bounds = bounds;
    c.network = std::move(v);
    p.simulation = Side{std::move(c), {}, fmt::format("Normal forces up to {:.3g} N; the scale's top, {:.3g} N, is the 99th "
                                                      "percentile over the frames shown.", *std::max_element(n.force.begin(), n.force.end()), force_max)};
    panels.push_back(std::move(p));
  }
  return panels;
}

}  // namespace graintwin::report
