#include "graintwin/fdem/mass_scaling.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <fmt/format.h>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/contact.hpp"

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
  double scaled_mass = 0, total_mass = 0;
  for (std::size_t g = 0; g < model.grains.size(); ++g) total_mass += solver.body(g).mass;
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

}  // namespace graintwin::fdem
