// mpi/distributed_run on 1, 2, 3 and 4 ranks (ctest runs this program through mpirun, label
// `mpi`): rigid grains thrown at each other cross the ranks' boxes many times in 1 000 steps, and
// every rank count must give every grain the state the plain one-rank Solver gives it in the same
// process, and the same energies every step; so must grains pressed between platens, and the
// platens' forces, and a triaxial test's servo wall and membrane.
#include "graintwin/mpi/distributed_run.hpp"

#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cstdio>
#include <numeric>
#include <random>
#include <tuple>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/primitives.hpp"
#include "graintwin/fdem/triaxial.hpp"

using namespace graintwin;

namespace {

const mpi::Session* g_session = nullptr;

constexpr int kSteps = 1000;
constexpr double kSpacing = 1.25e-3;  // m between lattice sites: 1 mm grains 0.05-0.45 mm apart
constexpr double kDrift = 8.0;        // m/s along x, the packing's common velocity
constexpr double kSpeed = 1.5;        // m/s, the largest component of a grain's own velocity

// 48 rigid boxes (1 mm cubes and 1.4 x 1 x 0.8 mm slabs) on an 8 x 3 x 2 lattice, each thrown at
// kDrift along x plus up to kSpeed per component in a random direction, and spun, under gravity:
// the packing churns, its grains colliding and turning, while it drifts about 5 mm across the
// ranks' boxes (cut across x), so grains change owner in contact and take their history along.
struct Scene {
  fdem::Model model;
  std::vector<Eigen::Vector3d> velocity, spin;
  fdem::Aabb domain;
};

/// `deformable`: the grains are elastic, 4-node and 10-node by turns, of a softer material (0.1 GPa:
/// a step as long as the rigid packing's).
Scene make_scene(bool deformable = false) {
  Scene s;
  const fdem::TetMesh cube = fdem::box_mesh(Eigen::Vector3d::Constant(1e-3), 0.5e-3);
  const fdem::TetMesh slab = fdem::box_mesh(Eigen::Vector3d(1.4e-3, 1e-3, 0.8e-3), 0.35e-3);
  std::mt19937_64 rng(28);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  s.model.materials[0].normal_penalty = s.model.materials[0].tangential_penalty = 1e11;  // a longer step
  std::uint32_t label = 1;
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 8; ++i) {
        const Eigen::Vector3d at(kSpacing * i, kSpacing * j, kSpacing * k);
        const fdem::GrainKind kind = !deformable ? fdem::GrainKind::rigid
                                     : label % 2 ? fdem::GrainKind::tet4
                                                 : fdem::GrainKind::tet10;
        fdem::add_grain(s.model, (i + j + k) % 3 == 0 ? slab : cube, at, kind, 0, label++);
        s.domain.grow(at);
        s.velocity.push_back(Eigen::Vector3d(kDrift, 0, 0) + kSpeed * Eigen::Vector3d(unit(rng), unit(rng), unit(rng)));
        s.spin.push_back(2e3 * Eigen::Vector3d(unit(rng), unit(rng), unit(rng)));
      }
  s.domain = s.domain.inflated(kSpacing / 2);
  if (deformable) s.model.materials[0].young = 1e8;
  return s;
}

fdem::SolverOptions options() {
  fdem::SolverOptions o;
  o.gravity = Eigen::Vector3d(0, 0, -9.81);
  return o;
}

std::unique_ptr<fdem::Solver> thrown(const Scene& s) {
  auto solver = std::make_unique<fdem::Solver>(s.model, options());
  for (std::size_t g = 0; g < s.velocity.size(); ++g) solver->set_grain_velocity(g, s.velocity[g], s.spin[g]);
  return solver;
}

std::uint64_t bits(double x) { return std::bit_cast<std::uint64_t>(x); }

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// Every grain's state gathered from its owner against the one-rank solver's: the largest position
/// difference relative to the lattice, and how many grains agree in every bit.
struct StateMatch {
  double worst = 0;
  std::size_t identical = 0;
};
/// The packing between a fixed bottom platen and a top one, 0.1 mm above it, coming down at 2 m/s.
Scene pressed_scene() {
  Scene scene = make_scene();
  scene.model.platens.push_back({"bottom", Eigen::Vector3d(0, 0, -0.6e-3), Eigen::Vector3d::UnitZ(), 0.3});
  scene.model.platens.push_back({"top", Eigen::Vector3d(0, 0, kSpacing + 0.6e-3), -Eigen::Vector3d::UnitZ(), 0.3});
  return scene;
}
std::unique_ptr<fdem::Solver> pressed(const Scene& scene) {
  std::unique_ptr<fdem::Solver> solver = thrown(scene);
  solver->set_platen_velocity(1, Eigen::Vector3d(0, 0, -2.0));
  return solver;
}

