// fdem/rank_state and the solver's and contact model's hooks for a run split over ranks, without
// MPI: messages keep every bit and refuse damage, the exchange plan sends a leaving grain with its
// pairs' history and the receiver takes it as its own, histories merge and refuse disagreement,
// the step's sums are rebuilt in the one-rank order, and a solver stepping under a share that owns
// every grain moves exactly as without one. The run across ranks itself: tests/mpi/distributed_run_test.cpp.
#include "graintwin/fdem/rank_state.hpp"

#include <gtest/gtest.h>

#include <bit>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/primitives.hpp"

using namespace graintwin;
using namespace graintwin::fdem;

namespace {

std::uint64_t bits(double x) { return std::bit_cast<std::uint64_t>(x); }

void expect_same_bits(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  for (int k = 0; k < 3; ++k) EXPECT_EQ(bits(a[k]), bits(b[k]));
}

RankMessage sample_message() {
  RankMessage m;
  RigidBodyState s;
  s.position = {1.0 / 3.0, -0.0, 4.9e-324};
  s.orientation = Eigen::Quaterniond(0.5, -0.5, 0.5, std::sqrt(0.25)).normalized();
  s.velocity = {1e300, -2.5, 0.1};
  s.angular_momentum = {-1e-30, 7.0, 0.0};
  m.bodies.push_back({41, s});
  m.bodies.push_back({4000000000u, RigidBodyState{}});
  m.nodes.push_back({5, true, true, {1.0 / 3.0, -0.0, 1e-310, 4, 5, 6, 7, 8, 1e300}});
  m.nodes.push_back({6, false, false, {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 1.0 / 7.0}});
  m.history.push_back({3, 9, 77, Eigen::Vector3d(1e-9, -2e-9, 1.0 / 7.0), 2.5e-7});
  m.history.push_back({0, 1, 0, Eigen::Vector3d::Zero(), 0.0});
  m.rows.keys = {3, (std::uint64_t{1} << 53) - 1};
  m.rows.values = {1.0 / 3.0, -0.0, 1e-310, 2.0, 0.0, 5.0, 6.0, 7.0, 8.0, 9.0};
  GrainLoad load{7, {}};
  load.load.force = {1.0 / 3.0, -0.0, 1e-310};
  load.load.moment << 1, 2, 3, 4, 5, 6, 7, 8, 1.0 / 9.0;
  m.loads.push_back(load);
  ContactRecord record;
  record.a = 2, record.b = 4000000000u;
  record.point = {1e-3, -2e-3, 1.0 / 3.0};
  record.normal = {0.0, -0.0, 1.0};
  record.force = {-1e300, 5e-324, 2.0};
  record.overlap = 1.0 / 7.0, record.stiffness = 3e9;
  m.records.push_back(record);
  return m;
}

/// Four rigid 1 mm cubes along x at 0, 2, 4 and 6 mm.
Model four_cubes() {
  Model m;
  const TetMesh cube = box_mesh(Eigen::Vector3d::Constant(1e-3), 0.5e-3);
  for (int i = 0; i < 4; ++i) add_grain(m, cube, Eigen::Vector3d(2e-3 * i, 0, 0), GrainKind::rigid, 0, i + 1);
  return m;
}

std::vector<double> radii_of(const Solver& solver) {
  std::vector<BodyProperties> bodies;
  for (std::size_t g = 0; g < solver.model().grains.size(); ++g) bodies.push_back(solver.body(g));
  return grain_bounding_radii(solver.model(), bodies);
}

/// A share owning every grain whose sums need no completing: the one-rank run through the hooks.
class WholeShare : public RankShare {
 public:
  explicit WholeShare(std::size_t grains) : roles_(grains, GrainRole::owned) {}
  std::span<const GrainRole> roles() const override { return roles_; }
  void finish_step(GrainStepSums&, std::span<const PairStepSum> pairs, ContactStepStats&, std::span<Eigen::Vector3d>,
                   std::span<double>, StepRows&) override {
    owned_pairs += pairs.size();
  }
  std::size_t owned_pairs = 0;

 private:
  std::vector<GrainRole> roles_;
};

}  // namespace

