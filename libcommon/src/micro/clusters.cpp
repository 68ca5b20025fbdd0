#include "graintwin/micro/clusters.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>

#include "graintwin/core/error.hpp"
#include "graintwin/core/geometry.hpp"
#include "graintwin/core/point_grid.hpp"

namespace graintwin::micro {

std::vector<std::size_t> top_fraction(const std::vector<double>& score, double fraction) {
  if (!(fraction > 0.0 && fraction <= 1.0)) throw UsageError("top_fraction: the fraction must be in (0, 1]");
  std::vector<double> finite;
  for (double s : score)
    if (std::isfinite(s)) finite.push_back(s);
  if (finite.empty()) return {};
  const std::size_t k = std::max<std::size_t>(1, std::size_t(std::floor(fraction * double(finite.size()))));
  std::nth_element(finite.begin(), finite.begin() + std::ptrdiff_t(finite.size() - k), finite.end());
  const double threshold = finite[finite.size() - k];
  std::vector<std::size_t> out;
  for (std::size_t i = 0; i < score.size(); ++i)
    if (std::isfinite(score[i]) && score[i] >= threshold) out.push_back(i);
  return out;
}

std::vector<std::pair<std::size_t, std::size_t>> contact_links(const std::vector<Eigen::Vector3d>& positions,
                                                               const std::vector<double>& radii,
                                                               const std::vector<std::size_t>& members,
                                                               double link_factor) {
  if (positions.size() != radii.size()) throw UsageError("contact_links: positions and radii differ in length");
  std::vector<std::pair<std::size_t, std::size_t>> links;
  if (members.empty()) return links;
  std::vector<Eigen::Vector3d> pts;
  double r_max = 0.0;
  for (std::size_t m : members) pts.push_back(positions[m]), r_max = std::max(r_max, radii[m]);
  if (!(r_max > 0.0)) return links;
  const PointGrid grid(pts, 2.0 * link_factor * r_max);
  for (std::size_t a = 0; a < members.size(); ++a) {
    const std::size_t i = members[a];
    grid.for_each_within(pts[a], link_factor * (radii[i] + r_max), [&](std::size_t b, double d2) {
      const std::size_t j = members[b];
      const double reach = link_factor * (radii[i] + radii[j]);
      if (b > a && d2 <= reach * reach) links.emplace_back(std::min(i, j), std::max(i, j));
    });
  }
  std::sort(links.begin(), links.end());
  return links;
}

std::vector<std::uint32_t> connected_components(std::size_t n, const std::vector<std::pair<std::size_t, std::size_t>>& links) {
  std::vector<std::size_t> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  const auto find = [&](std::size_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (auto [a, b] : links) {
    if (a >= n || b >= n) throw UsageError("connected_components: a link names a node out of range");
    const std::size_t ra = find(a), rb = find(b);
    if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);  // the root stays the smallest node
  }
  std::vector<std::uint32_t> id(n), root_id(n, std::numeric_limits<std::uint32_t>::max());
  std::uint32_t next = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t r = find(i);
    if (root_id[r] == std::numeric_limits<std::uint32_t>::max()) root_id[r] = next++;
    id[i] = root_id[r];
  }
  return id;
}

double radius_of_gyration(const std::vector<Eigen::Vector3d>& positions, const std::vector<double>& volumes) {
  if (positions.size() != volumes.size() || positions.empty())
    throw UsageError("radius_of_gyration: needs one volume per position and at least one grain");
  double w = 0.0;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < positions.size(); ++i) w += volumes[i], c += volumes[i] * positions[i];
  if (!(w > 0.0)) throw DataError("radius_of_gyration: the grains' volumes sum to zero");
  c /= w;
  double s = 0.0;
  for (std::size_t i = 0; i < positions.size(); ++i) s += volumes[i] * (positions[i] - c).squaredNorm();
  return std::sqrt(s / w);
}

ClusterStatistics cluster_statistics(const std::vector<double>& score, const std::vector<Eigen::Vector3d>& positions,
                                     const std::vector<double>& volumes, const ClusterOptions& o) {
  const std::size_t n = score.size();
  if (positions.size() != n || volumes.size() != n) throw UsageError("cluster_statistics: score, positions and volumes differ in length");
  ClusterStatistics st;
  st.cluster.assign(n, -1);
  const std::vector<std::size_t> top = top_fraction(score, o.top_fraction);
  st.selected = top.size();
  st.fractal_dimension = st.fractal_dimension_error = std::numeric_limits<double>::quiet_NaN();
  if (top.empty()) return st;
  st.threshold = std::numeric_limits<double>::infinity();
  for (std::size_t i : top) st.threshold = std::min(st.threshold, score[i]);
  std::vector<double> radii(n);
  for (std::size_t i = 0; i < n; ++i) radii[i] = equivalent_radius(volumes[i]);
  // Links in member numbering, for the components.
  std::vector<std::size_t> member_of(n, 0);
  for (std::size_t a = 0; a < top.size(); ++a) member_of[top[a]] = a;
  auto links = contact_links(positions, radii, top, o.link_factor);
  for (auto& [a, b] : links) a = member_of[a], b = member_of[b];
  const std::vector<std::uint32_t> comp = connected_components(top.size(), links);
  const std::size_t clusters = comp.empty() ? 0 : *std::max_element(comp.begin(), comp.end()) + 1;
  std::vector<std::vector<Eigen::Vector3d>> pos(clusters);
  std::vector<std::vector<double>> vol(clusters);
  for (std::size_t a = 0; a < top.size(); ++a) {
    st.cluster[top[a]] = std::int32_t(comp[a]);
    pos[comp[a]].push_back(positions[top[a]]);
    vol[comp[a]].push_back(volumes[top[a]]);
  }
  std::vector<double> sizes, log_s, log_rg;
  for (std::size_t c = 0; c < clusters; ++c) {
    st.size.push_back(std::uint32_t(pos[c].size()));
    st.radius_of_gyration.push_back(radius_of_gyration(pos[c], vol[c]));
    sizes.push_back(double(pos[c].size()));
    if (pos[c].size() >= 2 && st.radius_of_gyration.back() > 0.0)
      log_s.push_back(std::log10(sizes.back())), log_rg.push_back(std::log10(st.radius_of_gyration.back()));
  }
  st.size_fit = fit_power_law(sizes, true, o.min_tail);
  st.rg_fit = fit_line(log_s, log_rg);
  if (st.rg_fit.valid && st.rg_fit.slope > 0.0) {
    st.fractal_dimension = 1.0 / st.rg_fit.slope;
    st.fractal_dimension_error = st.rg_fit.slope_error / (st.rg_fit.slope * st.rg_fit.slope);
  }
  return st;
}

}  // namespace graintwin::micro
