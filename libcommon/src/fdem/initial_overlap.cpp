#include "graintwin/fdem/initial_overlap.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "graintwin/core/error.hpp"
#include "graintwin/core/geometry.hpp"
#include "graintwin/fdem/contact.hpp"

namespace graintwin::fdem {
namespace {

/// Passes of relaxation before the grains are taken to have no room to part: a pair needs a few
/// (each moves it by its depth as measured to the nearest face, which may be less than the depth
/// along the line of centroids); a packing's chains of pushed grains need more.
constexpr std::size_t kMaxPasses = 500;
/// Relaxation pushes until no overlap exceeds this fraction of its tolerance, and parts each pair
/// it pushes by this fraction of its tolerance beyond touching: the penalty would turn even a
/// micrometre of overlap into a separation speed of metres per second, so relaxed grains start
/// apart, not pressed into each other at the tolerance.
constexpr double kRelaxedFraction = 0.01;
/// With kept initial overlaps, relaxation parts only those beyond the tolerance, to this fraction
/// of it: the rest carry no force, and parting them all would dilate a scanned packing.
constexpr double kKeptRelaxedFraction = 0.5;

std::string mm(double metres) { return fmt::format("{:.3g} mm", 1e3 * metres); }

/// Where an overlap is and what it may be: its tolerance, m, and how to name it.
class OverlapJudge {
 public:
  OverlapJudge(const Solver& solver, double fraction) : model_(solver.model()), fraction_(fraction) {
    for (std::size_t g = 0; g < model_.grains.size(); ++g)
      size_.push_back(equivalent_diameter(solver.body(g).volume));
  }

  bool platen(const Overlap& o) const { return o.b >= model_.grains.size(); }
  /// The size the tolerance is a fraction of: the smaller grain's equivalent diameter.
  double size(const Overlap& o) const { return platen(o) ? size_[o.a] : std::min(size_[o.a], size_[o.b]); }
  double tolerance(const Overlap& o) const { return fraction_ * size(o); }
  /// "grains label 3 and label 7 overlap by 0.2 mm" or "grain label 3 reaches 0.2 mm behind platen 'top'".
  std::string describe(const Overlap& o) const {
    if (platen(o))
      return fmt::format("grain label {} reaches {} behind platen '{}'", model_.grains[o.a].label, mm(o.depth),
                         model_.platens[o.b - model_.grains.size()].name);
    return fmt::format("grains label {} and label {} overlap by {}", model_.grains[o.a].label, model_.grains[o.b].label,
                       mm(o.depth));
  }
  std::string tolerance_text(const Overlap& o) const {
    return fmt::format("{} ([run] overlap_tolerance = {:g} x the {} equivalent diameter, {})", mm(tolerance(o)), fraction_,
                       platen(o) ? "grain's" : "smaller grain's", mm(size(o)));
  }