TEST(FdemRankState, PackedMessagesKeepEveryBit) {
  const RankMessage m = sample_message();
  std::vector<double> packed{42.0};  // appended after what is there
  pack_message(m, packed);
  ASSERT_EQ(packed.size(), 1 + 6 + 2 * kBodyDoubles + (3 + 9) + (3 + 12) + 2 * kHistoryDoubles + 2 * (1 + kTermColumns) +
                               kLoadDoubles + kRecordDoubles);
  const RankMessage back = unpack_message(std::span<const double>(packed).subspan(1));
  ASSERT_EQ(back.bodies.size(), 2u);
  ASSERT_EQ(back.history.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    const RigidBodyState &a = m.bodies[i].state, &b = back.bodies[i].state;
    EXPECT_EQ(back.bodies[i].grain, m.bodies[i].grain);
    expect_same_bits(a.position, b.position);
    expect_same_bits(a.velocity, b.velocity);
    expect_same_bits(a.angular_momentum, b.angular_momentum);
    for (int k = 0; k < 4; ++k) EXPECT_EQ(bits(a.orientation.coeffs()[k]), bits(b.orientation.coeffs()[k]));
    const ContactHistoryEntry &h = m.history[i], &g = back.history[i];
    EXPECT_EQ(std::tie(h.a, h.b, h.node), std::tie(g.a, g.b, g.node));
    expect_same_bits(h.spring, g.spring);
    EXPECT_EQ(bits(h.offset), bits(g.offset));
  }
  ASSERT_EQ(back.nodes.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(std::tie(back.nodes[i].grain, back.nodes[i].whole, back.nodes[i].forces),
              std::tie(m.nodes[i].grain, m.nodes[i].whole, m.nodes[i].forces));
    ASSERT_EQ(back.nodes[i].values.size(), m.nodes[i].values.size());
    for (std::size_t k = 0; k < m.nodes[i].values.size(); ++k)
      EXPECT_EQ(bits(back.nodes[i].values[k]), bits(m.nodes[i].values[k]));
  }
  EXPECT_EQ(back.rows.keys, m.rows.keys);
  ASSERT_EQ(back.rows.values.size(), m.rows.values.size());
  for (std::size_t i = 0; i < m.rows.values.size(); ++i) EXPECT_EQ(bits(back.rows.values[i]), bits(m.rows.values[i]));
  ASSERT_EQ(back.loads.size(), 1u);
  EXPECT_EQ(back.loads[0].grain, 7u);
  expect_same_bits(back.loads[0].load.force, m.loads[0].load.force);
  for (int r = 0; r < 3; ++r) expect_same_bits(back.loads[0].load.moment.row(r).transpose(), m.loads[0].load.moment.row(r).transpose());
  ASSERT_EQ(back.records.size(), 1u);
  const ContactRecord &c = m.records[0], &d = back.records[0];
  EXPECT_EQ(std::tie(c.a, c.b), std::tie(d.a, d.b));
  expect_same_bits(c.point, d.point);
  expect_same_bits(c.normal, d.normal);
  expect_same_bits(c.force, d.force);
  EXPECT_EQ(bits(c.overlap), bits(d.overlap));
  EXPECT_EQ(bits(c.stiffness), bits(d.stiffness));
  EXPECT_TRUE(unpack_message(std::vector<double>{0.0, 0.0, 0.0, 0.0, 0.0, 0.0}).bodies.empty());
}

TEST(FdemRankState, DamagedMessagesAreRefused) {
  std::vector<double> packed;
  pack_message(sample_message(), packed);
  const auto refused = [](std::vector<double> p, const std::string& words) {
    try {
      unpack_message(p);
      ADD_FAILURE() << "accepted: " << words;
    } catch (const DataError& e) {
      EXPECT_NE(e.message().find(words), std::string::npos) << e.message();
    }
  };
  refused({packed.begin(), packed.end() - 1}, "ends inside an entry");
  std::vector<double> longer = packed;
  longer.push_back(0.0);
  refused(longer, "holds more than its counts say");
  std::vector<double> huge = packed;
  huge[0] = 4e9;  // a damaged count must not size anything
  refused(huge, "ends inside an entry");
  std::vector<double> fraction = packed;
  fraction[1] = 41.5;  // the first body's grain index
  refused(fraction, "where an index belongs");
  const std::size_t nodes_at = 1 + 2 * kBodyDoubles;  // the first grain of nodes: count, grain, flags, values
  std::vector<double> flags = packed;
  flags[nodes_at + 2] = 4;
  refused(flags, "node flags");
  std::vector<double> partial = packed;
  partial[nodes_at + 3] = 8;  // 8 values of 9 per node
  refused(partial, "not whole nodes");
}

