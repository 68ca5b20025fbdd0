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
  void finish_step(StepTotals& totals, StepRows&) override { steps_in_contact += totals.node_contacts.value() > 0; }
  std::size_t steps_in_contact = 0;

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

TEST(FdemRankState, TheRanksBoundaryRowsMergeInKeyOrderAndAGrainOwnedTwiceIsRefused) {
  // A wall's rows (key: the grain) from two ranks: one set in grain order, as one rank makes it.
  StepRows mine, theirs;
  mine.keys = {0, 2};
  mine.values = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10};
  theirs.keys = {1};
  theirs.values = {11, 12, 13, 14, 15};
  const StepRows all = sorted_rows(std::vector<StepRows>{mine, theirs});
  EXPECT_EQ(all.keys, (std::vector<std::uint64_t>{0, 1, 2}));
  EXPECT_EQ(all.values, (std::vector<double>{1, 2, 3, 4, 5, 11, 12, 13, 14, 15, 6, 7, 8, 9, 10}));
  EXPECT_THROW(sorted_rows(std::vector<StepRows>{mine, theirs, theirs}), DataError) << "grain 1 with two owners";
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
  EXPECT_GT(share.steps_in_contact, 0u) << "the cubes touched";
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
  EXPECT_EQ(contact.owned_pair_sums().size(), 1u) << "and every candidate";
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
