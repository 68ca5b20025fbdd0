// The contact model's boundaries: the triaxial test's cylinder wall and the membrane's balls (with
// their own hash grid over the grains' boxes).
#include <fmt/format.h>

#include <numbers>
#include <unordered_map>

#include "contact_state.hpp"
#include "graintwin/core/error.hpp"

namespace graintwin::fdem {

BoundaryContactStats wall_contact_stats(std::span<const WallContactSum> grains) {
  BoundaryContactStats stats;
  for (const WallContactSum& g : grains) {
    stats.contacts += g.contacts;
    stats.radial_force += g.radial_force;
    stats.radial_stiffness += g.radial_stiffness;
    stats.elastic_energy += g.elastic_energy;
    stats.dissipated += g.dissipated;
  }
  return stats;
}

BoundaryContactStats add_ball_contacts(std::span<const BallContact> contacts, std::span<Eigen::Vector3d> ball_force,
                                       std::span<Eigen::Vector3d> ball_moment) {
  BoundaryContactStats stats;
  for (const BallContact& c : contacts) {
    if (c.ball >= ball_force.size() || c.ball >= ball_moment.size())
      throw DataError(fmt::format("a contact of membrane ball {} came for a membrane of {} balls; the ranks must run the "
                                  "same membrane",
                                  c.ball, ball_force.size()));
    ball_force[c.ball] += c.force;
    ball_moment[c.ball] += c.moment;
    stats.elastic_energy += c.elastic_energy;
    stats.dissipated += c.dissipated;
    stats.max_overlap = std::max(stats.max_overlap, c.overlap);
    ++stats.contacts;
  }
  return stats;
}

std::span<const WallContactSum> ContactModel::add_wall_forces(std::span<const Eigen::Vector3d> x,
                                                              std::span<const Eigen::Vector3d> v,
                                                              const CylinderWallState& wall, double dt,
                                                              std::span<Eigen::Vector3d> f) {
  State& s = *state_;
  const auto grain_count = static_cast<std::int64_t>(s.grains.size());
  s.wall_hits.resize(s.grains.size());
#pragma omp parallel for schedule(dynamic, 16) if (grain_count >= static_cast<std::int64_t>(kParallelGrains))
  for (std::int64_t g = 0; g < grain_count; ++g) {
    std::vector<WallHit>& hits = s.wall_hits[g];
    hits.clear();
    if (!s.owned(static_cast<std::uint32_t>(g))) continue;  // its owner's rank pushes it
    const Aabb& box = s.trees.bounds(static_cast<std::size_t>(g));
    if (!(box.lo.array() <= box.hi.array()).all()) continue;
    // The box corner farthest from the axis, and the bounding sphere, decide whether the wall can
    // touch the grain.
    const double fx = std::max(std::abs(box.lo.x() - wall.axis_xy.x()), std::abs(box.hi.x() - wall.axis_xy.x()));
    const double fy = std::max(std::abs(box.lo.y() - wall.axis_xy.y()), std::abs(box.hi.y() - wall.axis_xy.y()));
    if (fx * fx + fy * fy <= wall.radius * wall.radius) continue;
    if ((s.sphere_centre[g].head<2>() - wall.axis_xy).norm() + s.sphere_radius[g] <= wall.radius) continue;
    const Material& m = s.material_of(static_cast<std::uint32_t>(g));
    const auto grain = static_cast<std::uint32_t>(g);
    for (std::uint32_t node : s.surface(grain)) {
      const auto [p, arm] = s.place(node, grain, x);
      const Eigen::Vector3d radial(p.x() - wall.axis_xy.x(), p.y() - wall.axis_xy.y(), 0.0);
      const double rho = radial.norm();
      if (!(rho > wall.radius)) continue;
      const Eigen::Vector3d outward = radial / rho;
      const double area = s.facing_area(node, -outward, x, s.pose[g]);
      if (!(area > 0)) continue;
      const ContactLaw law = contact_law(m.normal_penalty, m.tangential_penalty, area, s.node_mass[node], m.damping_ratio, 0.0);
      hits.push_back({node, arm, node_contact_force(law, -outward, rho - wall.radius,
                                                    s.velocity(node, grain, v) - wall.radial_velocity * outward,
                                                    Eigen::Vector3d::Zero(), dt)});
    }
  }
  s.wall_sums.clear();
  for (std::uint32_t g = 0; g < grain_count; ++g) {
    if (s.wall_hits[g].empty()) continue;
    WallContactSum sum{g};
    for (const auto& [node, arm, law] : s.wall_hits[g]) {
      if (s.pose[g].rigid) s.loads[g].add(arm, law.force);
      else f[node] += law.force;
      s.record(node, kNoTriangle, Eigen::Vector3d::Zero(), law.force);
      sum.radial_force += law.normal_force;
      sum.radial_stiffness += law.normal_stiffness;
      sum.elastic_energy += law.elastic_energy;
      sum.dissipated += law.dissipated;
      ++sum.contacts;
    }
    s.wall_sums.push_back(sum);
  }
  return s.wall_sums;
}

std::span<const BallContact> ContactModel::add_ball_forces(std::span<const Eigen::Vector3d> x,
                                                           std::span<const Eigen::Vector3d> v,
                                                           std::span<const Eigen::Vector3d> centres,
                                                           std::span<const Eigen::Vector3d> ball_velocity,
                                                           std::span<const Eigen::Vector3d> ball_spin,
                                                           const BallContactOptions& balls, double dt,
                                                           std::span<Eigen::Vector3d> f) {
  State& s = *state_;
  const std::size_t n = centres.size();
  if (ball_velocity.size() != n || ball_spin.size() != n)
    throw DataError("fdem contact: ball positions, velocities and spins must have one entry per ball");
  if (!(balls.radius > 0) || !(balls.mass > 0)) throw UsageError("membrane balls need a positive radius and mass");
  const double r = balls.radius;
  const double moved2 = 0.25 * s.skin * s.skin;
  bool stale = s.ball_lists_rebuilds != s.rebuilds || s.ball_lists_radius != r || s.ball_built_at.size() != n;
  for (std::size_t b = 0; b < n && !stale; ++b) stale = (centres[b] - s.ball_built_at[b]).squaredNorm() > moved2;
  if (stale) s.build_ball_lists(centres, r);
  // A ball's history is found once, then each of its grains searches only the ball's few entries.
  const auto history_of = [&](std::uint32_t ball) -> std::span<const BallHistoryEntry> {
    const auto first = std::lower_bound(s.ball_history.begin(), s.ball_history.end(), ball,
                                        [](const BallHistoryEntry& h, std::uint32_t k) { return h.ball < k; });
    auto last = first;
    while (last != s.ball_history.end() && last->ball == ball) ++last;
    return {first, last};
  };
  const auto spring_of = [](std::span<const BallHistoryEntry> past, std::uint32_t grain) -> Eigen::Vector3d {
    const auto it = std::lower_bound(past.begin(), past.end(), grain,
                                     [](const BallHistoryEntry& h, std::uint32_t g) { return h.grain < g; });
    return it != past.end() && it->grain == grain ? it->spring : Eigen::Vector3d::Zero();
  };
  const double area = std::numbers::pi * r * r;
  if (s.ball_hits.size() < n) s.ball_hits.resize(n);
#pragma omp parallel for schedule(dynamic, 64) if (n >= kParallelNodes / 4)
  for (std::int64_t b = 0; b < static_cast<std::int64_t>(n); ++b) {
    std::vector<BallHit>& out = s.ball_hits[b];
    out.clear();
    const Eigen::Vector3d& c = centres[b];
    const std::span<const BallHistoryEntry> past = history_of(static_cast<std::uint32_t>(b));
    for (BallCandidate& candidate : s.ball_candidates[b]) {
      const std::uint32_t g = candidate.grain;
      if (!s.owned(g) || !s.trees.bounds(g).inflated(r).contains(c)) continue;  // another rank's grain: its owner's
      SurfaceTrees::Nearest near;
      if (!s.ball_nearest(candidate, c, r + s.max_penetration, r, x, near)) continue;
      const Eigen::Vector3d d = near.closest.point - c;  // from the centre to the surface
      const double dist = std::sqrt(near.distance2);
      const bool inside = d.dot(s.pseudonormal(near.triangle, near.closest.feature, x)) > 0;
      BallHit hit;
      hit.overlap = inside ? r + dist : r - dist;
      if (!(hit.overlap > 0)) continue;
      const Eigen::Vector3d face = s.normal_of(near.triangle, x).normalized();
      hit.normal = dist > 1e-12 * r ? Eigen::Vector3d((inside ? 1.0 : -1.0) * d / dist) : face;
      const Eigen::Vector3d w = near.closest.weights;
      Eigen::Vector3d surface_velocity = s.surface_velocity(near.triangle, w, v);
      // On an implicit grain the ball presses its footprint: its force on one triangle's corners
      // against the grain's quasi-static local give made the explicit contact unstable.
      std::vector<std::pair<std::uint32_t, double>> spread;
      if (s.pose[g].framed) {
        s.ball_footprint(near.triangle, near.closest.point, r, x, spread);
        if (!spread.empty()) {
          surface_velocity.setZero();
          for (const auto& [node, share] : spread) surface_velocity += share * v[node];
        }
      }
      const Eigen::Vector3d contact_velocity = ball_velocity[b] + ball_spin[b].cross(-r * hit.normal);
      const Material& m = s.material_of(g);
      hit.law = node_contact_force(contact_law(m.normal_penalty, m.tangential_penalty, area, balls.mass, m.damping_ratio,
                                               balls.friction),
                                   hit.normal, hit.overlap, contact_velocity - surface_velocity,
                                   spring_of(past, g), dt);
      hit.grain = g;
      hit.triangle = near.triangle;
      hit.weights = w;
      hit.spread = std::move(spread);
      out.push_back(std::move(hit));
    }
    std::sort(out.begin(), out.end(), [](const BallHit& p, const BallHit& q) { return p.grain < q.grain; });
  }
  s.ball_contacts.clear();
  for (std::uint32_t b = 0; b < n; ++b)
    for (const BallHit& h : s.ball_hits[b]) {
      const Eigen::Vector3d& force = h.law.force;
      if (s.pose[h.grain].rigid) {
        s.loads[h.grain].add(s.surface_arm(h.triangle, h.weights), -force);
        s.record(kNoNode, h.triangle, h.weights, force);
      } else if (!h.spread.empty()) {
        for (const auto& [node, share] : h.spread) f[node] -= share * force;
        if (s.record_node_forces)
          for (const auto& [node, share] : h.spread) s.node_forces[node] -= share * force;
      } else {
        const auto& tri = s.triangles[h.triangle];
        for (int k = 0; k < 3; ++k) f[tri[k]] -= h.weights[k] * force;
        s.record(kNoNode, h.triangle, h.weights, force);
      }
      s.ball_contacts.push_back({b, h.grain, force, (-r * h.normal).cross(force - h.law.normal_force * h.normal),
                                 h.law.spring, h.law.elastic_energy, h.law.dissipated, h.overlap});
    }
  set_ball_history(s.ball_contacts);
  return s.ball_contacts;
}

void ContactModel::State::ball_footprint(std::uint32_t t, const Eigen::Vector3d& at, double radius,
                                         std::span<const Eigen::Vector3d> x,
                                         std::vector<std::pair<std::uint32_t, double>>& out) const {
  out.clear();
  // Triangles reached over the surface from t while one of their corners lies within the radius.
  std::vector<std::uint32_t> reached{t};
  const auto within = [&](std::uint32_t node) { return (x[node] - at).squaredNorm() < radius * radius; };
  for (std::size_t k = 0; k < reached.size(); ++k) {
    const auto& corners = triangles[reached[k]];
    if (!within(corners[0]) && !within(corners[1]) && !within(corners[2])) continue;
    for (int e = 0; e < 3; ++e) {
      const std::uint32_t across = neighbour[reached[k]][e];
      if (across != kNoTriangle && std::find(reached.begin(), reached.end(), across) == reached.end()) reached.push_back(across);
    }
    for (std::uint32_t node : corners)
      if (within(node) && std::none_of(out.begin(), out.end(), [&](const auto& o) { return o.first == node; }))
        out.emplace_back(node, 0.0);
  }
  double total = 0;
  for (auto& [node, share] : out) {
    double area = 0;
    for (std::uint32_t k = node_triangle_offset[node]; k < node_triangle_offset[node + 1]; ++k) area += triangle_area[node_triangles[k]] / 3;
    share = area * (1 - (x[node] - at).norm() / radius);
    total += share;
  }
  if (!(total > 0)) {
    out.clear();
    return;
  }
  for (auto& [node, share] : out) share /= total;
  std::sort(out.begin(), out.end());
}

void ContactModel::set_ball_history(std::span<const BallContact> contacts) {
  State& s = *state_;
  s.ball_history.clear();
  for (const BallContact& c : contacts) {
    if (c.grain >= s.grains.size())
      throw DataError(fmt::format("a membrane ball's contact names grain {} of a model of {} grains; the ranks must run "
                                  "the same model",
                                  c.grain, s.grains.size()));
    s.ball_history.push_back({c.ball, c.grain, c.spring});
  }
}

void ContactModel::State::build_ball_lists(std::span<const Eigen::Vector3d> centres, double radius) {
  // The grains' boxes, grown by the reach, in a hash grid of cells as large as the largest grown
  // box, so a box spans at most 8 cells and a ball looks in one.
  const double reach = radius + skin;
  double cell = 0;
  for (std::size_t g = 0; g < grains.size(); ++g) {
    const Aabb& box = trees.bounds(g);
    if ((box.lo.array() <= box.hi.array()).all()) cell = std::max(cell, (box.hi - box.lo).maxCoeff());
  }
  cell += 2 * reach;
  const auto index = [cell](double c) { return static_cast<std::int64_t>(std::floor(c / cell)); };
  const auto key = [](std::int64_t i, std::int64_t j, std::int64_t k) {
    const auto bits = [](std::int64_t a) { return static_cast<std::uint64_t>(a + (1 << 20)) & 0x1FFFFFu; };
    return bits(i) << 42 | bits(j) << 21 | bits(k);
  };
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> grid;
  for (std::uint32_t g = 0; g < grains.size(); ++g) {
    const Aabb& box = trees.bounds(g);
    if (!(box.lo.array() <= box.hi.array()).all()) continue;
    const Aabb grown = box.inflated(reach);
    for (std::int64_t i = index(grown.lo.x()); i <= index(grown.hi.x()); ++i)
      for (std::int64_t j = index(grown.lo.y()); j <= index(grown.hi.y()); ++j)
        for (std::int64_t k = index(grown.lo.z()); k <= index(grown.hi.z()); ++k) grid[key(i, j, k)].push_back(g);
  }
  const std::size_t n = centres.size();
  // A memo is a fact about a grain's fixed body-frame surface, true whatever the lists: a ball that
  // keeps a grain keeps its memo and hint (both lists are in grain order), unless the radius changed.
  const bool keep_memos = ball_lists_radius == radius && ball_candidates.size() == n;
  ball_candidates.resize(n);
#pragma omp parallel for schedule(dynamic, 64) if (n >= kParallelNodes / 4)
  for (std::int64_t b = 0; b < static_cast<std::int64_t>(n); ++b) {
    std::vector<BallCandidate>& list = ball_candidates[b];
    std::vector<BallCandidate> before;
    if (keep_memos) before.swap(list);
    list.clear();
    const Eigen::Vector3d& c = centres[b];
    const auto it = grid.find(key(index(c.x()), index(c.y()), index(c.z())));
    if (it == grid.end()) continue;
    auto kept = before.begin();
    for (std::uint32_t g : it->second) {
      if (!trees.bounds(g).inflated(reach).contains(c)) continue;
      while (kept != before.end() && kept->grain < g) ++kept;
      list.push_back(kept != before.end() && kept->grain == g ? *kept : BallCandidate{g, SurfaceTrees::kNoHint, SearchMemo{}});
    }
  }
  ball_built_at.assign(centres.begin(), centres.end());
  ball_lists_rebuilds = rebuilds;
  ball_lists_radius = radius;
}

double ContactModel::ball_stable_time_step(const BallContactOptions& balls) const {
  const State& s = *state_;
  double dt = std::numeric_limits<double>::infinity();
  for (const Material& m : s.materials) {
    const double k_n = m.normal_penalty * std::numbers::pi * balls.radius * balls.radius;
    if (!(k_n > 0) || !(balls.mass > 0)) continue;
    const double beta = m.damping_ratio;
    dt = std::min(dt, kTimeStepSafety * 2.0 / std::sqrt(k_n / balls.mass) * (std::sqrt(1 + beta * beta) - beta));
  }
  return dt;
}

}  // namespace graintwin::fdem