TEST(FdemRankState, ALeavingGrainGoesToItsNewOwnerWithItsPairsHistory) {
  const Model m = four_cubes();
  Solver solver(m, SolverOptions{});
  const std::vector<double> radii = radii_of(solver);
  std::vector<Eigen::Vector3d> centroids;
  for (const RigidBodyState& b : solver.rigid_states()) centroids.push_back(b.position);
  const Aabb domain{Eigen::Vector3d(-1e-3, -1e-3, -1e-3), Eigen::Vector3d(7e-3, 1e-3, 1e-3)};
  const Subdomains sub = bisect_domain(centroids, radii, surface_node_work(m), domain, 2, solver.contact_model()->skin());
  ASSERT_EQ(owner_ranks(sub, centroids), (std::vector<int>{0, 0, 1, 1}));
  const std::vector<GrainRole> start = initial_roles(sub, 0, solver.rigid_states(), radii);
  EXPECT_EQ(start, (std::vector<GrainRole>{GrainRole::owned, GrainRole::owned, GrainRole::ghost, GrainRole::absent}));
  EXPECT_EQ(grains_with_role(start, GrainRole::owned), (std::vector<std::uint32_t>{0, 1}));

  // Grain 1 moved into rank 1's box; the contact model holds histories of three pairs.
  ContactModel& contact = *solver.contact_model();
  const std::uint32_t node = m.grains[1].node_begin;
  contact.merge_history(std::vector<ContactHistoryEntry>{
      {2, 3, m.grains[2].node_begin, Eigen::Vector3d(3, 0, 0), 0}, {0, 1, node, Eigen::Vector3d(1, 0, 0), 0},
      {1, 2, node, Eigen::Vector3d(2, 0, 0), 0}});
  RigidBodyState moved = solver.rigid_states()[1];
  moved.position.x() = 4.5e-3;
  solver.set_rigid_state(1, moved);

  const std::vector<std::uint32_t> owned{0, 1};
  const ExchangePlan plan = plan_exchange(sub, 0, owned, solver.rigid_states(), radii, contact);
  EXPECT_EQ(plan.kept, (std::vector<std::uint32_t>{0}));
  EXPECT_EQ(plan.ghosted, (std::vector<std::uint32_t>{1})) << "still within reach of rank 0's grains";
  EXPECT_TRUE(plan.to[0].bodies.empty());
  ASSERT_EQ(plan.to[1].bodies.size(), 1u) << "grain 1 as a migrant; grain 0 is out of rank 1's reach";
  EXPECT_EQ(plan.to[1].bodies[0].grain, 1u);
  EXPECT_EQ(bits(plan.to[1].bodies[0].state.position.x()), bits(4.5e-3));
  ASSERT_EQ(plan.to[1].history.size(), 2u) << "the pairs of grain 1 alone";
  EXPECT_EQ(std::tie(plan.to[1].history[0].a, plan.to[1].history[0].b), std::tie(owned[0], owned[1]));
  EXPECT_EQ(plan.to[1].history[1].b, 2u);

  // Rank 1 kept grains 2 and 3 and hears from rank 0.
  ExchangePlan own;
  own.kept = {2, 3};
  const std::vector<GrainRole> roles = roles_after_exchange(sub, 1, 4, own, std::span(&plan.to[1], 1));
  EXPECT_EQ(roles, (std::vector<GrainRole>{GrainRole::absent, GrainRole::owned, GrainRole::owned, GrainRole::owned}));
  RankMessage stray;
  stray.bodies.push_back({9, RigidBodyState{}});
  EXPECT_THROW(roles_after_exchange(sub, 1, 4, own, std::span(&stray, 1)), DataError);
}

