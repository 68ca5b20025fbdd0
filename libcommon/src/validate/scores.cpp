#include "graintwin/validate/scores.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <set>
#include <unordered_map>
#include <utility>

#include "graintwin/contacts/fabric.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/statistics.hpp"
#include "graintwin/micro/clusters.hpp"
#include "graintwin/micro/forces.hpp"
#include "graintwin/micro/local_deformation.hpp"

namespace graintwin::validate {

namespace {
constexpr double kDegrees = 180.0 / std::numbers::pi;

double share(std::size_t part, std::size_t whole) { return whole ? static_cast<double>(part) / static_cast<double>(whole) : kNaN; }

double median_or_nan(const std::vector<double>& v) { return v.empty() ? kNaN : median(v); }

// Mean ranks (1-based), ties sharing their mean rank.
std::vector<double> ranks(const std::vector<double>& v) {
  std::vector<std::size_t> order(v.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return v[a] < v[b]; });
  std::vector<double> r(v.size());
  for (std::size_t i = 0; i < order.size();) {
    std::size_t j = i + 1;
    while (j < order.size() && v[order[j]] == v[order[i]]) ++j;
    const double mean_rank = 0.5 * static_cast<double>(i + j + 1);
    for (std::size_t k = i; k < j; ++k) r[order[k]] = mean_rank;
    i = j;
  }
  return r;
}

std::uint32_t true_of(const std::vector<std::uint32_t>& true_of_label, std::uint32_t label) {
  return label < true_of_label.size() ? true_of_label[label] : 0;
}

std::uint64_t pair_key(std::uint32_t a, std::uint32_t b) {
  return std::uint64_t{std::min(a, b)} << 32 | std::max(a, b);
}

// Linear interpolation of (x, y) sorted by x at `at` (inside [x.front(), x.back()]).
double interpolate(const std::vector<double>& x, const std::vector<double>& y, double at) {
  const auto hi = std::lower_bound(x.begin(), x.end(), at);
  if (hi == x.begin()) return y.front();
  if (hi == x.end()) return y.back();
  const std::size_t k = static_cast<std::size_t>(hi - x.begin());
  const double span = x[k] - x[k - 1];
  return span > 0.0 ? y[k - 1] + (y[k] - y[k - 1]) * (at - x[k - 1]) / span : y[k];
}
}  // namespace

double quantile(std::vector<double> values, double q) {
  if (values.empty()) return kNaN;
  std::sort(values.begin(), values.end());
  const double at = q * static_cast<double>(values.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(at));
  const std::size_t hi = std::min(lo + 1, values.size() - 1);
  return values[lo] + (values[hi] - values[lo]) * (at - static_cast<double>(lo));
}

double spearman(const std::vector<double>& x, const std::vector<double>& y) {
  std::vector<double> a, b;
  for (std::size_t i = 0; i < std::min(x.size(), y.size()); ++i)
    if (std::isfinite(x[i]) && std::isfinite(y[i])) a.push_back(x[i]), b.push_back(y[i]);
  if (a.size() < 3) return kNaN;
  const double r = micro::pearson(ranks(a), ranks(b)).r;
  return std::isfinite(r) ? r : kNaN;
}

segment::VoidRatio true_void_ratio(const Volume<std::uint32_t>& truth_labels, const segment::Cylinder& region) {
  Volume<std::uint8_t> solid(truth_labels.shape(), truth_labels.voxel_size(), truth_labels.origin());
  std::transform(truth_labels.data(), truth_labels.data() + truth_labels.size(), solid.data(),
                 [](std::uint32_t l) { return static_cast<std::uint8_t>(l != 0); });
  return segment::void_ratio(solid, region);
}

SegmentationScore score_segmentation(const MatchResult& m, double void_ratio, double void_ratio_true) {
  SegmentationScore s;
  s.true_grains = m.grains.size();
  s.right = m.matched();
  s.split = m.split();
  s.merged = m.merged();
  s.missed = m.count(LabelOutcome::missed);
  s.boundary = m.count(LabelOutcome::boundary);
  s.labels = m.labels;
  s.spurious = m.spurious;
  s.right_share = share(s.right, s.true_grains);
  s.void_ratio = void_ratio;
  s.void_ratio_true = void_ratio_true;
  return s;
}

