// fdem/ solver: central differences under gravity (exact for constant acceleration), mass-
// proportional damping, the time-step checks (refusal with the numbers; NaN stops the run with the
// step and the cause), per-grain kinds, and checkpoints that restart bit for bit.
#include <gtest/gtest.h>

#include <cmath>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/mass_scaling.hpp"
#include "graintwin/fdem/primitives.hpp"
#include "graintwin/fdem/solver.hpp"
#include "graintwin/io/h5file.hpp"
#include "support/run_tool.hpp"

using namespace graintwin;
using namespace graintwin::fdem;

namespace {

SolverOptions no_contact() {
  SolverOptions o;
  o.contact.enabled = false;
  return o;
}

/// Two grains side by side: a deformable box (tet4 or tet10) and a rigid one.
Model two_boxes(GrainKind first) {
  Model m;
  add_grain(m, box_mesh({1e-3, 1e-3, 1e-3}, 0.5e-3), Eigen::Vector3d(0, 0, 0), first, 0, 1);
  add_grain(m, box_mesh({2e-3, 1e-3, 0.5e-3}, 0.5e-3), Eigen::Vector3d(5e-3, 0, 0), GrainKind::rigid, 0, 2);
  return m;
}

}  // namespace

TEST(FdemSolver, FreeFallIsExactForEveryKind) {
  for (GrainKind kind : {GrainKind::tet4, GrainKind::tet10}) {
    const Model m = two_boxes(kind);
    SolverOptions o = no_contact();
    o.gravity = Eigen::Vector3d(0, 0, -9.81);
    Solver s(m, o);
    const Eigen::Vector3d v0(0.3, -0.1, 2.0);
    s.set_grain_velocity(0, v0, Eigen::Vector3d::Zero());
    s.set_grain_velocity(1, v0, Eigen::Vector3d::Zero());
    const double dt = 0.5 * s.time_step_limits().stable();
    for (int n = 0; n < 200; ++n) s.step(dt);
    const double t = s.state().time;
    const Eigen::Vector3d expected = v0 * t + 0.5 * o.gravity * t * t;
    for (std::size_t g = 0; g < 2; ++g)
      // Exact up to the rounding of x += dt v at |x| ~ 5 mm over 200 steps.
      EXPECT_LT((s.grain_centroid(g) - s.body(g).centroid - expected).norm(), 1e-15) << "grain " << g;
    // Nothing deforms: free fall stores no strain energy.
    EXPECT_LT(s.step(dt).energies.strain, 1e-20);
  }
}

TEST(FdemSolver, GrainSpinIsTheAngularVelocityOfEveryKind) {
  // Spun as rigid bodies, a deformable box and a rigid one report the spin they were given (a
  // deformable grain's from its nodes' angular momentum through their inertia), and after free
  // steps the rigid one still holds its angular momentum through its turned inertia.
  for (GrainKind kind : {GrainKind::tet4, GrainKind::tet10}) {
    const Model m = two_boxes(kind);
    Solver s(m, no_contact());
    const Eigen::Vector3d omega(300, -200, 500);
    s.set_grain_velocity(0, {0.1, 0, 0}, omega);
    s.set_grain_velocity(1, {0, 0.1, 0}, omega);
    for (std::size_t g = 0; g < 2; ++g) EXPECT_LT((s.grain_spin(g) - omega).norm(), 1e-12 * omega.norm()) << "grain " << g;
    const double dt = 0.5 * s.time_step_limits().stable();
    for (int n = 0; n < 100; ++n) s.step(dt);
    const RigidBodyState& b = s.state().bodies[1];
    const Eigen::Matrix3d R = b.orientation.toRotationMatrix();
    EXPECT_LT((R * s.body(1).inertia * R.transpose() * s.grain_spin(1) - b.angular_momentum).norm(),
              1e-12 * b.angular_momentum.norm());
    EXPECT_GT((s.grain_spin(1) - omega).norm(), 1e-6 * omega.norm()) << "the box is no sphere: its spin must precess";
  }
}

