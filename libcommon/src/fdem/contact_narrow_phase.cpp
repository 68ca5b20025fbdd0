// The contact model's narrow phase: each candidate's node contacts (against another grain through
// its near-node lists and search memos, or against a platen) and what they add up to.
#include "contact_state.hpp"

namespace graintwin::fdem {

CandidateSum ContactModel::State::sum_hits(const Candidate& c, std::span<const NodeHit> hits) const {
  CandidateSum sum;
  const bool platen = c.b >= grains.size();
  const Grain& b_grain = grains[platen ? c.a : c.b];
  ContactRecord& record = sum.record;
  record.a = c.a;
  record.b = c.b;
  Eigen::Vector3d normal_force_on_b = Eigen::Vector3d::Zero(), point_sum = Eigen::Vector3d::Zero();
  double weight = 0;
  for (const NodeHit& h : hits) {
    const Eigen::Vector3d& force = h.law.force;
    // The node belongs to b (pushed along +normal by a) or to a (its reaction acts on b).
    const bool on_b = !platen && h.node >= b_grain.node_begin && h.node < b_grain.node_end;
    if (pose[on_b ? c.b : c.a].rigid) sum.load[on_b].add(h.arm, force);
    if (!platen && pose[on_b ? c.a : c.b].rigid) sum.load[!on_b].add(surface_arm(h.triangle, h.weights), -force);
    const double sign = on_b ? 1.0 : -1.0;
    record.force += sign * force;
    normal_force_on_b += sign * h.law.normal_force * h.normal;
    record.point += h.law.normal_force * h.point;
    weight += h.law.normal_force;
    point_sum += h.point;
    record.overlap = std::max(record.overlap, h.overlap);
    record.stiffness += h.law.normal_stiffness;
    sum.elastic_energy += h.law.elastic_energy;
    sum.dissipated += h.law.dissipated;
  }
  // Normal-force-weighted; a plain mean when every node force is clamped to zero.
  record.point = weight > 0 ? Eigen::Vector3d(record.point / weight) : Eigen::Vector3d(point_sum / static_cast<double>(hits.size()));
  const double nf = normal_force_on_b.norm();
  record.normal = nf > 0 ? Eigen::Vector3d(normal_force_on_b / nf) : Eigen::Vector3d::Zero();
  return sum;
}

template <class Outside>
bool ContactModel::State::nearest_remembered(std::uint32_t to, const Eigen::Vector3d& q, double deepest, NearNode& listed,
                                             SearchMemo& memo, SurfaceTrees::Nearest& near, Checks& checks,
                                             Outside outside, double touch) const {
  const double deepest2 = deepest * deepest;
  if (options.search_memos && (q - memo.at).squaredNorm() < memo.valid2) {
    if (memo.count == 0) return false;
    double best2 = std::numeric_limits<double>::infinity();
    std::uint32_t best = 0;
    for (std::uint32_t k = 0; k < memo.count; ++k) {
      const std::uint32_t slot = memo.slots[k];
      const TrianglePoint closest = trees.closest_in_slot(slot, q);
      const double d2 = (closest.point - q).squaredNorm();
      if (d2 < best2 || (d2 == best2 && trees.slot_triangle(slot) < trees.slot_triangle(best)))
        near.closest = closest, near.distance2 = d2, best2 = d2, best = slot;
    }
    near.triangle = trees.slot_triangle(best);
    checks.triangles += memo.count;
    return best2 < deepest2;
  }
  // Round-off allowance on the memo's distances (positions are rounded at ~1e-16 of their size).
  const double slack = kRigidRoundOff * (reference_radius[to] + reference_centre[to].norm());
  const double margin = memo_margin;
  memo.at = q;
  memo.count = 0;
  const bool found = trees.nearest_in_body(to, q, deepest + 2 * margin, near, listed.hint);
  checks.triangles += near.tested;
  if (!found) {
    memo.valid2 = 2 * margin > slack ? (2 * margin - slack) * (2 * margin - slack) : -1;
    return false;
  }
  if (listed.hint != SurfaceTrees::kNoHint) listed.hint = near.triangle;
  const double d = std::sqrt(near.distance2);
  if (outside(near) && !(d < touch)) {
    memo.valid2 = d - touch > slack ? (d - touch - slack) * (d - touch - slack) : -1;
    return false;
  }
  if (!options.search_memos) return near.distance2 < deepest2;
  if (!(near.distance2 < deepest2)) {
    memo.valid2 = d - deepest > slack ? (d - deepest - slack) * (d - deepest - slack) : -1;
    return false;
  }
  const std::size_t count = trees.slots_within_in_body(to, q, d + 2 * margin + slack, memo.slots);
  memo.count = static_cast<std::uint32_t>(std::min(count, kMemoTriangles));
  memo.valid2 = count <= kMemoTriangles ? margin * margin : -1;
  return true;
}

void ContactModel::State::grain_hits(std::uint32_t from, std::uint32_t to, const Candidate& key,
                                     std::span<NearNode> nodes, std::span<SearchMemo> memos, double moved,
                                     std::span<const Eigen::Vector3d> x, std::span<const Eigen::Vector3d> v, double dt,
                                     std::vector<NodeHit>& out, Checks& checks) const {
  // Two rigid grains: a listed node's reference position X maps into `to`'s body frame by one
  // affine map, q = R_to^T (R_from X + t_from - t_to), where `to`'s box and sphere are its
  // reference ones and its search memo holds; the node is placed in the world only once it is
  // found close.
  const RigidPose& body_from = pose[from];
  const RigidPose& body_to = pose[to];
  const bool rigid_pair = body_from.rigid && body_to.rigid;
  const Eigen::Matrix3d to_body = rigid_pair ? Eigen::Matrix3d(body_to.rotation.transpose() * body_from.rotation)
                                             : Eigen::Matrix3d::Identity();
  const Eigen::Vector3d to_body_shift = rigid_pair ? Eigen::Vector3d(body_to.rotation.transpose() *
                                                                     (body_from.translation - body_to.translation))
                                                   : Eigen::Vector3d::Zero();
  const Aabb& box = rigid_pair ? trees.reference_bounds(to) : trees.bounds(to);
  const Eigen::Vector3d& centre = rigid_pair ? reference_centre[to] : sphere_centre[to];
  const double reach2 = sphere_radius[to] * sphere_radius[to];
  const Material& mf = material_of(from);
  const Material& mt = material_of(to);
  const double p_n = std::min(mf.normal_penalty, mt.normal_penalty);
  const double p_t = std::min(mf.tangential_penalty, mt.tangential_penalty);
  const double mu = std::min(mf.friction, mt.friction);
  const double beta = 0.5 * (mf.damping_ratio + mt.damping_ratio);
  const double deepest = search_depth(key.a, key.b);
  const std::span<const HistoryEntry> past = history_of(key.a, key.b);
  SurfaceTrees::Nearest near;
  // Between rigid grains the list is sorted by clearance: read it only as far as the pair moved.
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    NearNode& listed = nodes[i];
    if (listed.clearance > moved) break;
    ++checks.nodes;
    const std::uint32_t node = listed.node;
    PlacedNode placed;
    const Eigen::Vector3d& p = placed.at;
    const auto place_node = [&] { placed = place(node, body_from, listed.reference, x); };
    // From the node out to the surface, and whether that leaves the node outside.
    const auto to_surface = [&](const SurfaceTrees::Nearest& n) -> Eigen::Vector3d { return n.closest.point - p; };
    const auto outside = [&](const SurfaceTrees::Nearest& n) {
      return !(to_surface(n).dot(pseudonormal(n.triangle, n.closest.feature, x)) > 0);
    };
    if (rigid_pair) {
      // Found, inside and placed in the body frame of `to`, where its reference pseudonormals hold.
      const Eigen::Vector3d q = to_body * listed.reference + to_body_shift;
      if (!box.contains(q) || (q - centre).squaredNorm() > reach2) continue;
      const auto outside_in_body = [&](const SurfaceTrees::Nearest& n) {
        return !((n.closest.point - q).dot(reference_pseudonormal(n.triangle, n.closest.feature)) > 0);
      };
      if (!nearest_remembered(to, q, deepest, listed, memos[i], near, checks, outside_in_body) || outside_in_body(near))
        continue;
      place_node();
      near.closest.point = body_to.rotation * near.closest.point + body_to.translation;
    } else {
      place_node();
      if (!box.contains(p) || (p - centre).squaredNorm() > reach2) continue;
      const bool close = nearest(to, p, deepest, x, near, listed.hint);
      checks.triangles += near.tested;
      if (close && listed.hint != SurfaceTrees::kNoHint) listed.hint = near.triangle;
      if (!close || outside(near)) continue;
    }
    const Eigen::Vector3d d = to_surface(near);
    NodeHit hit;
    hit.overlap = std::sqrt(near.distance2);
    hit.normal = near.closest.feature == TriangleFeature::face ? Eigen::Vector3d(normal_of(near.triangle, x).normalized())
                                                               : Eigen::Vector3d(d / hit.overlap);
    // Both directions are evaluated, each with half the penalty (docs/fdem_contact.md).
    const double area = 0.5 * facing_area(node, hit.normal, x, body_from);
    if (!(area > 0)) continue;
    const Eigen::Vector3d w = near.closest.weights;
    const Eigen::Vector3d relative = velocity(node, from, v) - surface_velocity(near.triangle, w, v);
    const HistoryEntry* previous = previous_entry(past, node);
    hit.offset = offset_of(previous, hit.overlap);
    hit.law = node_contact_force(contact_law(p_n, p_t, area, node_mass[node], beta, mu), hit.normal, hit.overlap - hit.offset,
                                 relative, previous ? previous->spring : Eigen::Vector3d::Zero(), dt);
    hit.node = node;
    hit.triangle = near.triangle;
    hit.weights = w;
    hit.arm = placed.arm;
    hit.point = 0.5 * (p + near.closest.point);
    out.push_back(hit);
  }
}

