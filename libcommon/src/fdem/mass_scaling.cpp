#include "graintwin/fdem/mass_scaling.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include <fmt/format.h>

#include "graintwin/core/error.hpp"
#include "graintwin/core/parallel.hpp"
#include "graintwin/fdem/contact.hpp"
#include "graintwin/fdem/element.hpp"

namespace graintwin::fdem {

MassScaling scale_fastest_grains(Model& model, const Solver& solver, double share) {
  if (!(share >= 0.0 && share <= 0.2))
    throw UsageError(fmt::format("scale_fastest_grains: the share of grains must lie in [0, 0.2] (got {:g})", share));
  MassScaling out;
  const ContactModel* contact = solver.contact_model();
  if (!contact || share == 0.0 || model.grains.empty()) return out;
  const std::vector<double> steps = contact->grain_time_steps();
  std::vector<std::uint32_t> order(steps.size());
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return steps[a] < steps[b]; });
  const auto count = static_cast<std::size_t>(std::floor(share * static_cast<double>(order.size())));
  out.step_before = steps[order.front()];
  out.step_after = out.step_before;
  if (count == 0 || count >= order.size() || !std::isfinite(steps[order[count]])) return out;
  const double target = steps[order[count]];
  out.step_after = target;
  double scaled_mass = 0;
  const double total_mass = grains_mass(solver);
  for (std::size_t k = 0; k < count; ++k) {
    const std::uint32_t g = order[k];
    if (!(steps[g] < target)) continue;
    const double factor = (target / steps[g]) * (target / steps[g]);
    Material scaled = model.materials.at(model.grains[g].material);
    scaled.density *= factor;
    scaled.name = fmt::format("{} x{:.3g}", scaled.name, factor);
    model.materials.push_back(scaled);
    model.grains[g].material = static_cast<std::uint32_t>(model.materials.size() - 1);
    scaled_mass += solver.body(g).mass;
    out.scaled.push_back(g);
    out.factors.push_back(factor);
    out.largest_factor = std::max(out.largest_factor, factor);
  }
  out.grains = out.scaled.size();
  out.mass_share = total_mass > 0 ? scaled_mass / total_mass : 0.0;
  return out;
}

double grains_mass(const Solver& solver) {
  double mass = 0;
  for (std::size_t g = 0; g < solver.model().grains.size(); ++g) mass += solver.body(g).mass;
  return mass;
}

std::vector<double> node_stiffness_bounds(const Model& model) {
  std::vector<double> rows(3 * model.nodes.size(), 0.0);
  // A grain's elements touch only its own nodes, so grains go in parallel.
  parallel_for_each_index(model.grains.size(), [&](std::size_t g) {
    const Grain& grain = model.grains[g];
    if (grain.kind == GrainKind::rigid) return;
    const Lame lame = lame_constants(model.materials[grain.material]);
    ElementStiffness K;
    for (std::size_t e = grain.element_begin; e < grain.element_end; ++e) {
      const int n = element_stiffness(model, e, lame, K);
      const std::uint32_t* nodes = model.element_nodes.data() + model.element_offset[e];
      for (int a = 0; a < n; ++a)
        for (int i = 0; i < 3; ++i) rows[3 * nodes[a] + i] += K.row(3 * a + i).head(3 * n).cwiseAbs().sum();
    }
  });
  std::vector<double> bounds(model.nodes.size());
  for (std::size_t v = 0; v < bounds.size(); ++v) bounds[v] = std::max({rows[3 * v], rows[3 * v + 1], rows[3 * v + 2]});
  return bounds;
}

double guaranteed_critical_step(std::span<const double> bounds, std::span<const double> node_mass) {
  double omega2 = 0;
  for (std::size_t v = 0; v < bounds.size(); ++v)
    if (bounds[v] > 0) omega2 = std::max(omega2, bounds[v] / node_mass[v]);
  return omega2 > 0 ? 2 / std::sqrt(omega2) : std::numeric_limits<double>::infinity();
}

SelectiveMassScaling scale_limiting_nodes(Solver& solver, double target_step, double stiffness_damping,
                                          double max_added_share, const std::string& where) {
  SelectiveMassScaling out;
  out.target_step = target_step;
  out.max_added_share = max_added_share;
  out.grains_mass = grains_mass(solver);
  out.step_before = solver.time_step_limits(stiffness_damping).element_stable;
  out.step_after = out.step_before;
  if (!(target_step > out.step_before)) return out;
  const std::vector<double> bounds = node_stiffness_bounds(solver.model());
  const std::span<const double> mass = solver.node_mass();
  const double safety = solver.options().element_safety;
  out.guaranteed_before = damped_critical_step(guaranteed_critical_step(bounds, mass), stiffness_damping) * safety;
  // The undamped critical step whose damped stable step is the target; a node certifies it with
  // bound dt^2 / 4 of mass (a hair more, so that the sum's rounding cannot fall short of it).
  const double needed = undamped_critical_step(target_step / safety, stiffness_damping) * (1 + 1e-12);
  std::vector<double> added(mass.size(), 0.0);
  for (std::size_t v = 0; v < mass.size(); ++v) {
    const double wanted = bounds[v] * needed * needed / 4;
    if (!(wanted > mass[v])) continue;
    added[v] = wanted - mass[v];
    out.added_mass += added[v];
    out.largest_factor = std::max(out.largest_factor, wanted / mass[v]);
    ++out.nodes;
  }
  if (out.added_share() > max_added_share)
    throw UsageError(fmt::format(
        "{}: selective mass scaling to an element step of {:.4g} s (from {:.4g} s) would add {:.3g} % of the grains' mass "
        "({:.4g} kg on {} nodes, up to {:.3g} times heavier), above the bound of {:.3g} %; ask for a smaller [run] "
        "element_step_target or raise [run] max_added_mass_share",
        where, target_step, out.step_before, 100 * out.added_share(), out.added_mass, out.nodes, out.largest_factor,
        100 * max_added_share));
  std::vector<double> scaled(mass.begin(), mass.end());
  for (std::size_t v = 0; v < scaled.size(); ++v) scaled[v] += added[v];
  solver.add_node_masses(std::move(added), guaranteed_critical_step(bounds, scaled));
  out.step_after = solver.time_step_limits(stiffness_damping).element_stable;
  return out;
}

}  // namespace graintwin::fdem