StateMatch match_states(const mpi::DistributedRun& run, const fdem::Solver& one) {
  const std::vector<fdem::RigidBodyState> all = run.gather_states();
  const std::span<const fdem::RigidBodyState> reference = one.rigid_states();
  StateMatch out;
  for (std::size_t g = 0; g < all.size(); ++g) {
    const double scale = std::max(reference[g].position.norm(), kSpacing);
    const double d = (all[g].position - reference[g].position).norm() / scale;
    out.worst = std::max(out.worst, d);
    EXPECT_LE(d, 1e-10) << "grain " << g;
    const Eigen::Vector4d q = all[g].orientation.coeffs(), q1 = reference[g].orientation.coeffs();
    bool same = true;
    for (int k = 0; k < 3; ++k)
      same = same && bits(all[g].position[k]) == bits(reference[g].position[k]) &&
             bits(all[g].velocity[k]) == bits(reference[g].velocity[k]) &&
             bits(all[g].angular_momentum[k]) == bits(reference[g].angular_momentum[k]);
    for (int k = 0; k < 4; ++k) same = same && bits(q[k]) == bits(q1[k]);
    out.identical += same;
  }
  return out;
}

}  // namespace

TEST(DistributedRun, RigidGrainsThrownAcrossRanksMoveAsOnOneRank) {
  const Scene scene = make_scene();
  std::unique_ptr<fdem::Solver> one = thrown(scene), mine = thrown(scene);
  const double dt = 0.5 * one->time_step_limits().stable();
  mpi::DistributedRun run(*g_session, *mine, scene.domain);
  const std::size_t grains = scene.model.grains.size();
  EXPECT_EQ(mpi::sum_over_ranks(*g_session, run.owned().size()), grains) << "one owner per grain";

  std::uint64_t energy_mismatches = 0, contacts = 0;
  double one_seconds = 0, run_seconds = 0;
  for (int n = 0; n < kSteps; ++n) {
    auto t0 = std::chrono::steady_clock::now();
    const fdem::StepReport expected = one->step(dt);
    one_seconds += seconds_since(t0);
    t0 = std::chrono::steady_clock::now();
    const fdem::StepReport got = run.step(dt);
    run_seconds += seconds_since(t0);
    const fdem::Energies &e = expected.energies, &r = got.energies;
    energy_mismatches += bits(e.kinetic) != bits(r.kinetic) || bits(e.contact_elastic) != bits(r.contact_elastic) ||
                         bits(e.dissipated) != bits(r.dissipated) || bits(e.external_work) != bits(r.external_work) ||
                         expected.contact.node_contacts != got.contact.node_contacts ||
                         bits(expected.contact.max_overlap) != bits(got.contact.max_overlap);
    contacts += expected.contact.node_contacts;
  }
  EXPECT_EQ(energy_mismatches, 0u) << "steps whose energies differ from one rank's in any bit";
  EXPECT_GT(contacts, 1000u) << "the grains collide";

  const auto [worst, identical] = match_states(run, *one);
  const mpi::RankTraffic& t = run.traffic();
  const std::uint64_t migrations = mpi::sum_over_ranks(*g_session, t.migrations);
  const std::uint64_t history = mpi::sum_over_ranks(*g_session, t.history);
  if (g_session->size() > 1) {
    EXPECT_GE(migrations, 8u * g_session->size()) << "grains change owner many times";
    EXPECT_GT(history, 0u) << "some in contact, with their friction history";
  }
  if (g_session->rank() == 0) {
    using ull = unsigned long long;
    std::printf("%d ranks, %zu grains, %d steps of %.3g s: largest position difference %.3g relative, %zu of %zu "
                "grains bit-identical, %llu node contacts over the steps; %llu migrations with %llu history "
                "entries\n",
                g_session->size(), grains, kSteps, dt, worst, identical, grains, ull(contacts), ull(migrations),
                ull(history));
    std::printf("rank 0: one-rank run %.3f s, its share %.3f s, of which the exchange %.3f s; sent %llu states, %llu "
                "doubles\n",
                one_seconds, run_seconds, t.exchange_seconds, ull(t.bodies), ull(t.doubles));
  }
  EXPECT_EQ(identical, grains) << "bit-identical states (the bound above is 1e-10)";
}

