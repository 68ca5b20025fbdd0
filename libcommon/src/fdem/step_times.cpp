#include "graintwin/fdem/step_times.hpp"

#include <fmt/format.h>

namespace graintwin::fdem {

std::string describe_step_times(const StepTimes& t, std::size_t grains, int threads) {
  const double total = t.total();
  if (t.steps == 0 || !(total > 0)) return "no steps timed";
  const double rate = static_cast<double>(grains) * static_cast<double>(t.steps) / total;
  const auto share = [&](double seconds) { return 100.0 * seconds / total; };
  std::string line = fmt::format(
      "{} steps in {:.4g} s ({:.3g} ms a step): {:.3g} grain-steps/s, {:.3g} per thread on {}; contact {:.0f} %, "
      "boundary {:.0f} %, elements {:.0f} %, motion {:.0f} %",
      t.steps, total, 1e3 * total / static_cast<double>(t.steps), rate, rate / threads, threads, share(t.contact),
      share(t.boundary), share(t.elements), share(t.motion));
  const auto per_step = [&](std::uint64_t count) { return static_cast<double>(count) / static_cast<double>(t.steps); };
  line += fmt::format("; a step has {:.3g} node contacts, checks {:.3g} nodes and {:.3g} node-triangle pairs and builds "
                      "{:.3g} pairs' lists",
                      per_step(t.node_contacts), per_step(t.node_checks), per_step(t.triangle_checks), per_step(t.pair_lists_built));
  if (t.body_steps > 0)
    line += fmt::format("; membrane {:.3g} us per ball and step", 1e6 * t.body_seconds / static_cast<double>(t.body_steps));
  return line;
}

}  // namespace graintwin::fdem
