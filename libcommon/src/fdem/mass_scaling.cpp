#include "graintwin/fdem/mass_scaling.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <fmt/format.h>

#include "graintwin/core/error.hpp"
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

ElementMassScaling scale_limiting_elements(Solver& solver, double target_step, double stiffness_damping,
                                           double max_added_share, const std::string& where) {
  const Model& model = solver.model();
  ElementMassScaling out;
  out.target_step = target_step;
  out.max_added_share = max_added_share;
  out.grains_mass = grains_mass(solver);
  out.step_before = solver.time_step_limits(stiffness_damping).element_stable;
  out.step_after = out.step_before;
  if (!(target_step > out.step_before)) return out;
  // The undamped critical step whose damped stable step is the target.
  const double needed = undamped_critical_step(target_step / solver.options().element_safety, stiffness_damping);
  const std::vector<double> critical = solver.element_critical_steps();
  std::vector<double> factor(critical.size(), 1.0);
  for (std::size_t e = 0; e < critical.size(); ++e) {
    if (!(critical[e] < needed)) continue;
    factor[e] = (needed / critical[e]) * (needed / critical[e]);
    const double density = model.materials[model.grains[model.element_grain[e]].material].density;
    out.added_mass += (factor[e] - 1) * density * std::abs(element_volume(model, e));
    out.largest_factor = std::max(out.largest_factor, factor[e]);
    ++out.elements;
  }
  if (out.added_share() > max_added_share)
    throw UsageError(fmt::format(
        "{}: selective mass scaling to an element step of {:.4g} s (from {:.4g} s) would add {:.3g} % of the grains' mass "
        "({:.4g} kg on {} elements, up to {:.3g} times denser), above the bound of {:.3g} %; ask for a smaller [run] "
        "element_step_target or raise [run] max_added_mass_share",
        where, target_step, out.step_before, 100 * out.added_share(), out.added_mass, out.elements, out.largest_factor,
        100 * max_added_share));
  solver.scale_element_densities(std::move(factor));
  out.step_after = solver.time_step_limits(stiffness_damping).element_stable;
  return out;
}

}  // namespace graintwin::fdem
