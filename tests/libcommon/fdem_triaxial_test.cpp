// The triaxial boundary (fdem/triaxial.hpp) on 27 rigid cubes: isotropic consolidation inside the
// servo wall reaches sigma_3 within 1 % on the wall and both platens; the membrane that replaces the
// wall (forming procedure) carries sigma_3 while the platens servo to it within 1 %, without
// entering the grains, and eq. 27 = eq. 28; strain-controlled shearing reaches its log strain at
// the set rate with sigma_1 > sigma_3; bad input is refused.
#include "graintwin/fdem/triaxial.hpp"

#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <numbers>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/primitives.hpp"
#include "graintwin/io/h5file.hpp"
#include "support/run_tool.hpp"

using namespace graintwin;
using namespace graintwin::fdem;

namespace {

constexpr double kEdge = 1e-3;

/// 3 x 3 x 3 rigid cubes of 1 mm, 2 % apart, in a cylinder that just encloses them, between
/// platens 2 % of an edge away.
Model cube_sample() {
  Model m;
  const TetMesh cube = box_mesh(Eigen::Vector3d::Constant(kEdge), 0.5 * kEdge);
  const double pitch = 1.02 * kEdge;
  std::uint32_t label = 0;
  for (int i = -1; i <= 1; ++i)
    for (int j = -1; j <= 1; ++j)
      for (int k = 0; k < 3; ++k)
        add_grain(m, cube, Eigen::Vector3d(i * pitch, j * pitch, (k + 0.5) * pitch), GrainKind::rigid, 0, ++label);
  SampleCylinder s;
  s.radius = std::hypot(1.5 * pitch, 1.5 * pitch) * 1.01;
  s.z_min = 0.0;
  s.z_max = 3 * pitch;
  m.sample = s;
  m.platens = {Platen{"bottom", Eigen::Vector3d(0, 0, s.z_min), Eigen::Vector3d::UnitZ(), 0.0},
               Platen{"top", Eigen::Vector3d(0, 0, s.z_max), -Eigen::Vector3d::UnitZ(), 0.0}};
  return m;
}

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
  shear(solver, boundary, shearing, dt_membrane, [&](const TriaxialMeasure& row, const StepReport&) {
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

TEST(Triaxial, RefusesAMembranePoissonRatioAboveOneThirdACheckpointAndAModelWithoutPlatens) {
  Model model = cube_sample();
  TriaxialOptions o;
  o.membrane.poisson = 0.49;
  EXPECT_THROW(TriaxialBoundary(model, o, kEdge), UsageError);
  // A checkpoint would lose the boundary's state, so it is refused rather than written.
  {
    Solver solver(model, SolverOptions{});
    TriaxialBoundary boundary(model, TriaxialOptions{}, kEdge);
    solver.set_boundary(&boundary);
    test::TempDir dir;
    io::H5File f = io::H5File::create(dir / "checkpoint.h5");
    EXPECT_THROW(solver.save(f, "/state"), UsageError);
  }
  model.platens.clear();
  EXPECT_THROW(find_platens(model), UsageError);
  model.sample.reset();
  EXPECT_THROW(TriaxialBoundary(model, TriaxialOptions{}, kEdge), UsageError);
}
