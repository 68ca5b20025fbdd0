// The triaxial boundary (fdem/triaxial.hpp) on 27 rigid cubes: isotropic consolidation inside the
// servo wall reaches sigma_3 within 1 % on the wall and both platens; the membrane that replaces the
// wall (forming procedure) carries sigma_3 while the platens servo to it within 1 %, without
// entering the grains, and eq. 27 = eq. 28; strain-controlled shearing reaches its log strain at
// the set rate with sigma_1 > sigma_3; bad input is refused.
#include "graintwin/fdem/triaxial.hpp"
#include "graintwin/fdem/triaxial_run.hpp"

#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <limits>
#include <numbers>

#include "graintwin/core/error.hpp"
#include "graintwin/io/h5file.hpp"
#include "support/cube_sample.hpp"
#include "support/run_tool.hpp"

using namespace graintwin;
using namespace graintwin::fdem;

namespace {

constexpr double kEdge = 1e-3;

Model cube_sample() { return test::cube_sample(kEdge); }

}  // namespace

TEST(Triaxial, ConsolidatesInTheWallThenInTheMembraneAndShears) {
  omp_set_num_threads(1);  // 27 grains: threads would only wait on each other (ctest runs suites side by side)
  const Model model = cube_sample();
  SolverOptions so;
  so.damping = 2e3;  // 1/s: quasi-static settling
  Solver solver(model, so);
  TriaxialOptions o;
  o.ball_radius = model.sample->radius / 15;  // a coarse membrane (ratio 15) keeps the test fast
  TriaxialBoundary boundary(model, o, grains_d50(solver));
  solver.set_boundary(&boundary);
  const double dt = 0.9 * solver.time_step_limits().stable();
  const double v0 = boundary.volume();
  const std::size_t steps = consolidate_in_wall(solver, boundary, o, dt, 200000);
  const PlatenPair platens = find_platens(model);
  const TriaxialMeasure m = measure(solver, boundary, platens);
  EXPECT_NEAR(m.axial_stress, o.confining_pressure, 0.01 * o.confining_pressure) << steps << " steps";
  EXPECT_NEAR(boundary.wall_stress(), o.confining_pressure, 0.01 * o.confining_pressure);
  EXPECT_LT(m.volume, v0);
  // The cubes are packed: the wall came in to the corners of the outer columns.
  EXPECT_LT(boundary.wall().radius, model.sample->radius);

  // The forming procedure goes on: the membrane replaces the wall (fixed while the grains settle,
  // then released under the ramped pressure) and the platens servo to sigma_3 again. It wraps
  // the square block of cubes (less volume than the wall's cylinder) without entering it.
  const double dt_membrane = 0.9 * solver.time_step_limits().stable();
  const std::size_t membrane_steps = consolidate_in_membrane(solver, boundary, o, dt_membrane, 500, 100000);
  ASSERT_TRUE(boundary.has_membrane());
  const TriaxialMeasure after = measure(solver, boundary, platens);
  EXPECT_NEAR(after.axial_stress, o.confining_pressure, 0.01 * o.confining_pressure) << membrane_steps << " steps";
  EXPECT_DOUBLE_EQ(after.lateral_stress, o.confining_pressure);
  EXPECT_LT(after.volume, m.volume);
  EXPECT_GT(after.volume, 0.98 * std::pow(3 * kEdge, 2) * after.height);
  EXPECT_NEAR(after.volume_radial, after.volume, 1e-9 * after.volume);
  // The balls press on the grains without entering them: overlaps far below a ball radius.
  EXPECT_GT(boundary.last_contact().contacts, 0u);
  EXPECT_LT(boundary.last_contact().max_overlap, 0.1 * boundary.ball_radius());

  // Shearing: the platens close at the strain rate until eps_1 = ln(H0 / H) reaches the target;
  // the columns of rigid cubes carry the load, so sigma_1 climbs far above sigma_3.
  ShearOptions shearing;
  shearing.strain_rate = 5.0;
  shearing.target_axial_strain = 1e-3;
  std::size_t rows = 0;
  double last_strain = 0, largest_gap = 0;
  const double h0 = after.height;
  shear(solver, boundary, o, shearing, dt_membrane, [&](const TriaxialMeasure& row, const StepReport&) {
    ++rows;
    const double strain = std::log(h0 / row.height);
    EXPECT_GE(strain, last_strain);
    last_strain = strain;
    largest_gap = std::max(largest_gap, std::abs(row.volume_radial / row.volume - 1));
  });
  const TriaxialMeasure end = measure(solver, boundary, platens);
  EXPECT_NEAR(std::log(h0 / end.height), shearing.target_axial_strain, 1e-4);
  // The gap closes linearly: H0 - H = H0 (1 - exp(-eps_1)) at strain_rate x H0 per second.
  EXPECT_NEAR(double(rows), -std::expm1(-shearing.target_axial_strain) / (shearing.strain_rate * dt_membrane), 1.5);
  EXPECT_GT(end.axial_stress / end.lateral_stress, 2.0);
  EXPECT_LT(largest_gap, 1e-9);
}