TEST(DistributedRun, PlatensPressingGrainsAcrossRanksFeelWhatTheyFeelOnOneRank) {
  // The churning packing between a fixed bottom platen and a top one coming down: each rank sums
  // the platen contacts of the grains it owns, and the exchange adds them in the one-rank order, so
  // the platens' forces and stiffnesses, their work and the grains' states match one rank's bits.
  const Scene scene = pressed_scene();
  std::unique_ptr<fdem::Solver> one = pressed(scene), mine = pressed(scene);
  const double dt = 0.5 * one->time_step_limits().stable();
  mpi::DistributedRun run(*g_session, *mine, scene.domain);
  std::uint64_t mismatches = 0;
  std::array<int, 2> steps_pressed{};
  for (int n = 0; n < kSteps; ++n) {
    const fdem::StepReport expected = one->step(dt), got = run.step(dt);
    mismatches += bits(expected.energies.external_work) != bits(got.energies.external_work) ||
                  bits(expected.energies.dissipated) != bits(got.energies.dissipated);
    for (std::size_t p = 0; p < 2; ++p) {
      for (int k = 0; k < 3; ++k) mismatches += bits(one->platen_force(p)[k]) != bits(mine->platen_force(p)[k]);
      mismatches += bits(one->platen_stiffness(p)) != bits(mine->platen_stiffness(p));
      steps_pressed[p] += one->platen_force(p).norm() > 0;
    }
  }
  EXPECT_EQ(mismatches, 0u) << "platen forces, stiffnesses and energies that differ from one rank's in any bit";
  EXPECT_GT(steps_pressed[0], 50) << "grains fall on the bottom platen";
  EXPECT_GT(steps_pressed[1], 50) << "the top platen meets grains";
  const StateMatch states = match_states(run, *one);
  EXPECT_EQ(states.identical, scene.model.grains.size()) << "bit-identical states";

  // For output, rank 0 gathers what one rank holds: contact records, grain stresses, history.
  run.gather_output();
  if (g_session->rank() == 0) {
    const std::span<const fdem::ContactRecord> got = mine->contacts(), expected = one->contacts();
    ASSERT_EQ(got.size(), expected.size());
    EXPECT_GT(got.size(), 10u);
    std::size_t differing = 0;
    for (std::size_t i = 0; i < got.size(); ++i) {
      const fdem::ContactRecord &c = got[i], &e = expected[i];
      bool same = c.a == e.a && c.b == e.b && bits(c.overlap) == bits(e.overlap) && bits(c.stiffness) == bits(e.stiffness);
      for (int k = 0; k < 3; ++k)
        same = same && bits(c.point[k]) == bits(e.point[k]) && bits(c.normal[k]) == bits(e.normal[k]) &&
               bits(c.force[k]) == bits(e.force[k]);
      differing += !same;
    }
    EXPECT_EQ(differing, 0u) << "contact records that differ from one rank's";
    for (std::size_t g = 0; g < scene.model.grains.size(); ++g) {
      const Eigen::Matrix3d a = mine->grain_stress(g), b = one->grain_stress(g);
      for (int k = 0; k < 9; ++k) EXPECT_EQ(bits(a(k)), bits(b(k))) << "grain " << g;
    }
    std::vector<std::uint32_t> every(scene.model.grains.size());
    std::iota(every.begin(), every.end(), 0u);
    const std::vector<fdem::ContactHistoryEntry> history = mine->contact_model()->history_of(every),
                                                 reference = one->contact_model()->history_of(every);
    ASSERT_EQ(history.size(), reference.size());
    for (std::size_t i = 0; i < history.size(); ++i) {
      EXPECT_EQ(std::tie(history[i].a, history[i].b, history[i].node), std::tie(reference[i].a, reference[i].b, reference[i].node));
      for (int k = 0; k < 3; ++k) EXPECT_EQ(bits(history[i].spring[k]), bits(reference[i].spring[k]));
    }
  }
  // Stepping goes on as before the gathering.
  for (int n = 0; n < 100; ++n) {
    const fdem::StepReport expected = one->step(dt), got = run.step(dt);
    mismatches += bits(expected.energies.kinetic) != bits(got.energies.kinetic);
  }
  EXPECT_EQ(mismatches, 0u) << "steps after the gathering that differ from one rank's";
  if (g_session->rank() == 0)
    std::printf("%d ranks with platens: the bottom platen pressed in %d steps, the top one in %d; largest position "
                "difference %.3g relative\n",
                g_session->size(), steps_pressed[0], steps_pressed[1], states.worst);
}