ContactScore score_contacts(const std::vector<synth::TrueContact>& truth, const contacts::ContactTable& measured,
                            const std::vector<std::uint32_t>& true_of_label, bool all_contacts) {
  std::vector<bool> faithful;  // by true label
  for (std::uint32_t t : true_of_label) {
    if (t >= faithful.size()) faithful.resize(t + 1, false);
    if (t) faithful[t] = true;
  }
  const auto is_faithful = [&](std::uint32_t t) { return t < faithful.size() && faithful[t]; };
  std::unordered_map<std::uint64_t, std::size_t> true_touching;  // pair of true labels -> row
  std::vector<Vec3> true_normals;
  for (std::size_t k = 0; k < truth.size(); ++k) {
    if (!truth[k].touching) continue;
    true_normals.push_back({truth[k].normal.x(), truth[k].normal.y(), truth[k].normal.z()});
    if (is_faithful(truth[k].low) && is_faithful(truth[k].high)) true_touching.emplace(pair_key(truth[k].low, truth[k].high), k);
  }
  ContactScore s;
  s.true_touching = true_touching.size();
  std::set<std::uint64_t> found_pairs;
  std::vector<Vec3> found_normals;
  for (std::size_t k = 0; k < measured.size(); ++k) {
    if (!all_contacts && !measured.accepted[k]) continue;
    const std::uint32_t a = true_of(true_of_label, measured.pair[2 * k]), b = true_of(true_of_label, measured.pair[2 * k + 1]);
    if (!a || !b) continue;
    const auto it = true_touching.find(pair_key(a, b));
    if (it == true_touching.end()) {
      ++s.false_found;
      continue;
    }
    if (!found_pairs.insert(it->first).second) continue;  // two labels of one true pair cannot both be faithful
    // The measured normal points from label low to label high; the true one from true low to high.
    const Vec3& m = measured.normal[k];
    const Eigen::Vector3d n = (a < b ? 1.0 : -1.0) * Eigen::Vector3d(m[0], m[1], m[2]).normalized();
    const double cosine = std::clamp(n.dot(truth[it->second].normal.normalized()), -1.0, 1.0);
    s.normal_error_deg.push_back(std::acos(cosine) * kDegrees);
    found_normals.push_back({n.x(), n.y(), n.z()});
  }
  s.found = found_pairs.size();
  s.missed = s.true_touching - s.found;
  s.found_share = share(s.found, s.true_touching);
  s.normal_error_median_deg = median_or_nan(s.normal_error_deg);
  s.normal_error_p90_deg = quantile(s.normal_error_deg, 0.9);
  s.anisotropy = contacts::fabric_tensor(found_normals).anisotropy;
  s.anisotropy_true = contacts::fabric_tensor(true_normals).anisotropy;
  return s;
}

ShapeScore score_shapes(const synth::GroundTruth& truth, const std::vector<shape::GrainShape>& grains,
                        const std::vector<std::uint32_t>& true_of_label) {
  ShapeScore s;
  std::vector<std::vector<double>> by_degree;
  std::vector<double> shape_errors, diameter_errors;
  for (const shape::GrainShape& g : grains) {
    const std::uint32_t t = true_of(true_of_label, g.label);
    if (!t || t > truth.volume.size()) continue;
    ++s.grains;
    const Eigen::VectorXd true_invariants = truth.sh_invariants.row(t - 1).transpose();
    const int degree = std::min({g.sh_degree, static_cast<int>(g.invariants.size()) - 1, static_cast<int>(true_invariants.size()) - 1});
    if (static_cast<int>(by_degree.size()) < degree + 1) by_degree.resize(static_cast<std::size_t>(degree + 1));
    for (int n = 0; n <= degree; ++n) {
      if (!(true_invariants[n] > 0.0)) continue;
      const double e = std::abs(g.invariants[n] / true_invariants[n] - 1.0);
      by_degree[static_cast<std::size_t>(n)].push_back(e);
      if (n >= 2) shape_errors.push_back(e);
    }
    const double v_true = truth.volume[t - 1];
    s.volume_error.push_back(g.volume / v_true - 1.0);
    diameter_errors.push_back(std::cbrt(g.volume / v_true) - 1.0);  // d / d_true = (V / V_true)^(1/3)
  }
  for (const auto& e : by_degree) s.invariant_error_by_degree.push_back(median_or_nan(e));
  s.invariant_error_median = median_or_nan(shape_errors);
  s.volume_error_median = median_or_nan(s.volume_error);
  s.diameter_error_median = median_or_nan(diameter_errors);
  return s;
}

