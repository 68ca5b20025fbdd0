// Grain matching between two scans: the paper's Algorithm 1 and the improved matcher (consensus
// anchors, the predicted displacement field, the combined cost, the assignment and its confidence).
// The explanations of grains damaged by the segmentation are weighed in match_damage.cpp.
#include "graintwin/track/match.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "graintwin/core/enum_names.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/point_grid.hpp"
#include "graintwin/track/assignment.hpp"
#include "graintwin/track/displacement_field.hpp"
#include "match_damage.hpp"

namespace graintwin::track {
namespace {

using detail::Prediction;
using detail::Scales;
using detail::volume_z;

constexpr double nan = std::numeric_limits<double>::quiet_NaN();
constexpr std::size_t none = DisplacementField::none;

/// Candidate lists row by row, each sorted by (score, column).
struct Candidates {
  std::vector<std::size_t> start{0};
  std::vector<std::uint32_t> column;
  std::vector<double> score;
  std::size_t rows() const { return start.size() - 1; }
};

bool volume_ok(const ScanGrains& ref, std::size_t i, const ScanGrains& def, std::size_t j, double tol) {
  return tol < 0.0 || std::abs(def.volume[j] - ref.volume[i]) <= tol * ref.volume[i];
}

/// C1 and C2 of Algorithm 1 with the given score: every grain of `def` within `window` of each
/// reference grain's own position whose volume passes the filter (negative: none).
Candidates window_candidates(const ScanGrains& ref, const ScanGrains& def, const PointGrid& grid, Method method,
                             double window, double volume_tol) {
  Candidates c;
  std::vector<std::pair<double, std::uint32_t>> row;
  for (std::size_t i = 0; i < ref.size(); ++i) {
    row.clear();
    grid.for_each_within(ref.centroid[i], window, [&](std::size_t j, double d2) {
      if (!volume_ok(ref, i, def, j, volume_tol)) return;
      const double s = method == Method::nearest  ? std::sqrt(d2)
                       : method == Method::volume ? std::abs(def.volume[j] - ref.volume[i]) / ref.volume[i]
                                                  : invariant_distance(ref, i, def, j);
      row.push_back({s, static_cast<std::uint32_t>(j)});
    });
    std::sort(row.begin(), row.end());
    for (const auto& [s, j] : row) c.column.push_back(j), c.score.push_back(s);
    c.start.push_back(c.column.size());
  }
  return c;
}

/// Step 4 of Algorithm 1: every reference grain points at its best remaining candidate; a grain
/// wanted by several stays with the smallest score (ties: the lower index) and the others move on
/// to their next best, until no grain is taken twice or a list runs out (lost). This is deferred
/// acceptance with the reference grains proposing; its result does not depend on the order.
std::vector<int> deferred_acceptance(const Candidates& c, std::size_t n_def, std::vector<double>& score) {
  const std::size_t n = c.rows();
  std::vector<int> partner(n, -1), holder(n_def, -1);
  std::vector<double> held(n_def, 0.0);
  std::vector<std::size_t> next(n), queue(n);
  for (std::size_t i = 0; i < n; ++i) next[i] = c.start[i], queue[i] = n - 1 - i;  // pop from the back: index order
  while (!queue.empty()) {
    const std::size_t i = queue.back();
    queue.pop_back();
    while (next[i] < c.start[i + 1]) {
      const std::size_t e = next[i]++;
      const std::uint32_t j = c.column[e];
      const double s = c.score[e];
      const int h = holder[j];
      if (h >= 0 && !(s < held[j] || (s == held[j] && static_cast<int>(i) < h))) continue;
      if (h >= 0) {
        partner[static_cast<std::size_t>(h)] = -1;
        queue.push_back(static_cast<std::size_t>(h));
      }
      holder[j] = static_cast<int>(i), held[j] = s, partner[i] = static_cast<int>(j);
      break;
    }
  }
  score.assign(n, nan);
  for (std::size_t j = 0; j < n_def; ++j)
    if (holder[j] >= 0) score[static_cast<std::size_t>(holder[j])] = held[j];
  return partner;
}

Matching greedy_match(const ScanGrains& ref, const ScanGrains& def, const MatchOptions& o) {
  Matching m;
  m.predicted = ref.centroid;
  const double window = o.window_d50 * ref.d50;
  const PointGrid grid(def.centroid, ref.d50);
  const Candidates c = window_candidates(ref, def, grid, o.method, window, volume_filter(o));
  m.partner = deferred_acceptance(c, def.size(), m.score);
  m.diagnostics.mean_candidates = ref.size() ? static_cast<double>(c.column.size()) / ref.size() : 0.0;
  m.confidence.assign(ref.size(), nan);
  for (std::size_t i = 0; i < ref.size(); ++i)
    if (m.partner[i] >= 0) m.confidence[i] = 1.0;
  return m;
}

// ---- the improved mode -------------------------------------------------------------------------

/// D / ||R_0||; 0 (no evidence either way) when either grain has no SH fit: labels2shapes leaves
/// the invariants of grains too small to fit at zero, and dividing by their zero ||R_0|| gave
/// costs of 1e593 that no assignment can hold.
double shape_term(const ScanGrains& ref, std::size_t i, const ScanGrains& def, std::size_t j) {
  const double r0 = ref.invariants(static_cast<Eigen::Index>(i), 0), r0_def = def.invariants(static_cast<Eigen::Index>(j), 0);
  if (!(r0 > 0.0) || !(r0_def > 0.0)) return 0.0;
  return invariant_distance(ref, i, def, j) / r0;
}

/// Pairs believed matched: the prediction and the cost scales rest on them.
struct Anchors {
  std::vector<Eigen::Vector3d> from, to;
  std::vector<double> shape, log_volume;  ///< D / ||R_0|| and ln(v_def / v_ref) of each pair
  std::vector<std::size_t> ref_index;     ///< the pair's grain in the scan being matched, or none
  void add(const ScanGrains& a, std::size_t i, const ScanGrains& b, std::size_t j, std::size_t self) {
    from.push_back(a.centroid[i]), to.push_back(b.centroid[j]);
    shape.push_back(shape_term(a, i, b, j));
    log_volume.push_back(std::log(b.volume[j] / a.volume[i]));
    ref_index.push_back(self);
  }
  std::size_t size() const { return from.size(); }
};

/// Half a grain spacing (in d50): two displacements this close agree. A wrong pair lands this close
/// to where its grain went only by chance, and a right one moving non-affinely by up to about
/// 0.15 d50 per component still does.
constexpr double kAgreement_d50 = 0.5;

/// The bootstrap anchors, before any prediction: the candidates of each reference grain within
/// the paper's criteria (C1, and C2: the volume filter, or the paper's 10 % when none is set), each
/// supported by the reference neighbours within 1.5 d50 (about two shells of grains) that have a
/// candidate moving the same way (within kAgreement_d50): neighbours move alike, while a chance
/// candidate finds such support only by chance. Anchors are the pairs that are each other's best
/// by support, then by the paper's score D; shapes and volumes that agree by chance, as those of a
/// grain and another grain's merged or cut label may, rarely have the support of the neighbours.
Anchors consensus_anchors(const ScanGrains& ref, const ScanGrains& def, const PointGrid& grid, const PointGrid& ref_grid,
                          const MatchOptions& o) {
  const double gate = volume_filter(o) >= 0.0 ? volume_filter(o) : 0.10;
  const Candidates c = window_candidates(ref, def, grid, Method::paper, o.window_d50 * ref.d50, gate);
  const double agree2 = std::pow(kAgreement_d50 * ref.d50, 2);
  std::vector<int> support(c.column.size(), 0);
#pragma omp parallel for schedule(dynamic, 256)
  for (std::size_t i = 0; i < ref.size(); ++i) {
    const std::vector<std::size_t> near = ref_grid.within(ref.centroid[i], 1.5 * ref.d50);
    for (std::size_t e = c.start[i]; e < c.start[i + 1]; ++e) {
      const Eigen::Vector3d u = def.centroid[c.column[e]] - ref.centroid[i];
      for (std::size_t n : near) {
        if (n == i) continue;
        for (std::size_t f = c.start[n]; f < c.start[n + 1]; ++f)
          if (c.column[f] != c.column[e] && (def.centroid[c.column[f]] - ref.centroid[n] - u).squaredNorm() <= agree2) {
            ++support[e];
            break;
          }
      }
    }
  }
  // Better: more support, then a smaller D.
  const auto better = [&](std::size_t e, std::size_t f) { return support[e] > support[f] || (support[e] == support[f] && c.score[e] < c.score[f]); };
  std::vector<std::size_t> best_of_row(ref.size(), none), best_of_column(def.size(), none);
  for (std::size_t i = 0; i < ref.size(); ++i)
    for (std::size_t e = c.start[i]; e < c.start[i + 1]; ++e) {
      if (best_of_row[i] == none || better(e, best_of_row[i])) best_of_row[i] = e;
      std::size_t& b = best_of_column[c.column[e]];
      if (b == none || better(e, b)) b = e;
    }
  Anchors a;
  for (std::size_t i = 0; i < ref.size(); ++i) {
    const std::size_t e = best_of_row[i];
    if (e != none && best_of_column[c.column[e]] == e) a.add(ref, i, def, c.column[e], i);
  }
  return a;
}

/// Local residual spread shrunk towards the global one by a prior worth 3 pairs, floored.
double shrunk_sigma(const DisplacementField::Estimate& e, double global, double floor) {
  return std::max(floor, std::sqrt((3.0 * global * global + e.weight * e.spread * e.spread) / (3.0 + e.weight)));
}

/// The displacement field of the anchors, each weighted by its probability of being a right pair
/// judged by its position, shape and volume residuals together (right_pair_probability): a global
/// affine (RANSAC + reweighting), then local fits, refitted once with the weights of their own
/// leave-one-out errors. The scales are the right anchors' spreads, which wrong anchors (a
/// bootstrap of shapes that agree by chance, a grain matched to a merged or cut label) do not widen.
struct Predictor {
  DisplacementField field;
  std::vector<DisplacementField::Estimate> estimate;  ///< leave-one-out estimate at each anchor
  std::vector<double> error;   ///< leave-one-out prediction error of each anchor (m)
  std::vector<double> weight;  ///< probability of each anchor being right
  Scales scales;
  double floor = 0.0, clip = 0.0;
};

Predictor build_predictor(const Anchors& an, double d50, const MatchOptions& o) {
  Predictor p;
  p.floor = 0.02 * d50;  // a third of a voxel at 16 voxels per d50: segmented centroids repeat no better
  p.clip = 0.5 * d50;
  const std::size_t n = an.size();
  std::vector<double> consensus;
  const Affine base = robust_affine(an.from, an.to, kAgreement_d50 * d50, 4096, 1, &consensus);
  const double radius = o.local_radius_d50 * d50;
  p.error.assign(n, 0.0);
  p.estimate.resize(n);
  // The spreads start from the anchors the global map agrees with (the floors keep identical data
  // from making every difference infinitely expensive).
  std::vector<ResidualTerm> terms{{ResidualLaw::half_normal, an.shape, 0.0, 0.0, 0.005},
                                  {ResidualLaw::gaussian, an.log_volume, 0.0, 0.0, 0.005}};
  const auto take_scales = [&] {
    p.scales.shape = terms[0].spread;
    p.scales.volume_mean = terms[1].centre, p.scales.volume = terms[1].spread;
  };
  if (n < 4) {  // nothing to predict from: the base map with the whole window as uncertainty
    p.weight = right_pair_probability(terms, consensus);
    take_scales();
    p.field = DisplacementField(an.from, an.to, p.weight, base, radius);
    for (std::size_t a = 0; a < n; ++a) p.estimate[a] = p.field.estimate(an.from[a], a);
    p.scales.position = o.window_d50 * d50 / o.window_sigmas;
    return p;
  }
  std::vector<double> affine_error(n);
  for (std::size_t a = 0; a < n; ++a) affine_error[a] = (an.to[a] - base(an.from[a])).norm();
  terms.push_back({ResidualLaw::length3, affine_error, 0.0, 0.0, p.floor});
  p.weight = right_pair_probability(terms, consensus);
  for (int round = 0; round < 2; ++round) {
    p.field = DisplacementField(an.from, an.to, p.weight, base, radius);
    const std::vector<double> previous = p.error;
#pragma omp parallel for schedule(static)
    for (std::size_t a = 0; a < n; ++a) {
      p.estimate[a] = p.field.estimate(an.from[a], a, round ? &previous : nullptr, p.clip);
      p.error[a] = (an.to[a] - p.estimate[a].position).norm();
    }
    terms[2].value = p.error;
    const std::vector<double> weight = right_pair_probability(terms, p.weight);
    if (round == 0) p.weight = weight;  // the final field keeps the weights it was fitted with
  }
  take_scales();
  p.scales.position = terms[2].spread;
  return p;
}

/// One pass: predict, gather candidates around the predictions, cost them, assign.
struct Pass {
  SparseCosts costs;
  std::vector<double> lost_cost;  ///< per reference grain
  Assignment assignment;
  std::vector<Eigen::Vector3d> predicted;
};

Pass assign_pass(const ScanGrains& ref, const ScanGrains& def, const PointGrid& ref_grid, const PointGrid& grid,
                 const Anchors& an, const MatchOptions& o, MatchDiagnostics& diag) {
  const double d50 = ref.d50;
  const Predictor p = build_predictor(an, d50, o);
  const Scales& k = p.scales;
  diag.sigma_position = k.position, diag.sigma_shape = k.shape, diag.sigma_volume = k.volume;
  std::vector<std::size_t> self(ref.size(), none);
  for (std::size_t a = 0; a < an.size(); ++a)
    if (an.ref_index[a] != none) self[an.ref_index[a]] = a;
  Prediction at{std::vector<Eigen::Vector3d>(ref.size()), std::vector<double>(ref.size()), std::vector<double>(ref.size())};
#pragma omp parallel for schedule(dynamic, 256)
  for (std::size_t i = 0; i < ref.size(); ++i) {
    // An anchor's own leave-one-out estimate is already there (its spread from the first round's errors).
    const auto e = self[i] != none ? p.estimate[self[i]] : p.field.estimate(ref.centroid[i], none, &p.error, p.clip);
    at.position[i] = e.position;
    at.sigma[i] = shrunk_sigma(e, k.position, p.floor);
    at.window[i] = std::clamp(o.window_sigmas * at.sigma[i], o.min_window_d50 * d50, o.window_d50 * d50);
  }
  const double gate = volume_filter(o);
  Pass pass;
  std::vector<std::vector<std::pair<std::uint32_t, double>>> rows(ref.size());
#pragma omp parallel for schedule(dynamic, 256)
  for (std::size_t i = 0; i < ref.size(); ++i) {
    const double s2 = at.sigma[i] * at.sigma[i];
    grid.for_each_within(at.position[i], at.window[i], [&](std::size_t j, double d2) {
      if (!volume_ok(ref, i, def, j, gate)) return;
      const double zs = shape_term(ref, i, def, j) / k.shape;
      const double zv = volume_z(def.volume[j], ref.volume[i], k);
      rows[i].push_back({static_cast<std::uint32_t>(j), zs * zs + zv * zv + d2 / s2});
    });
  }
  pass.costs.columns = def.size();
  for (auto& r : rows) {
    for (const auto& [j, w] : r) pass.costs.add(j, w);
    pass.costs.end_row();
  }
  pass.lost_cost = detail::damage_lost_costs(ref, def, ref_grid, grid, at, k, pass.costs, o.lost_cost);
  pass.assignment = solve_assignment(pass.costs, pass.lost_cost);
  pass.predicted = std::move(at.position);
  diag.mean_candidates = ref.size() ? static_cast<double>(pass.costs.column.size()) / ref.size() : 0.0;
  diag.explained_as_damaged = static_cast<std::size_t>(
      std::count_if(pass.lost_cost.begin(), pass.lost_cost.end(), [&](double c) { return c < o.lost_cost; }));
  return pass;
}

/// The improved mode one way round. `seed` pairs (if any) start the prediction; otherwise the
/// mutual-best pairs of the paper's criteria do. Each further pass re-seeds from the last assignment.
Matching improved_match(const ScanGrains& ref, const ScanGrains& def, const MatchOptions& o, const Anchors* seed,
                        int passes) {
  Matching m;
  const PointGrid grid(def.centroid, ref.d50), ref_grid(ref.centroid, ref.d50);
  Anchors an = seed ? *seed : consensus_anchors(ref, def, grid, ref_grid, o);
  m.diagnostics.anchors = an.size();
  Pass pass;
  for (int k = 0; k < passes; ++k) {
    pass = assign_pass(ref, def, ref_grid, grid, an, o, m.diagnostics);
    if (k + 1 == passes) break;
    an = Anchors();
    for (std::size_t i = 0; i < ref.size(); ++i)
      if (pass.assignment.column_of[i] >= 0) an.add(ref, i, def, static_cast<std::size_t>(pass.assignment.column_of[i]), i);
  }
  const std::size_t n = ref.size();
  m.partner = pass.assignment.column_of;
  m.predicted = std::move(pass.predicted);
  m.score.assign(n, nan);
  m.confidence.assign(n, nan);
  // Confidence: the match's share of the likelihood exp(-cost / 2) among the alternatives of its
  // reference grain (its other candidates and being lost) and among those of its partner (the
  // other reference grains that had it as a candidate), whichever is smaller.
  const SparseCosts& c = pass.costs;
  std::vector<double> column_sum(def.size(), 0.0), cost_of(n, nan);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t e = c.row_start[i]; e < c.row_start[i + 1]; ++e)
      if (static_cast<int>(c.column[e]) == m.partner[i]) cost_of[i] = c.cost[e];
  std::vector<int> owner(def.size(), -1);
  for (std::size_t i = 0; i < n; ++i)
    if (m.partner[i] >= 0) owner[static_cast<std::size_t>(m.partner[i])] = static_cast<int>(i);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t e = c.row_start[i]; e < c.row_start[i + 1]; ++e) {
      const int w = owner[c.column[e]];
      if (w >= 0) column_sum[c.column[e]] += std::exp(-(c.cost[e] - cost_of[static_cast<std::size_t>(w)]) / 2.0);
    }
  for (std::size_t i = 0; i < n; ++i) {
    if (m.partner[i] < 0) continue;
    const double ci = cost_of[i];
    const double lost = std::exp(-(pass.lost_cost[i] - ci) / 2.0);
    double row_sum = lost;
    for (std::size_t e = c.row_start[i]; e < c.row_start[i + 1]; ++e) row_sum += std::exp(-(c.cost[e] - ci) / 2.0);
    const double col_sum = column_sum[static_cast<std::size_t>(m.partner[i])] + lost;
    m.score[i] = ci;
    m.confidence[i] = 1.0 / std::max(row_sum, col_sum);
  }
  return m;
}

