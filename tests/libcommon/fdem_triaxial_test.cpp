// The triaxial boundary (fdem/triaxial.hpp): isotropic consolidation of rigid grains inside the servo
// wall reaches sigma_3 within 1 % on the wall and on both platens; the membrane that replaces the
// wall holds the sample under the confining pressure; a membrane Poisson ratio above 1/3 is refused.
#include "graintwin/fdem/triaxial.hpp"

#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <numbers>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/primitives.hpp"

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

TEST(Triaxial, ConsolidationInTheWallReachesSigma3WithinOnePercent) {
  omp_set_num_threads(1);  // 27 grains: threads would only wait on each other (ctest runs suites side by side)
  const Model model = cube_sample();
  SolverOptions so;
  so.damping = 2e3;  // 1/s: quasi-static settling
  Solver solver(model, so);
  TriaxialOptions o;
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

  // The membrane replaces the wall and carries the pressure: it wraps the square block of cubes
  // (less volume than the wall's cylinder) without entering it.
  boundary.install_membrane();
  ASSERT_TRUE(boundary.has_membrane());
  boundary.set_pressure(o.confining_pressure);
  const double dt_membrane = 0.9 * solver.time_step_limits().stable();
  for (int n = 0; n < 1000; ++n) solver.step(dt_membrane);
  const TriaxialMeasure after = measure(solver, boundary, platens);
  const double block = std::pow(3 * kEdge, 2) * after.height;
  EXPECT_LT(after.volume, m.volume);
  EXPECT_GT(after.volume, 0.98 * block);
  EXPECT_NEAR(after.volume_radial, after.volume, 1e-9 * after.volume);
  // The balls press on the grains without entering them: overlaps far below a ball radius.
  EXPECT_GT(boundary.last_contact().contacts, 0u);
  EXPECT_LT(boundary.last_contact().max_overlap, 0.1 * boundary.ball_radius());
}

TEST(Triaxial, RefusesAMembranePoissonRatioAboveOneThirdAndAModelWithoutPlatens) {
  Model model = cube_sample();
  TriaxialOptions o;
  o.membrane.poisson = 0.49;
  EXPECT_THROW(TriaxialBoundary(model, o, kEdge), UsageError);
  model.platens.clear();
  EXPECT_THROW(find_platens(model), UsageError);
  model.sample.reset();
  EXPECT_THROW(TriaxialBoundary(model, TriaxialOptions{}, kEdge), UsageError);
}
