#include "graintwin/micro/analysis.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "graintwin/core/error.hpp"
#include "graintwin/core/geometry.hpp"

namespace graintwin::micro {

std::vector<std::pair<std::size_t, std::size_t>> consecutive_increments(std::size_t states) {
  std::vector<std::pair<std::size_t, std::size_t>> inc;
  for (std::size_t t = 1; t < states; ++t) inc.emplace_back(t - 1, t);
  return inc;
}

namespace {

std::vector<Eigen::Vector3d> state_positions(const SeriesStates& s, std::size_t t) {
  std::vector<Eigen::Vector3d> p(s.grains);
  for (std::size_t i = 0; i < s.grains; ++i) p[i] = s.position[i * s.states + t];
  return p;
}

std::vector<double> state_volumes(const SeriesStates& s, std::size_t t) {
  std::vector<double> v(s.grains);
  for (std::size_t i = 0; i < s.grains; ++i) v[i] = s.volume[i * s.states + t];
  return v;
}

IncrementResult analyse_increment(const SeriesStates& s, std::size_t from, std::size_t to, const MicroOptions& o) {
  IncrementResult r;
  r.from = from, r.to = to, r.d50 = s.d50[from];
  const auto before = state_positions(s, from), after = state_positions(s, to);
  DeformationOptions d;
  d.d50 = r.d50;
  d.radius = o.radius_d50 * r.d50;
  d.min_neighbours = o.min_neighbours;
  d.min_conditioning = o.min_conditioning;
  r.grains = local_deformation(before, after, d);
  std::vector<double> d2min(s.grains), eps_q(s.grains);
  for (std::size_t i = 0; i < s.grains; ++i) d2min[i] = r.grains[i].d2min, eps_q[i] = r.grains[i].eps_q;
  r.pdf_d2min = log_histogram_auto(d2min, o.pdf_per_decade);
  r.pdf_eps_q = log_histogram_auto(eps_q, o.pdf_per_decade);
  // Clusters: the volume in the first state weighs R_g; grains without one cannot be weighed.
  const auto volume = state_volumes(s, from);
  for (std::size_t i = 0; i < s.grains; ++i)
    if (!(volume[i] > 0.0)) d2min[i] = std::nan("");
  r.clusters = cluster_statistics(d2min, before, volume, o.clusters);
  std::vector<Eigen::Vector3d> increment(s.grains);
  double largest = 0.0;
  for (std::size_t i = 0; i < s.grains; ++i) {
    increment[i] = after[i] - before[i];
    if (increment[i].allFinite()) largest = std::max(largest, increment[i].cwiseAbs().maxCoeff() / r.d50);
  }
  const double range = o.displacement_range_d50 > 0.0 ? o.displacement_range_d50 : (largest > 0.0 ? largest : 1.0);
  r.displacement = displacement_distributions(increment, r.d50, range, o.displacement_bins);
  return r;
}

StateResult analyse_state(const SeriesStates& s, std::size_t t, const MicroOptions& o) {
  StateResult r;
  const auto p = state_positions(s, t);
  r.region = enclosing_region(p, o.region);
  r.rdf = pair_correlation(p, r.region, o.rdf_max_d50 * s.d50[t], o.rdf_bins);
  if (!s.coordination.empty() && !s.coordination[t].empty()) {
    r.coordination = s.coordination[t];
    r.coordination_from_contacts = true;
  } else {
    const auto v = state_volumes(s, t);
    std::vector<double> radii(s.grains);
    for (std::size_t i = 0; i < s.grains; ++i) radii[i] = v[i] > 0.0 ? equivalent_radius(v[i]) : 0.0;
    r.coordination = coordination_by_distance(p, radii, o.contact_factor);
  }
  std::vector<std::uint32_t> present;
  for (std::size_t i = 0; i < s.grains; ++i)
    if (p[i].allFinite()) present.push_back(r.coordination[i]);
  r.coordination_distribution = coordination_distribution(present);
  return r;
}

}  // namespace

MicroResult analyse_series(const SeriesStates& s, const std::vector<std::pair<std::size_t, std::size_t>>& increments,
                           const MicroOptions& o, const std::function<void(double)>& progress) {
  const std::size_t cells = s.grains * s.states;
  if (s.position.size() != cells || s.volume.size() != cells || s.d50.size() != s.states)
    throw UsageError("analyse_series: positions, volumes and d50 do not match " + std::to_string(s.grains) + " grains x " +
                     std::to_string(s.states) + " states");
  if (!s.coordination.empty() && s.coordination.size() != s.states)
    throw UsageError("analyse_series: coordination numbers must be given for every state or none");
  for (std::size_t t = 0; t < s.coordination.size(); ++t)
    if (!s.coordination[t].empty() && s.coordination[t].size() != s.grains)
      throw UsageError("analyse_series: coordination numbers of state " + std::to_string(t) + " do not cover every grain");
  for (double d : s.d50)
    if (!(d > 0.0)) throw DataError("a state has no positive d50; its shapes file holds no size distribution");
  for (auto [a, b] : increments)
    if (a >= s.states || b >= s.states || a == b)
      throw UsageError("increment " + std::to_string(a) + " -> " + std::to_string(b) + " needs two different states among 0.." +
                       std::to_string(s.states - 1));
  MicroResult r;
  const double steps = double(increments.size() + s.states);
  for (std::size_t k = 0; k < increments.size(); ++k) {
    r.increments.push_back(analyse_increment(s, increments[k].first, increments[k].second, o));
    if (progress) progress(double(k + 1) / steps);
  }
  for (std::size_t t = 0; t < s.states; ++t) {
    r.states.push_back(analyse_state(s, t, o));
    if (progress) progress(double(increments.size() + t + 1) / steps);
  }
  return r;
}

}  // namespace graintwin::micro