TEST(Triaxial, AServoNeverMovesFasterThanItsContactsStiffnessAllows) {
  // 1e5 N/m of contact under a 10 N force error: one step of 1e-6 s may close at most
  // 0.25 x 10 / 1e5 = 2.5e-5 m, i.e. 25 m/s; slower servos and untouched boundaries pass unchanged.
  EXPECT_DOUBLE_EQ(stiffness_limited_velocity(-100.0, 10.0, 1e5, 1e-6), -25.0);
  EXPECT_DOUBLE_EQ(stiffness_limited_velocity(100.0, -10.0, 1e5, 1e-6), 25.0);
  EXPECT_DOUBLE_EQ(stiffness_limited_velocity(3.0, 10.0, 1e5, 1e-6), 3.0);
  EXPECT_DOUBLE_EQ(stiffness_limited_velocity(-100.0, 10.0, 0.0, 1e-6), -100.0);
}

TEST(Triaxial, AFastServoSettlesOnStiffGrains) {
  // Columns of rigid cubes are far stiffer than a sand packing: at a servo inertial number of 0.3
  // the wall and platens would cross the whole 10 % proportional band in one step and swing about
  // sigma_3 without settling; judged by their contacts' stiffness they settle to 1 %.
  omp_set_num_threads(1);
  const Model model = cube_sample();
  SolverOptions so;
  so.damping = 2e3;
  Solver solver(model, so);
  TriaxialOptions o;
  o.servo_inertial_number = 0.3;
  TriaxialBoundary boundary(model, o, grains_d50(solver));
  solver.set_boundary(&boundary);
  const double dt = 0.9 * solver.time_step_limits().stable();
  std::size_t steps = 0;
  ASSERT_NO_THROW(steps = consolidate_in_wall(solver, boundary, o, dt, 20000));
  const TriaxialMeasure m = measure(solver, boundary, find_platens(model));
  EXPECT_NEAR(m.axial_stress, o.confining_pressure, 0.01 * o.confining_pressure) << steps << " steps";
  EXPECT_NEAR(boundary.wall_stress(), o.confining_pressure, 0.01 * o.confining_pressure);
  EXPECT_GT(boundary.wall_stiffness(), 0);
  EXPECT_GT(solver.platen_stiffness(0) + solver.platen_stiffness(1), 0);
}