TEST(DistributedRun, CuttingTheSampleAgainByMeasuredWorkKeepsTheOneRankBits) {
  // The pressed packing, cut again by the work measured so far (forced at steps 300 and 700, by the
  // counts; the checks every 100 steps between decide nothing here, their windows far below
  // kBalanceWindowSeconds): grains change owner wholesale, with every state and the whole history,
  // and the run stays the one-rank run bit for bit.
  const Scene scene = pressed_scene();
  std::unique_ptr<fdem::Solver> one = pressed(scene), mine = pressed(scene);
  const double dt = 0.5 * one->time_step_limits().stable();
  mpi::DistributedRun run(*g_session, *mine, scene.domain);
  std::uint64_t mismatches = 0, moved = 0;
  for (int n = 1; n <= kSteps; ++n) {
    const fdem::StepReport expected = one->step(dt), got = run.step(dt);
    mismatches += bits(expected.energies.kinetic) != bits(got.energies.kinetic) ||
                  bits(expected.energies.external_work) != bits(got.energies.external_work);
    if (n % 100 == 0) {
      const std::vector<std::uint32_t> before(run.owned().begin(), run.owned().end());
      run.rebalance(n == 300 || n == 700);  // a cut that would leave a box too thin is skipped
      for (std::uint32_t g : before) moved += !std::binary_search(run.owned().begin(), run.owned().end(), g);
    }
  }
  moved = mpi::sum_over_ranks(*g_session, moved);
  EXPECT_EQ(mismatches, 0u) << "steps whose energies differ from one rank's in any bit";
  EXPECT_EQ(mpi::sum_over_ranks(*g_session, run.owned().size()), scene.model.grains.size()) << "one owner per grain";
  const StateMatch states = match_states(run, *one);
  EXPECT_EQ(states.identical, scene.model.grains.size()) << "bit-identical states";
  if (g_session->size() > 1) {
    EXPECT_GT(run.rebalances(), 0u) << "the measured work asked for a new cut";
    EXPECT_GT(moved, 0u) << "the new cuts moved grains between ranks";
  }
  if (g_session->rank() == 0)
    std::printf("%d ranks: cut again %zu times by measured work, moving %llu grains to other ranks\n", g_session->size(),
                run.rebalances(), static_cast<unsigned long long>(moved));
}