TEST(FdemSolver, MassProportionalDampingDecaysExponentially) {
  const Model m = two_boxes(GrainKind::tet4);
  SolverOptions o = no_contact();
  o.damping = 2e4;  // 1/s
  Solver s(m, o);
  s.set_grain_velocity(0, {1, 0, 0}, Eigen::Vector3d::Zero());
  s.set_grain_velocity(1, {1, 0, 0}, Eigen::Vector3d::Zero());
  const double dt = 0.5 * s.time_step_limits().stable();
  StepReport r;
  for (int n = 0; n < 2000; ++n) r = s.step(dt);
  const double t = s.state().time - dt;  // energies are those at the start of the last step
  const double expected = 2 * 0.5 * (s.body(0).mass + s.body(1).mass) / 2 * std::exp(-2 * o.damping * t);
  EXPECT_NEAR(r.energies.kinetic, expected, 1e-4 * expected);
  // Every joule lost is booked as dissipated.
  const double initial = 0.5 * (s.body(0).mass + s.body(1).mass);
  EXPECT_NEAR(r.energies.kinetic + r.energies.dissipated, initial, 2e-3 * initial);
}

TEST(FdemSolver, TimeStepAboveTheLimitIsRefusedWithTheNumbers) {
  const Model m = two_boxes(GrainKind::tet10);
  Solver s(m, no_contact());
  const StepLimits lim = s.time_step_limits();
  EXPECT_GT(lim.element_critical, 0);
  EXPECT_TRUE(std::isinf(lim.contact_stable));
  EXPECT_NO_THROW(s.check_time_step(0.99 * lim.stable()));
  try {
    s.check_time_step(1.5 * lim.stable());
    FAIL() << "a step above the stable limit was accepted";
  } catch (const UsageError& e) {
    EXPECT_NE(e.message().find("above the stable limit"), std::string::npos) << e.message();
    EXPECT_NE(e.message().find("element"), std::string::npos) << e.message();
  }
  EXPECT_THROW(s.check_time_step(-1), UsageError);
}

TEST(FdemSolver, UnstableStepStopsWithStepNumberAndCause) {
  Model m;
  add_grain(m, box_mesh({2e-3, 1e-3, 1e-3}, 0.5e-3), Eigen::Vector3d::Zero(), GrainKind::tet4, 0, 1);
  Solver s(m, no_contact());
  s.set_grain_velocity(0, Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 0, 1e3));
  // Shake it: a random nodal velocity field excites the highest modes.
  auto& v = const_cast<std::vector<Eigen::Vector3d>&>(s.state().v);
  for (std::size_t i = 0; i < v.size(); ++i) v[i] += 0.1 * Eigen::Vector3d(std::sin(7.0 * i), std::cos(3.0 * i), std::sin(11.0 * i));
  const double dt = 3 * s.time_step_limits().element_critical;
  try {
    for (int n = 0; n < 2000; ++n) s.step(dt);
    FAIL() << "a step 3x above the critical one ran 2000 steps";
  } catch (const DataError& e) {
    EXPECT_NE(e.message().find("step "), std::string::npos);
    EXPECT_NE(e.message().find("likely cause"), std::string::npos) << e.message();
    EXPECT_NE(e.message().find("smaller time step"), std::string::npos) << e.message();
  }
}

TEST(FdemSolver, ARoundOffOfEnergyIsNoRunaway) {
  // A deformable grain at rest, touched by a velocity of 1e-15 m/s: energy put in ~1e-37 J; the
  // round-off of its strain energy may exceed 10 x that, which is no runaway (an absolute floor of
  // 1e-12 E V applies), while a genuine instability still stops (the test above).
  Model m;
  add_grain(m, box_mesh({1e-3, 1e-3, 1e-3}, 0.5e-3), Eigen::Vector3d::Zero(), GrainKind::tet10, 0, 1);
  Solver s(m, no_contact());
  s.set_grain_velocity(0, Eigen::Vector3d(1e-15, 0, 0), Eigen::Vector3d(0, 0, 1e-9));
  const double dt = s.time_step_limits().stable();
  EXPECT_NO_THROW(for (int n = 0; n < 2000; ++n) s.step(dt));
}