TEST(FdemRankState, HistoriesMergeAndRefuseDisagreement) {
  const Model m = four_cubes();
  Solver solver(m, SolverOptions{});
  ContactModel& contact = *solver.contact_model();
  const ContactHistoryEntry a{0, 1, 5, Eigen::Vector3d(1, 2, 3), 1e-7}, b{1, 2, 40, Eigen::Vector3d(4, 5, 6), 0};
  contact.merge_history(std::vector<ContactHistoryEntry>{b});
  contact.merge_history(std::vector<ContactHistoryEntry>{b, a, a});  // duplicates of equal bits are one entry
  const std::vector<std::uint32_t> all{0, 1, 2, 3};
  const std::vector<ContactHistoryEntry> held = contact.history_of(all);
  ASSERT_EQ(held.size(), 2u);
  EXPECT_EQ(held[0].node, 5u);
  EXPECT_EQ(held[1].node, 40u);
  EXPECT_TRUE(contact.history_of(std::vector<std::uint32_t>{3}).empty());

  ContactHistoryEntry other = a;
  other.spring.x() = std::nextafter(1.0, 2.0);
  try {
    contact.merge_history(std::vector<ContactHistoryEntry>{other});
    ADD_FAILURE() << "a history one bit apart was taken";
  } catch (const DataError& e) {
    EXPECT_NE(e.message().find("different friction histories for node 5 of grain pair (0, 1)"), std::string::npos)
        << e.message();
  }
  EXPECT_THROW(contact.merge_history(std::vector<ContactHistoryEntry>{{2, 1, 0, Eigen::Vector3d::Zero(), 0}}), DataError) << "b <= a";
}