TrackingScore score_tracking(const track::TracksTable& tracks, std::size_t from, std::size_t to,
                             const std::vector<std::uint32_t>& true_of_label_from,
                             const std::vector<std::uint32_t>& true_of_label_to, const synth::GroundTruth& truth_from,
                             const synth::GroundTruth& truth_to) {
  if (from >= tracks.scans || to >= tracks.scans) throw UsageError("score_tracking: the tracks do not hold those scans");
  TrackingScore s;
  s.from = from, s.to = to;
  // The label of each true grain in `to` (0: not faithfully segmented there).
  std::vector<std::uint32_t> label_to(truth_to.poses.size() + 1, 0);
  for (std::uint32_t l = 1; l < true_of_label_to.size(); ++l)
    if (true_of_label_to[l] && true_of_label_to[l] < label_to.size()) label_to[true_of_label_to[l]] = l;
  // The track holding each label of `from`.
  std::unordered_map<std::uint32_t, std::size_t> track_of;
  for (std::size_t i = 0; i < tracks.tracks; ++i)
    if (const std::uint32_t l = tracks.label[i * tracks.scans + from]) track_of.emplace(l, i);
  std::vector<double> relative;
  for (std::uint32_t a = 1; a < true_of_label_from.size(); ++a) {
    const std::uint32_t g = true_of_label_from[a];
    if (!g || g >= label_to.size() || !label_to[g]) continue;
    ++s.targets;
    const auto it = track_of.find(a);
    const std::uint32_t c = it == track_of.end() ? 0 : tracks.label[it->second * tracks.scans + to];
    if (c == 0) {
      ++s.lost;
      continue;
    }
    if (c != label_to[g]) {
      ++s.wrong;
      continue;
    }
    ++s.right;
    const std::size_t i = it->second;
    const auto at = [&](const std::vector<double>& v, std::size_t scan, int width) { return &v[(i * tracks.scans + scan) * width]; };
    const Eigen::Vector3d u = Eigen::Map<const Eigen::Vector3d>(at(tracks.centroid, to, 3)) -
                              Eigen::Map<const Eigen::Vector3d>(at(tracks.centroid, from, 3));
    const Eigen::Vector3d u_true = truth_to.poses[g - 1].position - truth_from.poses[g - 1].position;
    s.displacement_error_m.push_back((u - u_true).norm());
    if (u_true.norm() > 0.0) relative.push_back((u - u_true).norm() / u_true.norm());
    // rotation_step of scan `to` is the rotation from the scan before it, which is `from` for consecutive scans.
    if (to == from + 1 && tracks.rotation_defined[i * tracks.scans + to]) {
      const double* q = at(tracks.rotation_step, to, 4);
      const Eigen::Quaterniond step(q[0], q[1], q[2], q[3]);
      const Eigen::Quaterniond true_step =
          truth_to.poses[g - 1].orientation.normalized() * truth_from.poses[g - 1].orientation.normalized().conjugate();
      s.rotation_error_deg.push_back(true_step.angularDistance(step.normalized()) * kDegrees);
    }
  }
  s.displacement_error_median_m = median_or_nan(s.displacement_error_m);
  s.displacement_error_p90_m = quantile(s.displacement_error_m, 0.9);
  s.displacement_error_rel_median = median_or_nan(relative);
  s.rotation_error_median_deg = median_or_nan(s.rotation_error_deg);
  s.rotation_error_p90_deg = quantile(s.rotation_error_deg, 0.9);
  return s;
}

MicroParameters micro_parameters(const std::string& parameters_json, const std::string& name) {
  const nlohmann::json p = nlohmann::json::parse(parameters_json, nullptr, false);
  const auto number = [&](const char* key) {
    if (!p.is_object() || !p.contains(key) || !p[key].is_number())
      throw DataError(name + ": its parameters JSON has no number " + key + "; rewrite it with tracks2micro");
    return p[key].get<double>();
  };
  MicroParameters m;
  m.radius_d50 = number("radius_d50");
  m.min_neighbours = static_cast<std::size_t>(number("min_neighbours"));
  m.top_fraction = number("top_fraction");
  m.contact_factor = number("contact_factor");
  return m;
}

TrueDeformation true_deformation(const synth::GroundTruth& from, const synth::GroundTruth& to, const MicroParameters& p) {
  const std::size_t n = from.poses.size();
  if (to.poses.size() != n) throw DataError("the truth files of one series differ in their grain counts; rewrite the series with ctsynth");
  std::vector<Eigen::Vector3d> before(n), after(n);
  for (std::size_t i = 0; i < n; ++i) before[i] = from.poses[i].position, after[i] = to.poses[i].position;
  micro::DeformationOptions d;
  d.d50 = d50_of_volumes(from.volume);
  d.radius = p.radius_d50 * d.d50;
  d.min_neighbours = p.min_neighbours;
  TrueDeformation t;
  t.grains = micro::local_deformation(before, after, d);
  std::vector<double> d2min(n);
  for (std::size_t i = 0; i < n; ++i) d2min[i] = t.grains[i].d2min;
  micro::ClusterOptions c;
  c.top_fraction = p.top_fraction;
  c.link_factor = p.contact_factor;
  t.cluster = micro::cluster_statistics(d2min, before, from.volume, c).cluster;
  return t;
}