 private:
  const Model& model_;
  double fraction_;
  std::vector<double> size_;
};

/// The overlap furthest beyond its tolerance (by depth / tolerance) among `overlaps`, and how many
/// exceed `share` of theirs.
std::pair<const Overlap*, std::size_t> worst(const std::vector<Overlap>& overlaps, const OverlapJudge& judge, double share) {
  const Overlap* worst = nullptr;
  std::size_t beyond = 0;
  for (const Overlap& o : overlaps) {
    if (!(o.depth > share * judge.tolerance(o))) continue;
    ++beyond;
    if (!worst || o.depth / judge.tolerance(o) > worst->depth / judge.tolerance(*worst)) worst = &o;
  }
  return {worst, beyond};
}

}  // namespace

OverlapSettlement settle_initial_overlaps(Solver& solver, Model& model, const OverlapOptions& options,
                                          const std::string& where) {
  OverlapSettlement out;
  ContactModel* contact = solver.contact_model();
  if (!contact || model.grains.empty()) return out;
  if (&solver.model() != &model) throw UsageError("settle_initial_overlaps: the model is not the solver's");
  const std::vector<PlatenState> platens(solver.platens().begin(), solver.platens().end());
  const OverlapJudge judge(solver, options.tolerance);
  std::vector<Eigen::Vector3d> x = model.nodes;
  std::vector<Overlap> overlaps = contact->overlaps(x, platens);
  for (const Overlap& o : overlaps) out.deepest = std::max(out.deepest, o.depth);
  const auto [first_worst, beyond] = worst(overlaps, judge, 1.0);
  out.beyond = beyond;
  if (beyond == 0) {
    out.deepest_after = out.deepest;
    out.remaining = std::move(overlaps);
    return out;
  }
  if (!options.relax)
    throw UsageError(fmt::format("{}: {} at the start, beyond the tolerance of {}{}; move them apart, or set [run] "
                                 "relax_overlaps = true to push overlapping grains apart before the run",
                                 where, judge.describe(*first_worst), judge.tolerance_text(*first_worst),
                                 beyond > 1 ? fmt::format(" ({} overlaps in all are beyond theirs)", beyond) : ""));

  // Relaxation: Jacobi passes of rigid translations, each grain moved by the mean of its pairs'
  // pushes; after a pass only the pairs of the grains that moved are measured again.
  const std::size_t grains = model.grains.size();
  std::vector<Eigen::Vector3d> centroid(grains), shift(grains, Eigen::Vector3d::Zero());
  for (std::size_t g = 0; g < grains; ++g) centroid[g] = solver.body(g).centroid;
  std::vector<Eigen::Vector3d> push(grains);
  std::vector<int> pushes(grains);
  std::vector<std::uint8_t> moved(grains);
  const double relaxed = options.keep ? kKeptRelaxedFraction : kRelaxedFraction;
  const char* share_text = options.keep ? "half" : "a hundredth";
  for (;;) {
    const auto [left, count] = worst(overlaps, judge, relaxed);
    if (count == 0) break;
    spdlog::debug("relaxation pass {}: {} overlaps beyond {} of their tolerance, worst {} ({:.3g} of its tolerance)",
                  out.passes, count, share_text, judge.describe(*left), left->depth / judge.tolerance(*left));
    if (out.passes == kMaxPasses)
      throw UsageError(fmt::format("{}: relaxing the initial overlaps ([run] relax_overlaps) left {} after {} passes "
                                   "(the relaxation stops at {} of the tolerance, {}); they have no room to part: move "
                                   "the grains or the platens apart",
                                   where, judge.describe(*left), kMaxPasses, share_text, mm(relaxed * judge.tolerance(*left))));
    ++out.passes;
    std::fill(push.begin(), push.end(), Eigen::Vector3d::Zero());
    std::fill(pushes.begin(), pushes.end(), 0);
    for (const Overlap& o : overlaps) {
      if (!(o.depth > relaxed * judge.tolerance(o))) continue;
      // Parted to touching, or with kept overlaps to half the tolerance.
      const double distance = options.keep ? o.depth - 0.5 * relaxed * judge.tolerance(o) : o.depth + kRelaxedFraction * judge.tolerance(o);
      if (judge.platen(o)) {
        push[o.a] += distance * platens[o.b - grains].normal;
        ++pushes[o.a];
        continue;
      }
      Eigen::Vector3d line = (centroid[o.b] + shift[o.b]) - (centroid[o.a] + shift[o.a]);
      // Grains centred on each other part along x: any direction separates them in the end.
      line = line.norm() > 0 ? Eigen::Vector3d(line.normalized()) : Eigen::Vector3d::UnitX();
      push[o.a] -= 0.5 * distance * line;
      push[o.b] += 0.5 * distance * line;
      ++pushes[o.a], ++pushes[o.b];
    }
    for (std::size_t g = 0; g < grains; ++g) {
      moved[g] = pushes[g] > 0;
      if (!moved[g]) continue;
      const Eigen::Vector3d move = push[g] / static_cast<double>(pushes[g]);
      shift[g] += move;
      for (std::uint32_t i = model.grains[g].node_begin; i < model.grains[g].node_end; ++i) x[i] += move;
    }
    // The unmoved grains' overlaps stand; the moved grains' are measured again.
    std::erase_if(overlaps, [&](const Overlap& o) { return moved[o.a] || (!judge.platen(o) && moved[o.b]); });
    std::vector<Overlap> fresh = contact->overlaps(x, platens, moved);
    overlaps.insert(overlaps.end(), fresh.begin(), fresh.end());
  }
  for (std::size_t g = 0; g < grains; ++g) {
    const double moved = shift[g].norm();
    if (moved > 0) ++out.moved_grains;
    out.largest_move = std::max(out.largest_move, moved);
  }
  for (const Overlap& o : overlaps) out.deepest_after = std::max(out.deepest_after, o.depth);
  model.nodes = std::move(x);
  out.remaining = std::move(overlaps);
  return out;
}

}  // namespace graintwin::fdem