TEST(DistributedRun, DeformableGrainsAcrossRanksMoveAsOnOneRank) {
  // The churning packing of elastic 4- and 10-node boxes: the owner of a grain steps its elements
  // and sends its surface nodes to the ranks that ghost it, and all its nodes to its next owner.
  // Every step's energies, then every node's position, velocity and force and every grain's
  // element stress gathered on rank 0, must be the one-rank run's bits.
  const Scene scene = make_scene(true);
  std::unique_ptr<fdem::Solver> one = thrown(scene), mine = thrown(scene);
  const double dt = 0.5 * one->time_step_limits().stable();
  mpi::DistributedRun run(*g_session, *mine, scene.domain);
  constexpr int kDeformableSteps = 800;
  std::uint64_t mismatches = 0, contacts = 0;
  for (int n = 0; n < kDeformableSteps; ++n) {
    const fdem::StepReport expected = one->step(dt), got = run.step(dt);
    const fdem::Energies &e = expected.energies, &r = got.energies;
    mismatches += bits(e.kinetic) != bits(r.kinetic) || bits(e.strain) != bits(r.strain) ||
                  bits(e.contact_elastic) != bits(r.contact_elastic) || bits(e.dissipated) != bits(r.dissipated) ||
                  expected.contact.node_contacts != got.contact.node_contacts;
    contacts += expected.contact.node_contacts;
    if (n == kDeformableSteps / 2) run.rebalance(true);  // every rank takes every node, then its new share
  }
  EXPECT_EQ(mismatches, 0u) << "steps whose energies differ from one rank's in any bit";
  EXPECT_GT(contacts, 500u) << "the grains collide";
  const std::uint64_t migrations = mpi::sum_over_ranks(*g_session, run.traffic().migrations);
  if (g_session->size() > 1) {
    EXPECT_GE(migrations, 2u) << "grains change owner, with all their nodes";
  }

  run.gather_output();
  if (g_session->rank() == 0) {
    const fdem::SolverState &a = one->state(), &b = mine->state();
    const std::span<const Eigen::Vector3d> fa = one->node_forces(), fb = mine->node_forces();
    std::size_t differing = 0;
    for (std::size_t i = 0; i < a.x.size(); ++i)
      for (int k = 0; k < 3; ++k)
        differing += bits(a.x[i][k]) != bits(b.x[i][k]) || bits(a.v[i][k]) != bits(b.v[i][k]) || bits(fa[i][k]) != bits(fb[i][k]);
    EXPECT_EQ(differing, 0u) << "node coordinates, velocities and forces that differ from one rank's";
    const std::vector<Eigen::Matrix3d> stress_a = one->love_weber_stresses(), stress_b = mine->love_weber_stresses();
    for (std::size_t g = 0; g < scene.model.grains.size(); ++g)
      for (int k = 0; k < 9; ++k) {
        EXPECT_EQ(bits(one->grain_stress(g)(k)), bits(mine->grain_stress(g)(k))) << "grain " << g;
        EXPECT_EQ(bits(stress_a[g](k)), bits(stress_b[g](k))) << "grain " << g;
      }
    std::printf("%d ranks, deformable: %d steps of %.3g s, %llu node contacts over them, %llu migrations\n",
                g_session->size(), kDeformableSteps, dt, static_cast<unsigned long long>(contacts),
                static_cast<unsigned long long>(migrations));
  }
}

namespace {

constexpr double kEdge = 1e-3;  // m, the triaxial sample's cubes

/// A triaxial sample cut by the ranks along its height: 3 x 3 columns of 8 rigid 1 mm cubes, 2 %
/// apart, in a sample cylinder enclosing them, between platens "bottom" and "top" (each of 4 ranks
/// gets two layers, thick enough for a cube and the skin).
fdem::Model column_sample() {
  fdem::Model m;
  const fdem::TetMesh cube = fdem::box_mesh(Eigen::Vector3d::Constant(kEdge), 0.5 * kEdge);
  const double pitch = 1.02 * kEdge;
  constexpr int kLayers = 8;
  std::uint32_t label = 0;
  for (int i = -1; i <= 1; ++i)
    for (int j = -1; j <= 1; ++j)
      for (int k = 0; k < kLayers; ++k)
        fdem::add_grain(m, cube, Eigen::Vector3d(i * pitch, j * pitch, (k + 0.5) * pitch), fdem::GrainKind::rigid, 0, ++label);
  fdem::SampleCylinder s;
  s.radius = std::hypot(1.5 * pitch, 1.5 * pitch) * 1.01;
  s.z_min = 0.0;
  s.z_max = kLayers * pitch;
  m.sample = s;
  m.platens = {fdem::Platen{"bottom", Eigen::Vector3d(0, 0, s.z_min), Eigen::Vector3d::UnitZ(), 0.0},
               fdem::Platen{"top", Eigen::Vector3d(0, 0, s.z_max), -Eigen::Vector3d::UnitZ(), 0.0}};
  return m;
}

/// One side of the comparison: a solver with its triaxial boundary.
struct Triaxial {
  std::unique_ptr<fdem::Solver> solver;
  std::unique_ptr<fdem::TriaxialBoundary> boundary;
};
Triaxial triaxial(const fdem::Model& model, const fdem::TriaxialOptions& o) {
  fdem::SolverOptions so;
  so.damping = 2e3;  // 1/s: quasi-static settling
  Triaxial t;
  t.solver = std::make_unique<fdem::Solver>(model, so);
  t.boundary = std::make_unique<fdem::TriaxialBoundary>(model, o, fdem::grains_d50(*t.solver));
  t.solver->set_boundary(t.boundary.get());
  return t;
}

/// Runs a consolidation for at most `steps`: whether it settled (it throws DataError when not).
template <class Procedure>
bool settles(Procedure&& procedure) {
  try {
    procedure();
    return true;
  } catch (const DataError&) {
    return false;
  }
}

}  // namespace

