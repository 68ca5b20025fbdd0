// The contact model's near-node lists: per grain pair, the surface nodes of each grain within
// reach of the other's surface, kept between rigid or framed grains while the pair moves less than
// the skin.
#include "contact_state.hpp"

namespace graintwin::fdem {

void ContactModel::State::collect_near_nodes(std::uint32_t from, std::uint32_t to, double reach,
                                             std::span<const Eigen::Vector3d> x, std::vector<NearNode>& out) const {
  out.clear();
  if (!options.near_node_lists) {
    for (std::uint32_t node : surface(from)) out.push_back({node, SurfaceTrees::kNoHint, trees.reference_positions()[node]});
    return;
  }
  const Aabb box = trees.bounds(to).inflated(reach);
  const Eigen::Vector3d& centre = sphere_centre[to];
  const double sphere_reach2 = (sphere_radius[to] + reach) * (sphere_radius[to] + reach);
  SurfaceTrees::Nearest near;
  const bool framed_pair = (pose[from].rigid || pose[from].framed) && (pose[to].rigid || pose[to].framed);
  for (std::uint32_t node : surface(from)) {
    const Eigen::Vector3d p = position(node, from, x);
    if (!box.contains(p) || (p - centre).squaredNorm() > sphere_reach2 || !nearest(to, p, reach, x, near)) continue;
    const bool inside = (near.closest.point - p).dot(pseudonormal(near.triangle, near.closest.feature, x)) > 0;
    out.push_back({node, near.triangle, trees.reference_positions()[node],
                   framed_pair && !inside ? std::sqrt(near.distance2) : 0.0});
  }
  if (framed_pair)  // nearest first; stable, so the order is the same on every run
    std::stable_sort(out.begin(), out.end(), [](const NearNode& a, const NearNode& b) { return a.clearance < b.clearance; });
}

double ContactModel::State::relative_motion(std::uint32_t from, std::uint32_t to, const RigidPose& f0,
                                            const RigidPose& t0) const {
  const RigidPose &f = pose[from], &t = pose[to];
  const auto framed = [](const RigidPose& p) { return p.rigid || p.framed; };
  if (!(framed(f) && framed(t) && framed(f0) && framed(t0))) return std::numeric_limits<double>::infinity();
  const Eigen::Matrix3d turn = t.rotation.transpose() * f.rotation - t0.rotation.transpose() * f0.rotation;
  const Eigen::Vector3d shift =
      t.rotation.transpose() * (f.translation - t.translation) - t0.rotation.transpose() * (f0.translation - t0.translation);
  const double slack = kRigidRoundOff * (reference_radius[from] + reference_centre[from].norm() +
                                         reference_radius[to] + reference_centre[to].norm());
  return turn.norm() * reference_radius[from] + (turn * reference_centre[from] + shift).norm() + slack + f.deviation +
         f0.deviation + t.deviation + t0.deviation;
}

std::array<double, 2> ContactModel::State::pair_motion(std::size_t k) const {
  const auto [a, b] = grain_pairs[k];
  return {relative_motion(a, b, list_pose[k][0], list_pose[k][1]), relative_motion(b, a, list_pose[k][1], list_pose[k][0])};
}

std::size_t ContactModel::State::build_pair_lists(std::size_t k, std::span<const Eigen::Vector3d> x) {
  const auto [a, b] = grain_pairs[k];
  const double reach = (search_depth(a, b) + skin) * (1 + kReachRoundOff);
  collect_near_nodes(a, b, reach, x, near_nodes[k][0]);
  collect_near_nodes(b, a, reach, x, near_nodes[k][1]);
  for (int side : {0, 1}) memos[k][side].assign(near_nodes[k][side].size(), SearchMemo{});
  list_pose[k] = {pose[a], pose[b]};
  return surface(a).size() + surface(b).size();
}

void ContactModel::State::rebuild_pairs(std::vector<BoxPair> pairs, std::span<const Eigen::Vector3d> x) {
  std::vector<std::array<std::vector<NearNode>, 2>> kept_nodes(pairs.size());
  std::vector<std::array<std::vector<SearchMemo>, 2>> kept_memos(pairs.size());
  std::vector<std::array<RigidPose, 2>> kept_pose(pairs.size());
  std::vector<char> fresh(pairs.size(), 1);
  for (std::size_t k = 0, old = 0; k < pairs.size(); ++k) {
    while (old < grain_pairs.size() && grain_pairs[old] < pairs[k]) ++old;
    if (old == grain_pairs.size() || grain_pairs[old] != pairs[k] || !lists_hold(pair_motion(old))) continue;
    kept_nodes[k] = std::move(near_nodes[old]);
    kept_memos[k] = std::move(memos[old]);
    kept_pose[k] = list_pose[old];
    fresh[k] = 0;
  }
  grain_pairs = std::move(pairs);
  near_nodes = std::move(kept_nodes);
  memos = std::move(kept_memos);
  list_pose = std::move(kept_pose);
  std::vector<std::size_t> visited(grain_pairs.size(), 0);
#pragma omp parallel for schedule(dynamic, 4) if (grain_pairs.size() >= kParallelCandidates)
  for (std::int64_t k = 0; k < static_cast<std::int64_t>(grain_pairs.size()); ++k)
    if (fresh[k]) visited[k] = build_pair_lists(static_cast<std::size_t>(k), x);
  for (std::size_t k = 0; k < grain_pairs.size(); ++k)
    if (visited[k] > 0) add_grain_work(grain_pairs[k].first, grain_pairs[k].second, kListNodeWork * static_cast<double>(visited[k]));
}

}  // namespace graintwin::fdem