TEST(FdemRankState, StepSumsAreRebuiltInTheOneRankOrder) {
  GrainStepSums sums;
  for (auto* v : {&sums.strain, &sums.kinetic, &sums.damped, &sums.gravity_work}) v->assign(3, 0.0);
  sums.bad.assign(3, 0);
  sums.kinetic = {1.0, 2.0, 3.0};
  sums.bad[2] = 1;
  // Order-sensitive energies and platen forces: added from zero in key order, as the contact step
  // adds them. With 3 grains and 2 platens, b = 3 is platen 0 and b = 4 platen 1; candidate (0, 3)
  // comes after (0, 1) and before (2, 4). Platen 1 meets grains 0 and 2 here and grain 1 on
  // another rank: 1e16, then 1, then -1e16 in grain order sum to 0 (in any other order, to 1).
  const auto pair = [](std::uint32_t a, std::uint32_t b, double elastic, double dissipated, double overlap,
                       std::uint64_t nodes, double force_x) {
    return PairStepSum{a, b, elastic, dissipated, overlap, nodes, Eigen::Vector3d(force_x, 2.0, 0.0), 0.5};
  };
  const std::vector<PairStepSum> pairs{pair(2, 4, -1e16, 1e16, 2e-6, 2, -1e16), pair(0, 1, 1e16, 1.0, 1e-6, 3, 7.0),
                                       pair(0, 3, 1.0, -1e16, 3e-6, 1, 5.0), pair(0, 4, 0.0, 0.0, 0.0, 1, 1e16)};
  const std::vector<std::uint32_t> owned{2, 0};
  // The boundary's rows (a wall's two grains here) travel after every step term, under keys of their own.
  StepRows wall;
  wall.keys = {0, 2};
  wall.values = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10};
  const StepRows rows = step_rows(sums, owned, pairs, 2, wall);
  const std::uint64_t boundary = first_boundary_key(3, 2);
  EXPECT_EQ(boundary, 3 + 3 * 5 + 3 * 2u);
  const std::uint64_t platen_rows = 3 + 3 * 5;
  ASSERT_EQ(rows.keys, (std::vector<std::uint64_t>{2, 0, 3 + 2 * 5 + 4, 3 + 1, 3 + 3, 3 + 4, platen_rows + 2 * 2 + 1,
                                                   platen_rows + 0, platen_rows + 1, boundary, boundary + 2}));
  ASSERT_EQ(rows.values.size(), 11 * kTermColumns);
  EXPECT_EQ(rows.values[1], 3.0);
  EXPECT_EQ(rows.values[4], 1.0);

  // Grain 1 and its candidate with platen 1 come from their owner, another rank: the rows of
  // both, sorted by key.
  GrainStepSums other_sums = sums;
  other_sums.kinetic = {0.0, 11.0, 0.0};
  other_sums.bad.assign(3, 0);
  const std::vector<std::uint32_t> other_owned{1};
  StepRows other_wall;
  other_wall.keys = {1};
  other_wall.values = {11, 12, 13, 14, 15};
  const StepRows other =
      step_rows(other_sums, other_owned, std::vector<PairStepSum>{pair(1, 4, 0.0, 0.0, 0.0, 1, 1.0)}, 2, other_wall);
  StepRows all = sorted_rows(std::vector<StepRows>{rows, other});
  const StepRows walls = take_boundary_rows(all, boundary);
  EXPECT_EQ(walls.keys, (std::vector<std::uint64_t>{0, 1, 2}));
  EXPECT_EQ(walls.values, (std::vector<double>{1, 2, 3, 4, 5, 11, 12, 13, 14, 15, 6, 7, 8, 9, 10}));
  EXPECT_EQ(all.keys, (std::vector<std::uint64_t>{0, 1, 2, 3 + 1, 3 + 3, 3 + 4, 3 + 5 + 4, 3 + 2 * 5 + 4, platen_rows,
                                                  platen_rows + 1, platen_rows + 2 + 1, platen_rows + 4 + 1}));
  GrainStepSums whole = sums;
  whole.kinetic.assign(3, 0.0);
  whole.bad.assign(3, 0);
  ContactStepStats stats;
  std::vector<Eigen::Vector3d> platen_force(2, Eigen::Vector3d::Constant(99.0));
  std::vector<double> platen_stiffness(2, 99.0);
  set_step_terms(all.keys, all.values, whole, stats, platen_force, platen_stiffness);
  EXPECT_EQ(whole.kinetic, (std::vector<double>{1, 11, 3}));
  EXPECT_EQ(whole.bad, (std::vector<char>{0, 0, 1}));
  EXPECT_EQ(bits(stats.elastic_energy), bits((1e16 + 1.0) + -1e16));
  EXPECT_EQ(bits(stats.dissipated), bits((1.0 + -1e16) + 1e16));
  EXPECT_EQ(stats.max_overlap, 3e-6);
  EXPECT_EQ(stats.node_contacts, 8u);
  EXPECT_EQ(platen_force[0], Eigen::Vector3d(5.0, 2.0, 0.0));
  EXPECT_EQ(platen_force[1], Eigen::Vector3d((1e16 + 1.0) + -1e16, 6.0, 0.0));
  EXPECT_EQ(platen_stiffness, (std::vector<double>{0.5, 1.5}));

  const StepRows without_1 = sorted_rows(std::span(&rows, 1));
  EXPECT_THROW(set_step_terms(without_1.keys, without_1.values, whole, stats, platen_force, platen_stiffness), DataError)
      << "grain 1 without an owner";
  EXPECT_THROW(sorted_rows(std::vector<StepRows>{rows, other, other}), DataError) << "grain 1 with two owners";
  StepRows beyond = all;
  beyond.keys.back() = platen_rows + 3 * 2;
  EXPECT_THROW(set_step_terms(beyond.keys, beyond.values, whole, stats, platen_force, platen_stiffness), DataError)
      << "a platen row of a fourth grain";
}