TEST(Triaxial, RefusesAMembranePoissonRatioAboveOneThirdACheckpointAndAModelWithoutPlatens) {
  Model model = cube_sample();
  TriaxialOptions o;
  o.membrane.poisson = 0.49;
  EXPECT_THROW(TriaxialBoundary(model, o, kEdge), UsageError);
  // A checkpoint with a boundary restores only into a run with one, and the other way round.
  {
    test::TempDir dir;
    Solver with(model, SolverOptions{}), without(model, SolverOptions{});
    TriaxialBoundary boundary(model, TriaxialOptions{}, kEdge);
    with.set_boundary(&boundary);
    {
      io::H5File f = io::H5File::create(dir / "with.h5");
      with.save(f, "/state");
      io::H5File g = io::H5File::create(dir / "without.h5");
      without.save(g, "/state");
    }
    EXPECT_THROW(without.load(io::H5File::open(dir / "with.h5"), "/state"), DataError);
    EXPECT_THROW(with.load(io::H5File::open(dir / "without.h5"), "/state"), DataError);
  }
  model.platens.clear();
  EXPECT_THROW(find_platens(model), UsageError);
  model.sample.reset();
  EXPECT_THROW(TriaxialBoundary(model, TriaxialOptions{}, kEdge), UsageError);
}

TEST(Triaxial, TheWallStartsOutsideTheGrainsAndTheMembraneIsScaledToTheRunsTimeStep) {
  Model model = cube_sample();
  // A fitted sample radius that cuts into the outer grains: the wall starts at the outermost node.
  double outermost = 0;
  for (const Eigen::Vector3d& p : model.nodes) outermost = std::max(outermost, p.head<2>().norm());
  model.sample->radius = 0.8 * outermost;
  Solver solver(model, SolverOptions{});
  TriaxialOptions o;
  o.ball_radius = outermost / 15;
  TriaxialBoundary natural(model, o, kEdge), scaled(model, o, kEdge);
  EXPECT_DOUBLE_EQ(natural.wall().radius, outermost);
  // A tiny run step leaves the latex as it is; one five times the membrane's own limit scales its
  // density by 25 so that its limit (bonds and ball contact, both as sqrt(mass)) reaches the step.
  natural.install_membrane(*solver.contact_model(), 1e-15);
  const double own = natural.stable_time_step(*solver.contact_model());
  EXPECT_EQ(natural.density_scaling(), 1.0);
  scaled.install_membrane(*solver.contact_model(), 5 * own);
  EXPECT_NEAR(scaled.density_scaling(), 25.0, 0.01);
  EXPECT_GE(scaled.stable_time_step(*solver.contact_model()), 5 * own);
  EXPECT_NEAR(scaled.membrane()->ball_mass / natural.membrane()->ball_mass, scaled.density_scaling(), 1e-9);
}

namespace {

/// Everything that moves, bit for bit: node positions and velocities, rigid bodies, platens, the
/// wall and the membrane balls.
void expect_same_state(const Solver& a, const TriaxialBoundary& ba, const Solver& b, const TriaxialBoundary& bb) {
  EXPECT_EQ(a.step_count(), b.step_count());
  EXPECT_EQ(a.state().x, b.state().x);
  EXPECT_EQ(a.state().v, b.state().v);
  for (std::size_t g = 0; g < a.state().bodies.size(); ++g) {
    EXPECT_EQ(a.state().bodies[g].position, b.state().bodies[g].position) << "grain " << g;
    EXPECT_EQ(a.state().bodies[g].angular_momentum, b.state().bodies[g].angular_momentum) << "grain " << g;
  }
  for (std::size_t p = 0; p < a.platens().size(); ++p) EXPECT_EQ(a.platens()[p].point, b.platens()[p].point);
  EXPECT_EQ(ba.wall().radius, bb.wall().radius);
  EXPECT_EQ(ba.has_membrane(), bb.has_membrane());
  if (ba.has_membrane()) {
    EXPECT_EQ(ba.membrane_state()->x, bb.membrane_state()->x);
    EXPECT_EQ(ba.membrane_state()->spin, bb.membrane_state()->spin);
    EXPECT_EQ(ba.membrane_state()->shear, bb.membrane_state()->shear);
  }
}

}  // namespace