Anchors anchors_from(const ScanGrains& a, const ScanGrains& b, const std::vector<std::size_t>& ia,
                     const std::vector<std::size_t>& ib) {
  if (ia.size() != ib.size()) throw UsageError("match_grains: known pairs need as many indices on both sides");
  Anchors an;
  for (std::size_t k = 0; k < ia.size(); ++k) {
    if (ia[k] >= a.size() || ib[k] >= b.size()) throw UsageError("match_grains: a known pair's index is out of range");
    an.add(a, ia[k], b, ib[k], none);
  }
  return an;
}

void check_options(const MatchOptions& o, const ScanGrains& ref, const ScanGrains& def) {
  if (!(o.window_d50 > 0.0)) throw UsageError("the candidate window must be positive (in d50)");
  if (!(o.min_window_d50 > 0.0) || o.min_window_d50 > o.window_d50)
    throw UsageError("the smallest candidate window must be positive and at most the window");
  if (!(o.local_radius_d50 > 0.0)) throw UsageError("the local fit radius must be positive (in d50)");
  if (!(o.window_sigmas > 0.0)) throw UsageError("the window in residual spreads must be positive");
  if (!(o.lost_cost > 0.0) || !std::isfinite(o.lost_cost)) throw UsageError("the lost cost must be positive and finite");
  if (o.passes < 1) throw UsageError("at least one matching pass is needed");
  for (const ScanGrains* s : {&ref, &def})
    if (!(s->d50 > 0.0) || !std::isfinite(s->d50)) throw UsageError("match_grains: a scan has no positive d50");
}