TEST(DistributedRun, ATriaxialTestAcrossRanksServoesItsWallAndMovesItsMembraneAsOnOneRank) {
  // The sample consolidates in the servo wall, then the membrane replaces it under the confining
  // pressure and the platens shear the sample. Every rank holds the whole wall or membrane; the
  // contacts of its own grains with it travel with the step's terms and every rank adds all of
  // them in the one-rank order, so the servo reads the same stresses everywhere and the grains,
  // the wall, the balls and the energies keep one rank's bits.
  const fdem::Model model = column_sample();
  fdem::TriaxialOptions o;
  o.ball_radius = model.sample->radius / 15;  // a coarse membrane keeps the test fast
  o.membrane_friction = 0.3;                  // the balls' friction springs must follow their grains' owners
  o.servo_inertial_number = 0.1;              // the wall reaches the grains within the test's steps
  Triaxial one = triaxial(model, o), mine = triaxial(model, o);
  fdem::Aabb domain;
  for (const Eigen::Vector3d& x : model.nodes) domain.grow(x);
  const double dt = 0.9 * one.solver->time_step_limits().stable();
  mpi::DistributedRun run(*g_session, *mine.solver, domain.inflated(0.5 * kEdge));
  const fdem::PlatenPair platens = fdem::find_platens(model);

  std::uint64_t mismatches = 0, steps = 0, wall_contacts = 0, ball_contacts = 0;
  const auto compare = [&](const fdem::TriaxialMeasure& expected, const fdem::StepReport& e, const fdem::TriaxialMeasure& got,
                           const fdem::StepReport& r) {
    mismatches += bits(e.energies.kinetic) != bits(r.energies.kinetic) ||
                  bits(e.energies.contact_elastic) != bits(r.energies.contact_elastic) ||
                  bits(e.energies.dissipated) != bits(r.energies.dissipated) ||
                  bits(e.energies.external_work) != bits(r.energies.external_work) ||
                  bits(expected.axial_stress) != bits(got.axial_stress) ||
                  bits(expected.lateral_stress) != bits(got.lateral_stress) || bits(expected.volume) != bits(got.volume);
    ++steps;
  };
  // The one-rank side's measurements, step by step, then the ranks' side checked against them.
  std::vector<std::pair<fdem::TriaxialMeasure, fdem::StepReport>> reference;
  const auto record = [&](const fdem::TriaxialMeasure& m, const fdem::StepReport& r) {
    reference.emplace_back(m, r);
    (one.boundary->has_membrane() ? ball_contacts : wall_contacts) += one.boundary->last_contact().contacts;
  };
  std::size_t at = 0;
  const auto check = [&](const fdem::TriaxialMeasure& m, const fdem::StepReport& r) {
    ASSERT_LT(at, reference.size()) << "more steps across ranks than on one rank";
    compare(reference[at].first, reference[at].second, m, r);
    ++at;
  };

  // Consolidation inside the servo wall, 400 steps.
  const bool wall_one = settles([&] { fdem::consolidate_in_wall(*one.solver, *one.boundary, o, dt, 400, record); });
  const bool wall_mine = settles([&] { fdem::consolidate_in_wall(*mine.solver, *mine.boundary, o, dt, 400, check); });
  EXPECT_EQ(wall_one, wall_mine);
  EXPECT_EQ(bits(one.boundary->wall().radius), bits(mine.boundary->wall().radius));

  // The membrane replaces the wall, released at once under sigma_3; the platens shear the sample
  // to 0.4 % axial strain, the ranks cut the sample again half way.
  for (Triaxial* t : {&one, &mine}) {
    t->solver->stop_grains();
    t->boundary->install_membrane(*t->solver->contact_model(), dt);
    t->boundary->set_membrane_fixed(false);
    t->boundary->set_pressure(o.confining_pressure);
  }
  fdem::ShearOptions shearing;
  shearing.strain_rate = 4e-3 / (600 * dt);  // about 600 steps
  shearing.target_axial_strain = 4e-3;
  const std::size_t shear_steps = fdem::shear(*one.solver, *one.boundary, o, shearing, dt, record);
  std::size_t taken = 0;
  fdem::shear(*mine.solver, *mine.boundary, o, shearing, dt, [&](const fdem::TriaxialMeasure& m, const fdem::StepReport& r) {
    check(m, r);
    if (++taken == shear_steps / 2) run.rebalance(true);
  });
  EXPECT_EQ(at, reference.size()) << "as many steps across ranks as on one rank";
  EXPECT_EQ(mismatches, 0u) << "steps whose energies or measurements differ from one rank's in any bit";
  EXPECT_GT(wall_contacts, 100u) << "the grains pressed on the wall";
  EXPECT_GT(ball_contacts, 100u) << "the grains pressed on the membrane";

  const StateMatch states = match_states(run, *one.solver);
  EXPECT_EQ(states.identical, model.grains.size()) << "bit-identical grain states";
  const std::span<const Eigen::Vector3d> balls = one.boundary->membrane_state()->x, my_balls = mine.boundary->membrane_state()->x;
  ASSERT_EQ(balls.size(), my_balls.size());
  std::size_t differing_balls = 0;
  for (std::size_t b = 0; b < balls.size(); ++b)
    for (int k = 0; k < 3; ++k) differing_balls += bits(balls[b][k]) != bits(my_balls[b][k]);
  EXPECT_EQ(differing_balls, 0u) << "membrane ball coordinates that differ from one rank's";
  for (std::size_t p : {platens.bottom, platens.top})
    for (int k = 0; k < 3; ++k) EXPECT_EQ(bits(one.solver->platen_force(p)[k]), bits(mine.solver->platen_force(p)[k]));
  if (g_session->rank() == 0)
    std::printf("%d ranks, triaxial: %llu steps (wall settled: %s), %llu wall and %llu ball contacts over them, "
                "%zu membrane balls; largest position difference %.3g relative\n",
                g_session->size(), static_cast<unsigned long long>(steps), wall_one ? "yes" : "no",
                static_cast<unsigned long long>(wall_contacts), static_cast<unsigned long long>(ball_contacts), balls.size(),
                states.worst);
}