TEST(FdemRankState, ShareOwningEveryGrainStepsExactlyAsWithout) {
  Model m;
  const TetMesh cube = box_mesh(Eigen::Vector3d::Constant(1e-3), 0.5e-3);
  add_grain(m, cube, Eigen::Vector3d::Zero(), GrainKind::rigid, 0, 1);
  add_grain(m, cube, Eigen::Vector3d(1.01e-3, 0.3e-3, 0.1e-3), GrainKind::rigid, 0, 2);
  Solver plain(m, SolverOptions{}), shared(m, SolverOptions{});
  WholeShare share(2);
  shared.set_rank_share(&share);
  for (Solver* s : {&plain, &shared}) s->set_grain_velocity(0, Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 0, 300));
  const double dt = 0.5 * plain.time_step_limits().stable();
  for (int n = 0; n < 400; ++n) {
    const StepReport a = plain.step(dt), b = shared.step(dt);
    ASSERT_EQ(bits(a.energies.mechanical()), bits(b.energies.mechanical())) << "step " << n;
  }
  EXPECT_GT(share.owned_pairs, 0u) << "the cubes touched";
  for (std::size_t g = 0; g < 2; ++g) {
    expect_same_bits(plain.rigid_states()[g].position, shared.rigid_states()[g].position);
    expect_same_bits(plain.rigid_states()[g].angular_momentum, shared.rigid_states()[g].angular_momentum);
  }
}

TEST(FdemRankState, ContactRolesLeaveOutAbsentGrainsAndPairsWithoutAnOwnedOne) {
  Model m;  // two rigid cubes overlapping by 1 um
  const TetMesh cube = box_mesh(Eigen::Vector3d::Constant(1e-3), 0.5e-3);
  add_grain(m, cube, Eigen::Vector3d::Zero(), GrainKind::rigid, 0, 1);
  add_grain(m, cube, Eigen::Vector3d(0.999e-3, 0.2e-3, 0), GrainKind::rigid, 0, 2);
  Solver solver(m, SolverOptions{});
  ContactModel& contact = *solver.contact_model();
  const double dt = 0.1 * solver.time_step_limits().stable();
  const auto step_with = [&](std::vector<GrainRole> roles) {
    contact.set_grain_roles(roles);
    solver.step(dt);
    return solver.contacts().size();
  };
  // The overlap's energy is put in by the first step (a later one would count as a runaway).
  EXPECT_EQ(step_with({GrainRole::owned, GrainRole::ghost}), 1u);
  ASSERT_EQ(contact.owned_pair_sums().size(), 1u);
  EXPECT_GT(contact.owned_pair_sums()[0].elastic_energy, 0);
  EXPECT_EQ(step_with({GrainRole::owned, GrainRole::absent}), 0u);
  EXPECT_EQ(step_with({GrainRole::ghost, GrainRole::owned}), 1u);
  EXPECT_TRUE(contact.owned_pair_sums().empty()) << "the pair belongs to the owner of grain 0";
  EXPECT_EQ(step_with({GrainRole::ghost, GrainRole::ghost}), 0u);
  EXPECT_EQ(step_with({}), 1u) << "no roles: every grain owned";
  EXPECT_TRUE(contact.owned_pair_sums().empty());
}

TEST(FdemRankState, GrainsInContactAreSharedDeformableOnesByTheirNodes) {
  Model m;
  add_grain(m, box_mesh(Eigen::Vector3d::Constant(1e-3), 0.5e-3), Eigen::Vector3d::Zero(), GrainKind::tet4, 0, 1);
  Solver deformable(m, SolverOptions{});
  WholeShare share(1);
  EXPECT_NO_THROW(deformable.set_rank_share(&share));
  EXPECT_THROW(deformable.set_rigid_state(0, RigidBodyState{}), UsageError) << "a deformable grain travels by its nodes";
  deformable.set_node_state(3, Eigen::Vector3d(1, 2, 3), Eigen::Vector3d(4, 5, 6));
  EXPECT_EQ(deformable.state().x[3], Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(deformable.state().v[3], Eigen::Vector3d(4, 5, 6));
  deformable.set_rank_share(nullptr);
  SolverOptions without_contact;
  without_contact.contact.enabled = false;
  Solver apart(m, without_contact);
  EXPECT_THROW(apart.set_rank_share(&share), UsageError) << "ranks meet where grains touch";
  Model walls = four_cubes();
  walls.platens.push_back({});
  Solver with_platen(walls, SolverOptions{});
  WholeShare four(4);
  EXPECT_NO_THROW(with_platen.set_rank_share(&four)) << "platens are shared";
  EXPECT_THROW(with_platen.contact_model()->set_grain_roles(std::vector<GrainRole>(3)), UsageError);
}