/// Sets confidence 0 where the match the other way round (`back`) disagrees.
void apply_backward(Matching& m, const Matching& back) {
  for (std::size_t i = 0; i < m.partner.size(); ++i) {
    const int j = m.partner[i];
    if (j >= 0 && back.partner[static_cast<std::size_t>(j)] != static_cast<int>(i)) {
      m.confidence[i] = 0.0;
      ++m.diagnostics.backward_disagreements;
    }
  }
}

/// The forward matches seen from the other scan: they seed the backward pass, which thus predicts
/// each grain's way back from its neighbours' matches (never its own) and solves its own assignment.
Anchors reversed_matches(const ScanGrains& ref, const ScanGrains& def, const Matching& m) {
  Anchors an;
  for (std::size_t i = 0; i < ref.size(); ++i)
    if (m.partner[i] >= 0) {
      const std::size_t j = static_cast<std::size_t>(m.partner[i]);
      an.add(def, j, ref, i, j);
    }
  return an;
}

}  // namespace

ScanGrains scan_grains(const shape::ShapesFile& shapes) {
  ScanGrains s;
  const std::size_t n = shapes.grains.size();
  s.invariants.resize(static_cast<Eigen::Index>(n), shapes.degree + 1);
  for (std::size_t i = 0; i < n; ++i) {
    const shape::GrainShape& g = shapes.grains[i];
    if (!g.centroid.allFinite() || !(g.volume > 0.0) || !std::isfinite(g.volume))
      throw DataError("grain " + std::to_string(g.label) + " has a non-finite centroid or a non-positive volume");
    if (g.invariants.size() != shapes.degree + 1)
      throw DataError("grain " + std::to_string(g.label) + " has " + std::to_string(g.invariants.size()) +
                      " invariants for SH degree " + std::to_string(shapes.degree));
    s.label.push_back(g.label);
    s.centroid.push_back(g.centroid);
    s.volume.push_back(g.volume);
    s.invariants.row(static_cast<Eigen::Index>(i)) = g.invariants.transpose();
  }
  s.d50 = shapes.psd.d50;
  if (n > 0 && (!(s.d50 > 0.0) || !std::isfinite(s.d50))) throw DataError("the size distribution has no positive d50");
  return s;
}