TEST(DistributedRun, TooManyRanksForTheSampleAreRefusedOnEveryRank) {
  // Three 1 mm cubes in a row, 0.1 mm apart: any cut leaves a subdomain thinner than a grain
  // (1.7 mm across its corners) and the skin.
  fdem::Model m;
  const fdem::TetMesh cube = fdem::box_mesh(Eigen::Vector3d::Constant(1e-3), 0.5e-3);
  fdem::Aabb domain;
  for (int i = 0; i < 3; ++i) {
    fdem::add_grain(m, cube, Eigen::Vector3d(1.1e-3 * i, 0, 0), fdem::GrainKind::rigid, 0, i + 1);
    domain.grow(Eigen::Vector3d(1.1e-3 * i, 0, 0));
  }
  domain = domain.inflated(0.5e-3);
  fdem::Solver solver(m, options());
  if (g_session->size() == 1) {
    mpi::DistributedRun run(*g_session, solver, domain);
    EXPECT_EQ(run.owned().size(), 3u);
    return;
  }
  try {
    mpi::DistributedRun run(*g_session, solver, domain);
    ADD_FAILURE() << "no refusal on rank " << g_session->rank();
  } catch (const UsageError& e) {
    EXPECT_NE(e.message().find("less than the largest grain's diameter plus the contact skin"), std::string::npos)
        << e.message();
    EXPECT_NE(e.message().find("run on at most 1 ranks"), std::string::npos) << e.message();
  }
  solver.step(1e-9);  // the refusal handed the solver back: it steps every grain again
  EXPECT_EQ(solver.step_count(), 1u);
}

int main(int argc, char** argv) {
  // One thread per rank: up to 4 ranks share CI's 2 cores, where each step's OpenMP barriers of
  // several threads per rank cost more than the small scene's work (runs of a minute were seen).
  omp_set_num_threads(1);
  mpi::Session session(argc, argv);
  g_session = &session;
  ::testing::InitGoogleTest(&argc, argv);
  // An exception on one rank ends the whole job (it leaves main, and mpirun stops the others)
  // rather than being caught by the test while the other ranks wait for this one in a collective.
  GTEST_FLAG_SET(catch_exceptions, false);
  return RUN_ALL_TESTS();
}