bool ContactModel::State::ball_nearest(BallCandidate& candidate, const Eigen::Vector3d& c, double radius,
                                       double ball_radius, std::span<const Eigen::Vector3d> x,
                                       SurfaceTrees::Nearest& near) const {
  const std::uint32_t g = candidate.grain;
  const RigidPose& body = pose[g];
  if (!body.rigid) {  // a deformable surface moves under any memo: searched anew from the last triangle
    if (!trees.nearest(g, c, radius, x, near, candidate.hint)) return false;
    candidate.hint = near.triangle;
    return true;
  }
  // A ball touches with its centre inside the grain or outside within its radius; a centre outside
  // farther than that keeps its memo until it has moved the difference (a membrane hovering near
  // the grains searched again every 2 m of motion: a third of a shearing step went to those searches).
  NearNode listed;
  listed.hint = candidate.hint;
  Checks checks;
  const Eigen::Vector3d q = body.rotation.transpose() * (c - body.translation);
  const auto outside = [&](const SurfaceTrees::Nearest& n) {
    return !((n.closest.point - q).dot(reference_pseudonormal(n.triangle, n.closest.feature)) > 0);
  };
  if (!nearest_remembered(g, q, radius, listed, candidate.memo, near, checks, outside, ball_radius)) return false;
  near.closest.point = body.rotation * near.closest.point + body.translation;
  candidate.hint = near.triangle;
  return true;
}