ScanGrains subset(const ScanGrains& scan, const std::vector<std::size_t>& index) {
  ScanGrains s;
  s.d50 = scan.d50;
  s.invariants.resize(static_cast<Eigen::Index>(index.size()), scan.invariants.cols());
  for (std::size_t k = 0; k < index.size(); ++k) {
    const std::size_t i = index.at(k);
    if (i >= scan.size()) throw UsageError("subset: index out of range");
    s.label.push_back(scan.label[i]);
    s.centroid.push_back(scan.centroid[i]);
    s.volume.push_back(scan.volume[i]);
    s.invariants.row(static_cast<Eigen::Index>(k)) = scan.invariants.row(static_cast<Eigen::Index>(i));
  }
  return s;
}

double invariant_distance(const ScanGrains& a, std::size_t i, const ScanGrains& b, std::size_t j) {
  const Eigen::Index k = std::min(a.invariants.cols(), b.invariants.cols());
  return (a.invariants.row(static_cast<Eigen::Index>(i)).head(k) - b.invariants.row(static_cast<Eigen::Index>(j)).head(k)).norm();
}

double volume_filter(const MatchOptions& o) {
  if (o.method == Method::nearest) return -1.0;
  return o.volume_tol.value_or(o.method == Method::improved ? -1.0 : 0.10);
}