TEST(Triaxial, ACheckpointWithTheWallOrTheMembraneContinuesBitForBit) {
  omp_set_num_threads(1);
  const Model model = cube_sample();
  SolverOptions so;
  so.damping = 2e3;
  TriaxialOptions o;
  o.ball_radius = model.sample->radius / 15;
  o.membrane_friction = 0.3;  // the balls' friction springs must come back too
  const PlatenPair platens = find_platens(model);
  for (const bool membrane : {false, true}) {
    Solver run(model, so);
    TriaxialBoundary boundary(model, o, kEdge);
    run.set_boundary(&boundary);
    const double dt = 0.9 * run.time_step_limits().stable();
    // The wall closes in (or the membrane presses under sigma_3) while the platens close: contacts,
    // friction history and the boundary's own state all change from step to step.
    const auto drive = [&](Solver& s, TriaxialBoundary& b) {
      s.set_platen_velocity(platens.bottom, Eigen::Vector3d(0, 0, 0.02));
      s.set_platen_velocity(platens.top, Eigen::Vector3d(0, 0, -0.02));
      b.set_platens(s.platens()[platens.bottom].point.z(), s.platens()[platens.top].point.z(), 0.02, -0.02);
      // The wall runs in from the sample radius and stops 2 um inside the cubes' corners.
      if (!b.has_membrane()) b.set_wall_velocity(b.wall().radius > std::sqrt(2.0) * 1.5 * kEdge - 2e-6 ? -2.5 : 0.0);
    };
    if (membrane) {
      boundary.install_membrane(*run.contact_model(), dt);
      boundary.set_membrane_fixed(false);
      boundary.set_pressure(o.confining_pressure);
    }
    for (int k = 0; k < 300; ++k) drive(run, boundary), run.step(dt);
    EXPECT_GT(boundary.last_contact().contacts, 0u) << (membrane ? "membrane" : "wall");
    test::TempDir dir;
    {
      io::H5File f = io::H5File::create(dir / "checkpoint.h5");
      run.save(f, "/state");
    }
    Solver restarted(model, so);
    TriaxialBoundary restored(model, o, kEdge);
    restarted.set_boundary(&restored);
    restarted.load(io::H5File::open(dir / "checkpoint.h5"), "/state");
    EXPECT_EQ(measure(restarted, restored, platens).axial_stress, measure(run, boundary, platens).axial_stress);
    EXPECT_EQ(restored.wall_stress(), boundary.wall_stress());
    // A frame written before the next step sees the same contacts and grain stresses.
    const auto before = run.contacts(), after = restarted.contacts();
    ASSERT_EQ(before.size(), after.size());
    for (std::size_t k = 0; k < before.size(); ++k) {
      EXPECT_EQ(before[k].b, after[k].b);
      EXPECT_EQ(before[k].force, after[k].force);
      EXPECT_EQ(before[k].point, after[k].point);
      EXPECT_EQ(before[k].stiffness, after[k].stiffness);
    }
    // The servos read the stiffness the checkpoint kept.
    EXPECT_EQ(restarted.platen_stiffness(platens.top), run.platen_stiffness(platens.top));
    EXPECT_EQ(restarted.platen_stiffness(platens.bottom), run.platen_stiffness(platens.bottom));
    EXPECT_EQ(restored.wall_stiffness(), boundary.wall_stiffness());
    if (!membrane) {
      EXPECT_GT(boundary.wall_stiffness(), 0);
      // A wall stiffness that is not a finite, non-negative number is refused.
      {
        io::H5File f = io::H5File::create(dir / "bad_wall.h5");
        run.save(f, "/state");
        const CylinderWallState& w = boundary.wall();
        f.set_attr("/state/boundary", "wall", std::vector<double>{w.radius, w.radial_velocity, 0.0, std::nan("")});
      }
      Solver refused(model, so);
      TriaxialBoundary refused_boundary(model, o, kEdge);
      refused.set_boundary(&refused_boundary);
      EXPECT_THROW(refused.load(io::H5File::open(dir / "bad_wall.h5"), "/state"), DataError);
    }
    for (std::size_t g = 0; g < model.grains.size(); ++g) EXPECT_EQ(run.grain_stress(g), restarted.grain_stress(g)) << g;
    for (int k = 0; k < 200; ++k) {
      drive(run, boundary), run.step(dt);
      drive(restarted, restored), restarted.step(dt);
    }
    expect_same_state(run, boundary, restarted, restored);
  }
}