void ContactModel::State::platen_hits(const Candidate& key, const PlatenState& platen,
                                      std::span<const Eigen::Vector3d> x, std::span<const Eigen::Vector3d> v, double dt,
                                      std::vector<NodeHit>& out, Checks& checks) const {
  const Material& m = material_of(key.a);
  const std::span<const HistoryEntry> past = history_of(key.a, key.b);
  checks.nodes += surface(key.a).size();
  for (std::uint32_t node : surface(key.a)) {
    const auto [p, arm] = place(node, key.a, x);
    const double height = (p - platen.point).dot(platen.normal);
    if (!(height < 0)) continue;
    NodeHit hit;
    hit.overlap = -height;
    hit.normal = platen.normal;
    const double area = facing_area(node, hit.normal, x, pose[key.a]);
    if (!(area > 0)) continue;
    const HistoryEntry* previous = previous_entry(past, node);
    hit.offset = offset_of(previous, hit.overlap);
    hit.law = node_contact_force(
        contact_law(m.normal_penalty, m.tangential_penalty, area, node_mass[node], m.damping_ratio, platen.friction),
        hit.normal, hit.overlap - hit.offset, velocity(node, key.a, v) - platen.velocity,
        previous ? previous->spring : Eigen::Vector3d::Zero(), dt);
    hit.node = node;
    hit.arm = arm;
    hit.point = p + 0.5 * hit.overlap * platen.normal;
    out.push_back(hit);
  }
}

}  // namespace graintwin::fdem