namespace {
constexpr std::array<EnumName<Method>, 4> kMethodNames{
    {{Method::improved, "improved"}, {Method::paper, "paper"}, {Method::nearest, "nearest"}, {Method::volume, "volume"}}};
}  // namespace

std::string method_name(Method m) { return enum_name(kMethodNames, m); }

Method parse_method(const std::string& name) { return parse_enum(kMethodNames, name, "matching method"); }

std::size_t Matching::matched() const {
  return static_cast<std::size_t>(std::count_if(partner.begin(), partner.end(), [](int j) { return j >= 0; }));
}

Matching match_grains(const ScanGrains& ref, const ScanGrains& def, const MatchOptions& o) {
  check_options(o, ref, def);
  if (o.method != Method::improved) {
    Matching m = greedy_match(ref, def, o);
    if (o.backward_check) apply_backward(m, greedy_match(def, ref, o));
    return m;
  }
  Matching m = improved_match(ref, def, o, nullptr, o.passes);
  if (o.backward_check) {
    const Anchors back = reversed_matches(ref, def, m);
    apply_backward(m, improved_match(def, ref, o, &back, 1));
  }
  return m;
}

Matching match_grains(const ScanGrains& ref, const ScanGrains& def, const MatchOptions& o, const ScanGrains& known_ref,
                      const ScanGrains& known_def, const KnownPairs& known) {
  check_options(o, ref, def);
  if (o.method != Method::improved || known.ref.size() < 8) return match_grains(ref, def, o);
  const Anchors forward = anchors_from(known_ref, known_def, known.ref, known.def);
  Matching m = improved_match(ref, def, o, &forward, 1);
  if (o.backward_check) {
    const Anchors backward = anchors_from(known_def, known_ref, known.def, known.ref);
    apply_backward(m, improved_match(def, ref, o, &backward, 1));
  }
  return m;
}

}  // namespace graintwin::track