TEST(FdemSolver, CheckpointRestartReproducesTheRunBitForBit) {
  const Model m = two_boxes(GrainKind::tet10);
  SolverOptions o = no_contact();
  o.gravity = Eigen::Vector3d(0, -9.81, 0);
  o.damping = 100;
  Solver a(m, o);
  a.set_grain_velocity(0, {0.1, 0, 0}, {0, 300, 500});
  a.set_grain_velocity(1, {0, 0.2, 0}, {800, -200, 100});
  const double dt = 0.5 * a.time_step_limits().stable();
  for (int n = 0; n < 150; ++n) a.step(dt);
  test::TempDir dir;
  {
    io::H5File f = io::H5File::create(dir / "checkpoint.h5");
    a.save(f, "/state");
  }
  Solver b(m, o);
  b.load(io::H5File::open(dir / "checkpoint.h5"), "/state");
  EXPECT_EQ(b.state().step, 150u);
  for (int n = 0; n < 150; ++n) {
    const StepReport ra = a.step(dt), rb = b.step(dt);
    ASSERT_EQ(ra.energies.kinetic, rb.energies.kinetic) << "step " << n;
  }
  EXPECT_EQ(a.state().x, b.state().x);
  EXPECT_EQ(a.state().v, b.state().v);
  EXPECT_EQ(a.state().time, b.state().time);
  EXPECT_EQ(a.grain_rotation(1).coeffs(), b.grain_rotation(1).coeffs());
  // A checkpoint of another model is refused.
  Model other;
  add_grain(other, box_mesh({1e-3, 1e-3, 1e-3}, 0.25e-3), Eigen::Vector3d::Zero(), GrainKind::tet4, 0, 1);
  Solver c(other, o);
  EXPECT_THROW(c.load(io::H5File::open(dir / "checkpoint.h5"), "/state"), DataError);
}

// A rigid 1 mm cube squeezed between two platens that both cut 1 um into it: the forces on its
// faces balance, and its Love-Weber stress is sigma_zz = -F / A (F the platen force, A = 1 mm^2)
// with nothing else, to round-off; before the first step it is zero.
TEST(FdemSolver, RigidGrainStressIsTheLoveWeberAverageOfItsContactForces) {
  Model m;
  add_grain(m, box_mesh(Eigen::Vector3d::Constant(1e-3), 0.25e-3), Eigen::Vector3d::Zero(), GrainKind::rigid, 0, 1);
  m.platens = {Platen{"bottom", Eigen::Vector3d(0, 0, -0.5e-3 + 1e-6), Eigen::Vector3d::UnitZ(), 0.0},
               Platen{"top", Eigen::Vector3d(0, 0, 0.5e-3 - 1e-6), -Eigen::Vector3d::UnitZ(), 0.0}};
  Solver s(m, SolverOptions{});
  EXPECT_EQ(s.grain_stress(0), Eigen::Matrix3d::Zero());
  s.step(0.5 * s.time_step_limits().stable());
  const double F = s.platen_force(1).z();
  ASSERT_GT(F, 0);
  EXPECT_NEAR(s.platen_force(0).z(), -F, 1e-9 * F);
  const Eigen::Matrix3d sigma = s.grain_stress(0);
  EXPECT_NEAR(sigma(2, 2), -F / 1e-6, 1e-6 * F / 1e-6);
  Eigen::Matrix3d rest = sigma;
  rest(2, 2) = 0;
  EXPECT_LT(rest.cwiseAbs().maxCoeff(), 1e-6 * F / 1e-6);
}

