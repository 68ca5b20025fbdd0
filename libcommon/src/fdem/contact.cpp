#include "graintwin/fdem/contact.hpp"

#include <fmt/format.h>

#include "contact_state.hpp"
#include "graintwin/core/error.hpp"

namespace graintwin::fdem {

ContactModel::ContactModel(const Model& model, std::span<const double> node_mass, const ContactOptions& options)
    : state_(std::make_unique<State>()) {
  State& s = *state_;
  if (node_mass.size() != model.nodes.size())
    throw DataError(fmt::format("fdem contact: {} node masses for {} model nodes; pass one lumped mass per node.",
                                node_mass.size(), model.nodes.size()));
  if (model.triangle_grain.size() != model.triangles.size())
    throw DataError("fdem contact: the model's triangle_grain does not match its triangles; rebuild the model.");
  s.grains = model.grains;
  s.materials = model.materials;
  s.triangles = model.triangles;
  s.triangle_grain = model.triangle_grain;
  s.node_mass.assign(node_mass.begin(), node_mass.end());
  s.node_count = model.nodes.size();
  s.options = options;
  for (const Grain& g : model.grains)
    if (g.material >= model.materials.size())
      throw DataError(fmt::format("fdem contact: grain {} uses material {} of {}; fix the model's materials.",
                                  g.label, g.material, model.materials.size()));

  // Surface nodes per grain and the triangles around every node.
  s.node_triangle_offset.assign(s.node_count + 1, 0);
  for (const auto& t : s.triangles)
    for (std::uint32_t v : t) {
      if (v >= s.node_count)
        throw DataError(fmt::format("fdem contact: a surface triangle uses node {} of {}; rebuild the model.", v,
                                    s.node_count));
      ++s.node_triangle_offset[v + 1];
    }
  for (std::size_t n = 0; n < s.node_count; ++n) s.node_triangle_offset[n + 1] += s.node_triangle_offset[n];
  s.node_triangles.resize(s.node_triangle_offset.back());
  {
    std::vector<std::uint32_t> fill(s.node_triangle_offset.begin(), s.node_triangle_offset.end() - 1);
    for (std::uint32_t t = 0; t < s.triangles.size(); ++t)
      for (std::uint32_t v : s.triangles[t]) s.node_triangles[fill[v]++] = t;
  }
  s.surface_offset.push_back(0);
  double smallest_diagonal = std::numeric_limits<double>::infinity();
  double smallest_side = std::numeric_limits<double>::infinity();
  for (const Grain& g : model.grains) {
    const std::size_t first = s.surface_nodes.size();
    for (std::uint32_t t = g.triangle_begin; t < g.triangle_end; ++t)
      for (std::uint32_t v : s.triangles[t]) s.surface_nodes.push_back(v);
    std::sort(s.surface_nodes.begin() + first, s.surface_nodes.end());
    s.surface_nodes.erase(std::unique(s.surface_nodes.begin() + first, s.surface_nodes.end()), s.surface_nodes.end());
    Aabb box;
    for (std::size_t k = first; k < s.surface_nodes.size(); ++k) {
      const std::uint32_t v = s.surface_nodes[k];
      if (v < g.node_begin || v >= g.node_end)
        throw DataError(fmt::format("fdem contact: grain {}'s surface uses node {} outside its nodes; rebuild the model.",
                                    g.label, v));
      if (!(s.node_mass[v] > 0))
        throw DataError(fmt::format("fdem contact: surface node {} of grain {} has mass {}; node masses must be positive.",
                                    v, g.label, s.node_mass[v]));
      box.grow(model.nodes[v]);
    }
    s.surface_offset.push_back(static_cast<std::uint32_t>(s.surface_nodes.size()));
    const Eigen::Vector3d centre = 0.5 * (box.lo + box.hi);
    double radius2 = 0;
    for (std::size_t k = first; k < s.surface_nodes.size(); ++k)
      radius2 = std::max(radius2, (model.nodes[s.surface_nodes[k]] - centre).squaredNorm());
    s.reference_centre.push_back(centre);
    s.reference_radius.push_back(std::sqrt(radius2));
    if (s.surface_nodes.size() > first) {
      smallest_diagonal = std::min(smallest_diagonal, (box.hi - box.lo).norm());
      smallest_side = std::min(smallest_side, (box.hi - box.lo).minCoeff());
    }
  }
  if (!std::isfinite(smallest_diagonal) || !(smallest_side > 0))
    throw DataError("fdem contact: no grain has a closed surface of positive size; mesh the grains first.");
  s.skin = options.skin > 0 ? options.skin : kSkinFraction * smallest_diagonal;
  s.memo_margin = kMemoMarginFraction * s.skin;
  s.max_penetration = kMaxPenetrationFraction * smallest_side;

  // Reference triangle areas and edge neighbours (for edge pseudonormals): each grain's edges
  // sorted by their end nodes, so the two uses of an edge are adjacent.
  s.triangle_area.resize(s.triangles.size());
  s.reference_normal.resize(s.triangles.size());
  s.neighbour.assign(s.triangles.size(), {kNoTriangle, kNoTriangle, kNoTriangle});
  struct EdgeUse {
    std::uint32_t low, high, triangle;
    int edge;
  };
  std::vector<EdgeUse> edges;
  for (const Grain& g : model.grains) {
    edges.clear();
    for (std::uint32_t t = g.triangle_begin; t < g.triangle_end; ++t) {
      s.reference_normal[t] = triangle_normal(s.triangles[t], model.nodes);
      s.triangle_area[t] = 0.5 * s.reference_normal[t].norm();
      for (int e = 0; e < 3; ++e) {
        const auto [low, high] = std::minmax(s.triangles[t][e], s.triangles[t][(e + 1) % 3]);
        edges.push_back({low, high, t, e});
      }
    }
    std::sort(edges.begin(), edges.end(), [](const EdgeUse& p, const EdgeUse& q) {
      return std::tie(p.low, p.high, p.triangle) < std::tie(q.low, q.high, q.triangle);
    });
    for (std::size_t k = 0; k + 1 < edges.size(); ++k)
      if (edges[k].low == edges[k + 1].low && edges[k].high == edges[k + 1].high) {
        s.neighbour[edges[k].triangle][edges[k].edge] = edges[k + 1].triangle;
        s.neighbour[edges[k + 1].triangle][edges[k + 1].edge] = edges[k].triangle;
        ++k;
      }
  }
  s.node_facets.resize(s.node_triangles.size());
  for (std::size_t k = 0; k < s.node_triangles.size(); ++k) {
    const std::uint32_t t = s.node_triangles[k];
    const Eigen::Vector3d n = triangle_normal(s.triangles[t], model.nodes);
    const double len = n.norm();
    s.node_facets[k] << (len > 0 ? Eigen::Vector3d(n / len) : Eigen::Vector3d::Zero()), s.triangle_area[t] / 3.0;
  }
  s.reference_corner_normal.assign(s.node_count, Eigen::Vector3d::Zero());
  for (std::uint32_t v : s.surface_nodes)
    s.reference_corner_normal[v] = s.corner_normal(v, [&](std::uint32_t node) { return model.nodes[node]; },
                                                   [&](std::uint32_t t) { return s.reference_normal[t]; });
  s.trees = SurfaceTrees(model);
  s.pose.assign(model.grains.size(), RigidPose{});
}

ContactModel::~ContactModel() = default;
ContactModel::ContactModel(ContactModel&&) noexcept = default;
ContactModel& ContactModel::operator=(ContactModel&&) noexcept = default;

ContactStepStats ContactModel::add_forces(std::span<const Eigen::Vector3d> x, std::span<const Eigen::Vector3d> v,
                                          std::span<const PlatenState> platens, double dt,
                                          std::span<Eigen::Vector3d> f, std::span<const RigidPose> poses) {
  State& s = *state_;
  if (x.size() != s.node_count || v.size() != s.node_count || f.size() != s.node_count)
    throw DataError(fmt::format("fdem contact: positions, velocities and forces have {}, {} and {} entries for {} "
                                "nodes; pass one per model node.",
                                x.size(), v.size(), f.size(), s.node_count));
  ContactStepStats stats;
  s.records.clear();
  if (!s.options.enabled) {
    s.history.clear();
    return stats;
  }
  const auto grain_count = static_cast<std::uint32_t>(s.grains.size());

  s.sphere_centre.resize(grain_count);
  s.sphere_radius.resize(grain_count);
  s.pose.resize(grain_count);
  s.loads.assign(grain_count, RigidLoad{});
  if (s.record_node_forces) s.node_forces.assign(s.node_count, Eigen::Vector3d::Zero());
  s.owned_pair_sums.clear();
  if (!poses.empty() && poses.size() != grain_count)
    throw DataError(fmt::format("fdem contact: {} rigid poses for {} grains; pass one per grain or none.", poses.size(),
                                grain_count));
  // Trees and spheres; the pairs stay complete until a node has moved skin / 2 since the build.
  s.overlap_configuration = false;
  const bool check_moved = !s.need_rebuild;
  bool moved = false;
#pragma omp parallel for schedule(dynamic, 16) reduction(|| : moved) if (grain_count >= kParallelGrains)
  for (std::int64_t g = 0; g < grain_count; ++g) {
    const auto k = static_cast<std::uint32_t>(g);
    if (!s.present(k)) continue;  // another rank's grain: its pose here is stale
    if (s.update_grain(k, x, poses.empty() ? nullptr : &poses[k], check_moved)) moved = true;
  }
  s.need_rebuild = s.need_rebuild || moved;
  if (s.need_rebuild) {
    std::vector<Aabb> boxes(grain_count);
    for (std::uint32_t g = 0; g < grain_count; ++g)
      if (s.present(g)) boxes[g] = s.trees.bounds(g).inflated(0.5 * s.skin);
    s.rebuild_pairs(s.rank_pairs(overlapping_box_pairs(boxes)), x);
    s.built_at.resize(s.surface_nodes.size());
    for (std::uint32_t g = 0; g < grain_count; ++g)
      for (std::uint32_t k = s.surface_offset[g]; k < s.surface_offset[g + 1]; ++k)
        s.built_at[k] = s.position(s.surface_nodes[k], g, x);
    if (poses.empty()) s.built_pose.assign(grain_count, RigidPose{});
    else s.built_pose.assign(poses.begin(), poses.end());
    s.need_rebuild = false;
    ++s.rebuilds;
    stats.rebuilt = true;
  }
  stats.pairs = s.grain_pairs.size();

  // This step's candidates in (a, b) order: grain pairs whose current boxes overlap, then each
  // grain's platens whose plane cuts its box.
  s.candidates.clear();
  for (std::size_t k = 0, a = 0; a < grain_count; ++a) {
    for (; k < s.grain_pairs.size() && s.grain_pairs[k].first == a; ++k)
      if (s.trees.bounds(a).overlaps(s.trees.bounds(s.grain_pairs[k].second)))
        s.candidates.push_back({s.grain_pairs[k].first, s.grain_pairs[k].second, static_cast<std::uint32_t>(k)});
    const Aabb& box = s.trees.bounds(a);
    if (!(box.lo.array() <= box.hi.array()).all() || !s.owned(a)) continue;
    for (std::uint32_t p = 0; p < platens.size(); ++p) {
      // The box corner deepest along -normal decides whether the plane can touch the grain.
      const Eigen::Vector3d& n = platens[p].normal;
      const Eigen::Vector3d deepest{n.x() > 0 ? box.lo.x() : box.hi.x(), n.y() > 0 ? box.lo.y() : box.hi.y(),
                                    n.z() > 0 ? box.lo.z() : box.hi.z()};
      if ((deepest - platens[p].point).dot(n) < 0) s.candidates.push_back({static_cast<std::uint32_t>(a), grain_count + p});
    }
  }

  // Narrow phase: each candidate's hits depend only on the state, not on the thread that found
  // them, and are applied below in candidate order: results are the same for any thread count.
  if (s.hits.size() < s.candidates.size()) s.hits.resize(s.candidates.size());
  s.checks.assign(s.candidates.size(), {});
  s.sums.resize(s.candidates.size());
  // Rigid pairs whose lists no longer hold build them again first, so that the narrow phase below
  // changes no list's storage (its prefetches read other pairs' lists).
  s.candidate_motion.resize(s.candidates.size());
#pragma omp parallel for schedule(static) if (s.candidates.size() >= kParallelCandidates)
  for (std::int64_t i = 0; i < static_cast<std::int64_t>(s.candidates.size()); ++i)
    if (s.candidates[i].b < grain_count) s.candidate_motion[i] = s.pair_motion(s.candidates[i].pair);
  std::vector<std::uint32_t> stale;
  for (std::uint32_t i = 0; i < s.candidates.size(); ++i)
    if (s.candidates[i].b < grain_count && std::isfinite(s.candidate_motion[i][0]) && !s.lists_hold(s.candidate_motion[i]))
      stale.push_back(i);
#pragma omp parallel for schedule(dynamic, 1) if (stale.size() >= kParallelCandidates)
  for (std::int64_t k = 0; k < static_cast<std::int64_t>(stale.size()); ++k) {
    const std::uint32_t i = stale[k];
    s.checks[i].list_nodes = s.build_pair_lists(s.candidates[i].pair, x);
    s.checks[i].lists_built = true;
    s.candidate_motion[i] = s.pair_motion(s.candidates[i].pair);
  }
#pragma omp parallel for schedule(dynamic, 4) if (s.candidates.size() >= kParallelCandidates)
  for (std::int64_t i = 0; i < static_cast<std::int64_t>(s.candidates.size()); ++i) {
    const Candidate& c = s.candidates[i];
    // The heads of a later pair's lists are scattered over the heap: fetch them early (a cache miss
    // per list was a quarter of grain_hits by perf). Prefetching never faults.
    if (const std::size_t ahead = static_cast<std::size_t>(i) + kPrefetchCandidates; ahead < s.candidates.size()) {
      const Candidate& later = s.candidates[ahead];
      if (later.b < grain_count)
        for (int side : {0, 1}) {
          __builtin_prefetch(s.near_nodes[later.pair][side].data());
          __builtin_prefetch(s.memos[later.pair][side].data());
        }
    }
    std::vector<NodeHit>& out = s.hits[i];
    out.clear();
    if (c.b >= grain_count) {
      s.platen_hits(c, platens[c.b - grain_count], x, v, dt, out, s.checks[i]);
    } else {
      const std::array<double, 2>& moved = s.candidate_motion[i];
      s.grain_hits(c.a, c.b, c, s.near_nodes[c.pair][0], s.memos[c.pair][0], moved[0], x, v, dt, out, s.checks[i]);
      s.grain_hits(c.b, c.a, c, s.near_nodes[c.pair][1], s.memos[c.pair][1], moved[1], x, v, dt, out, s.checks[i]);
      // History lookups need (a, b, node) order; the grains' node ranges need not be increasing.
      if (!std::is_sorted(out.begin(), out.end(), [](const NodeHit& p, const NodeHit& q) { return p.node < q.node; }))
        std::sort(out.begin(), out.end(), [](const NodeHit& p, const NodeHit& q) { return p.node < q.node; });
    }
    if (!out.empty()) s.sums[i] = s.sum_hits(c, out);
  }

  s.history.clear();
  for (std::size_t i = 0; i < s.candidates.size(); ++i) {
    const Candidate& c = s.candidates[i];
    stats.node_checks += s.checks[i].nodes;
    stats.triangle_checks += s.checks[i].triangles;
    stats.pair_lists_built += s.checks[i].lists_built;
    const Checks& done = s.checks[i];
    s.add_grain_work(c.a, c.b, static_cast<double>(done.nodes) * (c.b >= grain_count ? kPlatenNodeWork : 1.0) +
                                   static_cast<double>(done.triangles) + kListNodeWork * static_cast<double>(done.list_nodes));
    if (s.hits[i].empty()) continue;
    // Forces on deformable grains' nodes, in candidate order; rigid grains get their sums.
    const bool platen = c.b >= grain_count;
    const bool node_rigid[2] = {s.pose[c.a].rigid, !platen && s.pose[c.b].rigid};
    const Grain& b_grain = s.grains[platen ? c.a : c.b];
    for (const NodeHit& h : s.hits[i]) {
      const bool on_b = !platen && h.node >= b_grain.node_begin && h.node < b_grain.node_end;
      if (!node_rigid[on_b]) f[h.node] += h.law.force;
      if (!platen && !node_rigid[!on_b]) {
        const auto& tri = s.triangles[h.triangle];
        for (int k = 0; k < 3; ++k) f[tri[k]] -= h.weights[k] * h.law.force;
      }
      s.record(h.node, platen ? kNoTriangle : h.triangle, h.weights, h.law.force);
      s.history.push_back({c.a, c.b, h.node, h.law.spring, h.offset});
    }
    const CandidateSum& sum = s.sums[i];
    if (node_rigid[0]) s.loads[c.a] += sum.load[0];
    if (node_rigid[1]) s.loads[c.b] += sum.load[1];
    stats.elastic_energy += sum.elastic_energy;
    stats.dissipated += sum.dissipated;
    stats.node_contacts += s.hits[i].size();
    stats.max_overlap = std::max(stats.max_overlap, sum.record.overlap);
    s.records.push_back(sum.record);
    if (s.owned(c.a))
      s.owned_pair_sums.push_back({c.a, c.b, sum.elastic_energy, sum.dissipated, sum.record.overlap, s.hits[i].size(),
                                   sum.record.force, sum.record.stiffness});
  }
  s.adopt_initial_overlaps = false;
  return stats;
}

void ContactModel::keep_initial_overlaps(std::span<const Overlap> overlaps) {
  State& s = *state_;
  s.adopt_initial_overlaps = true;
  s.deep_pairs.clear();
  const auto grain_count = static_cast<std::uint32_t>(s.grains.size());
  for (const Overlap& o : overlaps)
    if (o.b < grain_count && o.depth > 0) s.deep_pairs.push_back({o.a, o.b, o.depth + s.max_penetration});
  std::sort(s.deep_pairs.begin(), s.deep_pairs.end(),
            [](const DeepPair& l, const DeepPair& r) { return std::tie(l.a, l.b) < std::tie(r.a, r.b); });
  s.need_rebuild = true;  // the lists of these pairs reach deeper
}

std::span<const RigidLoad> ContactModel::rigid_loads() const { return state_->loads; }

void ContactModel::record_node_forces(bool on) {
  state_->record_node_forces = on;
  if (!on) state_->node_forces.clear();
}

std::span<const Eigen::Vector3d> ContactModel::node_forces() const { return state_->node_forces; }

std::span<const ContactRecord> ContactModel::contacts() const { return state_->records; }

void ContactModel::set_node_masses(std::span<const double> node_mass) {
  if (node_mass.size() != state_->node_mass.size())
    throw DataError(fmt::format("fdem contact: {} node masses for {} model nodes; pass one lumped mass per node.",
                                node_mass.size(), state_->node_mass.size()));
  state_->node_mass.assign(node_mass.begin(), node_mass.end());
}

double ContactModel::stable_time_step() const {
  const std::vector<double> steps = grain_time_steps();
  return steps.empty() ? std::numeric_limits<double>::infinity() : *std::min_element(steps.begin(), steps.end());
}

std::vector<double> ContactModel::grain_time_steps() const {
  const State& s = *state_;
  std::vector<double> steps(s.grains.size(), std::numeric_limits<double>::infinity());
  for (std::uint32_t g = 0; g < s.grains.size(); ++g) {
    double& dt = steps[g];
    const Material& m = s.material_of(g);
    const double beta = m.damping_ratio;
    for (std::uint32_t node : s.surface(g)) {
      double area = 0;
      for (std::uint32_t k = s.node_triangle_offset[node]; k < s.node_triangle_offset[node + 1]; ++k)
        area += s.triangle_area[s.node_triangles[k]] / 3.0;
      const double k_n = m.normal_penalty * area;
      if (!(k_n > 0)) continue;
      // Critical step of a damped oscillator: (2 / omega) (sqrt(1 + beta^2) - beta).
      const double omega = std::sqrt(k_n / s.node_mass[node]);
      dt = std::min(dt, kTimeStepSafety * 2.0 / omega * (std::sqrt(1 + beta * beta) - beta));
    }
  }
  return steps;
}

std::size_t ContactModel::rebuild_count() const { return state_->rebuilds; }
double ContactModel::skin() const { return state_->skin; }

}  // namespace graintwin::fdem
