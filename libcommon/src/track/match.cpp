#include "graintwin/track/match.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "graintwin/core/enum_names.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/point_grid.hpp"
#include "graintwin/core/statistics.hpp"
#include "graintwin/track/assignment.hpp"
#include "graintwin/track/displacement_field.hpp"

namespace graintwin::track {
namespace {

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

/// The bootstrap anchors: pairs that are each other's best by the paper's criteria (C1, C2, D).
Anchors mutual_best(const ScanGrains& ref, const ScanGrains& def, const PointGrid& grid, const MatchOptions& o) {
  const Candidates c = window_candidates(ref, def, grid, Method::paper, o.window_d50 * ref.d50, volume_filter(o));
  std::vector<int> best_ref(def.size(), -1);
  std::vector<double> best_score(def.size(), std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < ref.size(); ++i)
    for (std::size_t e = c.start[i]; e < c.start[i + 1]; ++e)
      if (c.score[e] < best_score[c.column[e]]) best_score[c.column[e]] = c.score[e], best_ref[c.column[e]] = static_cast<int>(i);
  Anchors a;
  for (std::size_t i = 0; i < ref.size(); ++i)
    if (c.start[i] < c.start[i + 1] && best_ref[c.column[c.start[i]]] == static_cast<int>(i))
      a.add(ref, i, def, c.column[c.start[i]], i);
  return a;
}

/// Local residual spread shrunk towards the global one by a prior worth 3 pairs, floored.
double shrunk_sigma(const DisplacementField::Estimate& e, double global, double floor) {
  return std::max(floor, std::sqrt((3.0 * global * global + e.weight * e.spread * e.spread) / (3.0 + e.weight)));
}

/// The displacement field of the anchors with robust weights: a global affine (RANSAC + IRLS),
/// then local fits in which anchors far from their neighbours' consensus (leave-one-out error
/// above 6 global spreads) are weighted down by Tukey's biweight before the final fit.
struct Predictor {
  DisplacementField field;
  std::vector<DisplacementField::Estimate> estimate;  ///< leave-one-out estimate at each anchor
  std::vector<double> error;   ///< leave-one-out prediction error of each anchor (m)
  std::vector<double> weight;  ///< final weight of each anchor
  double sigma = 0.0;          ///< global per-component spread (m)
  double floor = 0.0, clip = 0.0;
};

Predictor build_predictor(const Anchors& an, double d50, const MatchOptions& o) {
  Predictor p;
  p.floor = 0.02 * d50;  // a third of a voxel at 16 voxels per d50: segmented centroids repeat no better
  p.clip = 0.5 * d50;
  const std::size_t n = an.size();
  const Affine base = robust_affine(an.from, an.to, 0.25 * d50, 128, 1);
  const double radius = o.local_radius_d50 * d50;
  p.weight.assign(n, 1.0);
  p.error.assign(n, 0.0);
  p.estimate.resize(n);
  if (n < 4) {  // nothing to predict from: the base map with the whole window as uncertainty
    p.field = DisplacementField(an.from, an.to, p.weight, base, radius);
    for (std::size_t a = 0; a < n; ++a) p.estimate[a] = p.field.estimate(an.from[a], a);
    p.sigma = o.window_d50 * d50 / o.window_sigmas;
    return p;
  }
  for (int round = 0; round < 2; ++round) {
    p.field = DisplacementField(an.from, an.to, p.weight, base, radius);
    const std::vector<double> previous = p.error;
#pragma omp parallel for schedule(static)
    for (std::size_t a = 0; a < n; ++a) {
      p.estimate[a] = p.field.estimate(an.from[a], a, round ? &previous : nullptr, p.clip);
      p.error[a] = (an.to[a] - p.estimate[a].position).norm();
    }
    std::vector<double> kept;
    for (std::size_t a = 0; a < n; ++a)
      if (p.weight[a] > 0.5) kept.push_back(p.error[a]);
    p.sigma = std::max(median(kept.empty() ? p.error : kept) / 1.538, p.floor);  // median |3-D Gaussian| = 1.538 sigma
    if (round == 1) break;
    for (std::size_t a = 0; a < n; ++a) {
      const double u = p.error[a] / (6.0 * p.sigma);
      p.weight[a] = u < 1.0 ? (1.0 - u * u) * (1.0 - u * u) : 0.0;
    }
  }
  return p;
}

/// Robust spreads of the shape and volume terms over the well-weighted anchors, floored so that
/// identical data do not make every difference infinitely expensive.
struct Scales {
  double shape = 0.0, volume_mean = 0.0, volume = 0.0;
};
Scales cost_scales(const Anchors& an, const std::vector<double>& weight) {
  std::vector<double> s, v;
  for (std::size_t a = 0; a < an.size(); ++a)
    if (weight[a] > 0.5) s.push_back(an.shape[a]), v.push_back(an.log_volume[a]);
  Scales k;
  k.shape = std::max(1.4826 * median(s), 0.005);  // D / ||R_0|| >= 0: half-normal median
  k.volume_mean = median(v);
  for (double& x : v) x = std::abs(x - k.volume_mean);
  k.volume = std::max(1.4826 * median(v), 0.005);
  return k;
}

/// One pass: predict, gather candidates around the predictions, cost them, assign.
struct Pass {
  SparseCosts costs;
  Assignment assignment;
  std::vector<Eigen::Vector3d> predicted;
};

Pass assign_pass(const ScanGrains& ref, const ScanGrains& def, const PointGrid& grid, const Anchors& an,
                 const MatchOptions& o, MatchDiagnostics& diag) {
  const double d50 = ref.d50;
  const Predictor p = build_predictor(an, d50, o);
  const Scales k = cost_scales(an, p.weight);
  diag.sigma_position = p.sigma, diag.sigma_shape = k.shape, diag.sigma_volume = k.volume;
  std::vector<std::size_t> self(ref.size(), none);
  for (std::size_t a = 0; a < an.size(); ++a)
    if (an.ref_index[a] != none) self[an.ref_index[a]] = a;
  const double gate = volume_filter(o);
  Pass pass;
  pass.predicted.resize(ref.size());
  std::vector<std::vector<std::pair<std::uint32_t, double>>> rows(ref.size());
#pragma omp parallel for schedule(dynamic, 256)
  for (std::size_t i = 0; i < ref.size(); ++i) {
    // An anchor's own leave-one-out estimate is already there (its spread from the first round's errors).
    const auto e = self[i] != none ? p.estimate[self[i]] : p.field.estimate(ref.centroid[i], none, &p.error, p.clip);
    const double sigma = shrunk_sigma(e, p.sigma, p.floor);
    const double window = std::clamp(o.window_sigmas * sigma, o.min_window_d50 * d50, o.window_d50 * d50);
    pass.predicted[i] = e.position;
    grid.for_each_within(e.position, window, [&](std::size_t j, double d2) {
      if (!volume_ok(ref, i, def, j, gate)) return;
      const double zs = shape_term(ref, i, def, j) / k.shape;
      const double zv = (std::log(def.volume[j] / ref.volume[i]) - k.volume_mean) / k.volume;
      rows[i].push_back({static_cast<std::uint32_t>(j), zs * zs + zv * zv + d2 / (sigma * sigma)});
    });
  }
  pass.costs.columns = def.size();
  for (auto& r : rows) {
    for (const auto& [j, w] : r) pass.costs.add(j, w);
    pass.costs.end_row();
  }
  pass.assignment = solve_assignment(pass.costs, std::vector<double>(ref.size(), o.lost_cost));
  diag.mean_candidates = ref.size() ? static_cast<double>(pass.costs.column.size()) / ref.size() : 0.0;
  return pass;
}

/// The improved mode one way round. `seed` pairs (if any) start the prediction; otherwise the
/// mutual-best pairs of the paper's criteria do. Each further pass re-seeds from the last assignment.
Matching improved_match(const ScanGrains& ref, const ScanGrains& def, const MatchOptions& o, const Anchors* seed,
                        int passes) {
  Matching m;
  const PointGrid grid(def.centroid, ref.d50);
  Anchors an = seed ? *seed : mutual_best(ref, def, grid, o);
  m.diagnostics.anchors = an.size();
  Pass pass;
  for (int k = 0; k < passes; ++k) {
    pass = assign_pass(ref, def, grid, an, o, m.diagnostics);
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
    double row_sum = std::exp(-(o.lost_cost - ci) / 2.0);
    for (std::size_t e = c.row_start[i]; e < c.row_start[i + 1]; ++e) row_sum += std::exp(-(c.cost[e] - ci) / 2.0);
    const double col_sum = column_sum[static_cast<std::size_t>(m.partner[i])] + std::exp(-(o.lost_cost - ci) / 2.0);
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