TEST(FdemSolver, MassScalingLiftsTheFastestGrainsToTheNextGrainsStep) {
  // Three 1 mm boxes, a 0.5 mm one and a 0.25 mm one, rigid: the smaller a box, the lighter its
  // contact nodes for their stiffness and the shorter its step.
  Model m;
  for (int k = 0; k < 3; ++k)
    add_grain(m, box_mesh(Eigen::Vector3d::Constant(1e-3), 0.25e-3), Eigen::Vector3d(3e-3 * k, 0, 0), GrainKind::rigid, 0, k + 1);
  add_grain(m, box_mesh(Eigen::Vector3d::Constant(0.5e-3), 0.125e-3), Eigen::Vector3d(9e-3, 0, 0), GrainKind::rigid, 0, 4);
  add_grain(m, box_mesh(Eigen::Vector3d::Constant(0.25e-3), 0.0625e-3), Eigen::Vector3d(12e-3, 0, 0), GrainKind::rigid, 0, 5);
  const Solver before(m, {});
  const std::vector<double> steps = before.contact_model()->grain_time_steps();
  ASSERT_LT(steps[4], steps[3]);
  ASSERT_LT(steps[3], steps[0]);
  EXPECT_EQ(before.time_step_limits().contact_stable, steps[4]);
  Model unscaled = m;
  EXPECT_EQ(scale_fastest_grains(unscaled, before, 0.0).grains, 0u);
  EXPECT_THROW(scale_fastest_grains(unscaled, before, 0.3), UsageError);
  // A tenth of five grains is none.
  EXPECT_EQ(scale_fastest_grains(unscaled, before, 0.1).grains, 0u);
  EXPECT_EQ(unscaled.materials.size(), m.materials.size());
  // A fifth is the smallest box, lifted to the 0.5 mm box's step.
  const MassScaling scaling = scale_fastest_grains(m, before, 0.2);
  ASSERT_EQ(scaling.grains, 1u);
  EXPECT_EQ(scaling.scaled[0], 4u);
  EXPECT_NEAR(scaling.factors[0], (steps[3] / steps[4]) * (steps[3] / steps[4]), 1e-12);
  double total = 0;
  for (std::size_t g = 0; g < 5; ++g) total += before.body(g).mass;
  EXPECT_NEAR(scaling.mass_share, before.body(4).mass / total, 1e-12);
  ASSERT_EQ(m.materials.size(), unscaled.materials.size() + 1);
  EXPECT_EQ(m.grains[4].material, m.materials.size() - 1);
  EXPECT_NEAR(m.materials.back().density, m.materials[0].density * scaling.factors[0], 1e-9);
  const Solver after(m, {});
  EXPECT_NEAR(after.time_step_limits().contact_stable, steps[3], 1e-9 * steps[3]);
  EXPECT_NEAR(after.body(4).mass, before.body(4).mass * scaling.factors[0], 1e-12 * after.body(4).mass);
  // A solver whose masses are refreshed in place holds what the one built again holds, bit for bit.
  Solver refreshed(unscaled, {});
  const MassScaling again = scale_fastest_grains(unscaled, refreshed, 0.2);
  refreshed.refresh_masses(again.scaled);
  for (std::size_t g = 0; g < 5; ++g) {
    EXPECT_EQ(refreshed.body(g).mass, after.body(g).mass) << g;
    EXPECT_EQ(refreshed.body(g).inertia, after.body(g).inertia) << g;
  }
  ASSERT_EQ(refreshed.contact_node_mass().size(), after.contact_node_mass().size());
  for (std::size_t i = 0; i < after.contact_node_mass().size(); ++i) {
    ASSERT_EQ(refreshed.node_mass()[i], after.node_mass()[i]) << i;
    ASSERT_EQ(refreshed.contact_node_mass()[i], after.contact_node_mass()[i]) << i;
  }
  EXPECT_EQ(refreshed.time_step_limits().contact_stable, after.time_step_limits().contact_stable);
}

TEST(FdemSolver, DeformableGrainsScaledInPlaceKeepTheirStiffness) {
  // Density scaling gives a grain a copy of its material after the solver built its elements; a
  // 10-node grain's elements must still find its elastic constants (they once read a cache of the
  // materials there were, past its end: the deformable twin turned NaN in its second step).
  for (GrainKind kind : {GrainKind::tet4, GrainKind::tet10}) {
    Model m = two_boxes(kind);
    Solver refreshed(m, no_contact());
    Material heavier = m.materials[0];
    heavier.density *= 4;
    m.materials.push_back(heavier);
    m.grains[0].material = 1;
    const std::uint32_t scaled[] = {0};
    refreshed.refresh_masses(scaled);
    Solver built(m, no_contact());
    // Both spin the box at the same rate and deform it alike, bit for bit.
    Solver* solvers[] = {&refreshed, &built};
    StepReport reports[2];
    for (int k = 0; k < 2; ++k) {
      solvers[k]->set_grain_velocity(0, Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 0, 3e3));
      const double dt = 0.5 * solvers[k]->time_step_limits().stable();
      for (int n = 0; n < 50; ++n) reports[k] = solvers[k]->step(dt);
    }
    EXPECT_GT(reports[0].energies.strain, 0) << enum_name(kGrainKindNames, kind);
    EXPECT_EQ(reports[0].energies.strain, reports[1].energies.strain) << enum_name(kGrainKindNames, kind);
    EXPECT_EQ(reports[0].energies.kinetic, reports[1].energies.kinetic) << enum_name(kGrainKindNames, kind);
  }
}