TEST(Triaxial, TheRunsProgressRoundTripsAndADamagedOneIsRefused) {
  test::TempDir dir;
  TriaxialRunProgress p;
  p.procedure = {TriaxialProgress::Phase::membrane_released, 1234, 17, 900, 3.5e-3};
  p.consolidation_steps = 1106;
  p.membrane_steps = 7;
  p.next_frame = 2;
  p.max_kinetic_ratio = 0.031;
  p.start = {3.1e5, 3e5, 3.5e-3, 1.2e-7, 1.19e-7};
  {
    io::H5File f = io::H5File::create(dir / "progress.h5");
    save_progress(f, p);
  }
  const TriaxialRunProgress q = load_progress(io::H5File::open(dir / "progress.h5"));
  EXPECT_EQ(q.procedure.phase, p.procedure.phase);
  EXPECT_EQ(q.procedure.step, 1234u);
  EXPECT_EQ(q.procedure.released, 900u);
  EXPECT_EQ(q.procedure.h0, 3.5e-3);
  EXPECT_EQ(q.next_frame, 2u);
  EXPECT_EQ(q.start.volume_radial, 1.19e-7);
  for (const double bad : {std::numeric_limits<double>::quiet_NaN(), -1.0, 2.5}) {
    {
      io::H5File f = io::H5File::create(dir / "damaged.h5");
      save_progress(f, p);
      f.set_attr("/triaxial", "procedure", std::vector<double>{2, bad, 17, 900, 3.5e-3});
    }
    EXPECT_THROW(load_progress(io::H5File::open(dir / "damaged.h5")), DataError) << bad;
  }
  io::H5File::create(dir / "plain.h5");  // a checkpoint of a run without a triaxial test
  EXPECT_THROW(load_progress(io::H5File::open(dir / "plain.h5")), DataError);
}

TEST(Triaxial, ConsolidationStatusSaysWhereTheStressesAndEnergyStandAgainstWhatSettlesThem) {
  TriaxialSpec spec;  // 300 kPa within 1 %, at most 200 000 steps a phase
  StepReport r;
  r.energies.kinetic = 3.0, r.energies.strain = 10.0, r.energies.contact_elastic = 40.0;
  const TriaxialMeasure m{2.981e5, 3.0123e5, 3.5e-3, 1.2e-7, 1.2e-7};
  using Phase = TriaxialProgress::Phase;
  EXPECT_EQ(consolidation_status(spec, m, r, {Phase::wall, 1200, 40, 0, 0}),
            "step 1200 of at most 200000, in the wall: axial 298.1 kPa, lateral 301.2 kPa (settle within 1 % of 300 "
            "kPa); kinetic / elastic energy 0.06 (settles below 0.05); settled for 40 of 100 steps");
  EXPECT_EQ(consolidation_status(spec, m, r, {Phase::membrane_fixed, 30, 0, 0, 0}),
            "step 30 of at most 200000, membrane held while the grains settle against it; kinetic / elastic energy "
            "0.06 (settles below 0.05); settled for 0 of 100 steps");
  const TriaxialMeasure ramping{2.5e5, 1.5e5, 3.5e-3, 1.2e-7, 1.2e-7};
  EXPECT_EQ(consolidation_status(spec, ramping, r, {Phase::membrane_released, 800, 0, 300, 0}),
            "step 800 of at most 200000, membrane released: axial 250 kPa (settles within 1 % of 300 kPa), pressure "
            "150 kPa (ramped to 300 kPa); kinetic / elastic energy 0.06 (settles below 0.05); settled for 0 of 100 steps");
  EXPECT_EQ(consolidation_status(spec, m, r, {Phase::shearing, 5, 0, 0, 3.5e-3}),
            "step 5: axial 298.1 kPa, lateral 301.2 kPa; kinetic / elastic energy 0.06");
}
