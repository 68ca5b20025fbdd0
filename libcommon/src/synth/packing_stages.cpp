// Packing in stages: the grains grown with smoother shapes first (pack_grains), then each later
// stage's shapes put in at the poses reached and relaxed (relax_grains).
#include <chrono>
#include <functional>
#include <string>
#include <vector>

#include "graintwin/core/error.hpp"
#include "graintwin/synth/packing.hpp"

namespace graintwin::synth {

namespace {
// Later stages regrow from this scale: at full size the new bumps would have no room.
constexpr double kStageRegrowScale = 0.98;
}  // namespace

std::vector<PackedGrain> pack_in_stages(
    const std::vector<std::vector<const shape::RadialTable*>>& stages, const Container& c,
    const PackingParams& p, PackingReport* report, const PackingObserver& observe) {
  for (std::size_t k = 1; k < stages.size(); ++k) {  // before any work, though the stages check again
    if (stages[k].size() != stages[0].size()) {
      throw UsageError("pack_in_stages: stage " + std::to_string(k) + " has " + std::to_string(stages[k].size()) +
                       " shapes but stage 0 has " + std::to_string(stages[0].size()) +
                       "; pass one shape per grain in every stage");
    }
  }
  return pack_in_stages(stages.size(), [&stages](std::size_t k) { return stages[k]; }, c, p, report, observe);
}

std::vector<PackedGrain> pack_in_stages(std::size_t stage_count, const StageShapes& stage_shapes,
                                        const Container& c, const PackingParams& p, PackingReport* report,
                                        const PackingObserver& observe) {
  if (stage_count == 0) {
    throw UsageError("pack_in_stages: no stages; pass at least the grains' true shapes");
  }
  std::size_t grains = 0;
  auto shapes_of = [&](std::size_t k) {
    std::vector<const shape::RadialTable*> shapes = stage_shapes(k);
    if (k == 0) grains = shapes.size();
    if (shapes.size() != grains) {
      throw UsageError("pack_in_stages: stage " + std::to_string(k) + " has " + std::to_string(shapes.size()) +
                       " shapes but stage 0 has " + std::to_string(grains) +
                       "; pass one shape per grain in every stage");
    }
    return shapes;
  };
  const auto t0 = std::chrono::steady_clock::now();
  auto observe_stage = [&](std::size_t k) -> PackingObserver {
    if (!observe) return {};
    return [&observe, k, stage_count](PackingStatus s) {
      s.stage = k, s.stages = stage_count;
      observe(s);
    };
  };
  auto in_stage = [&](std::size_t k, auto&& run) {
    try {
      return run();
    } catch (const DataError& e) {
      if (stage_count == 1) throw;
      throw DataError("packing stage " + std::to_string(k + 1) + " of " + std::to_string(stage_count) + ": " +
                      e.message());
    }
  };
  PackingReport r;
  std::vector<PackedGrain> poses =
      in_stage(0, [&] { return pack_grains(shapes_of(0), c, p, &r, observe_stage(0)); });
  int sweeps = r.sweeps;
  const double initial_scale = r.initial_scale;
  // Each later stage starts shrunk a little and regrows: at full size the new bumps would have to
  // be pushed out of a jammed packing; shrunk, they find room and the grains re-jam slowly.
  PackingParams regrow = p;
  regrow.initial_scale = kStageRegrowScale;
  for (std::size_t k = 1; k < stage_count; ++k) {
    r = in_stage(k, [&] { return relax_grains(shapes_of(k), poses, c, regrow, observe_stage(k)); });
    sweeps += r.sweeps;
  }
  r.sweeps = sweeps;
  r.initial_scale = initial_scale;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (report) *report = r;
  return poses;
}

}  // namespace graintwin::synth