DeformationScore score_deformation(const micro::MicroTables& run, std::size_t k, const TrueDeformation& truth,
                                   const std::vector<std::uint32_t>& true_of_label_from,
                                   const std::vector<std::uint32_t>& true_of_label_to) {
  if (k >= run.increments.size()) throw UsageError("score_deformation: the micro tables have no such increment");
  DeformationScore s;
  s.from = run.increments[k].from, s.to = run.increments[k].to;
  const std::size_t states = run.states.size(), increments = run.increments.size();
  std::vector<double> eps_q, eps_q_true;
  std::set<std::uint32_t> members, members_true, tracked;
  for (std::size_t i = 0; i < run.grains; ++i) {
    const std::uint32_t g = true_of(true_of_label_from, run.grain_label[i * states + s.from]);
    if (!g || g > truth.grains.size() || true_of(true_of_label_to, run.grain_label[i * states + s.to]) != g) continue;
    tracked.insert(g);
    if (run.grain_cluster[i * increments + k] >= 0) members.insert(g);
    if (truth.cluster[g - 1] >= 0) members_true.insert(g);
    const double d2 = run.grain_d2min[i * increments + k];
    const micro::LocalDeformation& t = truth.grains[g - 1];
    if (!std::isfinite(d2) || t.status != micro::DeformationStatus::ok) continue;
    s.d2min.push_back(d2), s.d2min_true.push_back(t.d2min);
    eps_q.push_back(run.grain_eps_q[i * increments + k]), eps_q_true.push_back(t.eps_q);
  }
  s.grains = s.d2min.size();
  s.d2min_spearman = spearman(s.d2min, s.d2min_true);
  s.eps_q_spearman = spearman(eps_q, eps_q_true);
  s.cluster_members = members.size();
  s.cluster_members_true = members_true.size();
  for (std::uint32_t g : members) s.cluster_common += members_true.count(g);
  s.cluster_jaccard = share(s.cluster_common, s.cluster_members + s.cluster_members_true - s.cluster_common);
  return s;
}

TwinScore score_twin(const synth::LoadingCurve& truth, const fdem::TriaxialSeries& simulation) {
  TwinScore s;
  s.simulated = !truth.axial_strain.empty();
  if (!s.simulated) return s;
  // The simulation's shearing rows, by axial strain.
  std::vector<std::size_t> rows;
  for (std::size_t r = 0; r < simulation.axial_strain.size(); ++r)
    if (std::isfinite(simulation.axial_strain[r]) && std::isfinite(simulation.stress_ratio[r]) &&
        std::isfinite(simulation.volumetric_strain[r]))
      rows.push_back(r);
  if (rows.size() < 2) return s;
  std::stable_sort(rows.begin(), rows.end(), [&](std::size_t a, std::size_t b) { return simulation.axial_strain[a] < simulation.axial_strain[b]; });
  std::vector<double> x, q, ev;
  for (std::size_t r : rows)
    x.push_back(simulation.axial_strain[r]), q.push_back(simulation.stress_ratio[r]), ev.push_back(simulation.volumetric_strain[r]);
  const auto [lo, hi] = std::minmax_element(truth.axial_strain.begin(), truth.axial_strain.end());
  const double start = std::max(*lo, x.front()), end = std::min(*hi, x.back());
  double sum = 0.0, largest = 0.0;
  for (std::size_t k = 0; k < truth.axial_strain.size(); ++k) {
    const double e = truth.axial_strain[k];
    if (e < start || e > end || !(truth.stress_ratio[k] != 0.0)) continue;
    const double q_sim = interpolate(x, q, e), ev_sim = interpolate(x, ev, e);
    s.axial_strain.push_back(e);
    s.stress_ratio_true.push_back(truth.stress_ratio[k]), s.stress_ratio.push_back(q_sim);
    s.volumetric_strain_true.push_back(truth.volumetric_strain[k]), s.volumetric_strain.push_back(ev_sim);
    const double rel = (q_sim - truth.stress_ratio[k]) / truth.stress_ratio[k];
    sum += rel * rel;
    largest = std::max(largest, std::abs(ev_sim - truth.volumetric_strain[k]));
  }
  if (s.axial_strain.empty()) return s;
  s.stress_ratio_rms_rel = std::sqrt(sum / static_cast<double>(s.axial_strain.size()));
  s.volumetric_strain_max_abs = largest;
  s.axial_strain_max = end;
  return s;
}

}  // namespace graintwin::validate
