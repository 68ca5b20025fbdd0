// FDEM verification against exact answers (ctest label fdem-verify; the long ones are benchmarks):
// the longitudinal wave speed of a free bar, energy conservation over 10^4 undamped steps, and a
// free rigid body's spin (angular momentum, energy, precession cone).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "graintwin/fdem/primitives.hpp"
#include "graintwin/fdem/solver.hpp"

using namespace graintwin;
using namespace graintwin::fdem;

/// Free grains: nothing touches them, so the contact module stays out.
const SolverOptions kFree = [] {
  SolverOptions o;
  o.contact.enabled = false;
  return o;
}();

// A free-free bar started in its first longitudinal mode, v = v0 cos(pi X / L) x: the end velocity
// goes v0 cos(omega t) with omega = pi c0 / L, c0 = sqrt(E / rho) (thin bar; the lateral inertia
// correction (nu pi r / L)^2 / 2 is below 1e-4 here). Tolerance 1 % on c0 (mesh dispersion).
TEST(FdemVerify, BarWaveSpeed) {
  for (GrainKind kind : {GrainKind::tet4, GrainKind::tet10}) {
    const double L = 10e-3, w = 0.5e-3;
    Model m;
    add_grain(m, box_mesh({L, w, w}, kind == GrainKind::tet4 ? 0.25e-3 : 0.5e-3), Eigen::Vector3d::Zero(), kind, 0, 1);
    Solver s(m, kFree);
    const double v0 = 0.1;
    auto& v = const_cast<std::vector<Eigen::Vector3d>&>(s.state().v);
    for (std::size_t i = 0; i < v.size(); ++i) v[i] = Eigen::Vector3d(v0 * std::cos(std::numbers::pi * (m.nodes[i][0] / L + 0.5)), 0, 0);
    const double c0 = std::sqrt(m.materials[0].young / m.materials[0].density);
    const double dt = 0.5 * s.time_step_limits().stable();
    // End velocity = mass-weighted mean over the nodes at X = -L/2; it crosses zero at a quarter period.
    const auto end_velocity = [&] {
      double sum = 0, mass = 0;
      for (std::size_t i = 0; i < v.size(); ++i)
        if (m.nodes[i][0] < -L / 2 + 1e-9) sum += s.node_mass()[i] * s.state().v[i][0], mass += s.node_mass()[i];
      return sum / mass;
    };
    double previous = end_velocity(), t_previous = 0, crossing = 0;
    while (crossing == 0) {
      s.step(dt);
      const double now = end_velocity(), t_now = s.state().time - 0.5 * dt;  // velocities are at half steps
      if (previous > 0 && now <= 0) crossing = t_previous + (t_now - t_previous) * previous / (previous - now);
      previous = now, t_previous = t_now;
      ASSERT_LT(s.state().time, 2 * L / c0) << "no zero crossing within half a period";
    }
    const double c = L / (2 * crossing);
    EXPECT_NEAR(c / c0, 1.0, 0.01) << (kind == GrainKind::tet4 ? "tet4" : "tet10") << ": c = " << c << " m/s, c0 = " << c0;
  }
}

// A grain spinning, translating and vibrating with no damping: kinetic + strain energy stays within
// 0.5 % of its start over 10^4 steps at half the stable step.
TEST(FdemVerify, EnergyDriftOverTenThousandUndampedSteps) {
  for (GrainKind kind : {GrainKind::tet4, GrainKind::tet10}) {
    Model m;
    add_grain(m, box_mesh({1e-3, 0.6e-3, 0.4e-3}, 0.5e-3), Eigen::Vector3d::Zero(), kind, 0, 1);
    Solver s(m, kFree);
    s.set_grain_velocity(0, {0.2, 0, -0.1}, {3e4, 1e4, 2e4});
    auto& v = const_cast<std::vector<Eigen::Vector3d>&>(s.state().v);
    for (std::size_t i = 0; i < v.size(); ++i) v[i] += Eigen::Vector3d(std::sin(7.0 * i), std::cos(3.0 * i), std::sin(5.0 * i));
    const double dt = 0.5 * s.time_step_limits().stable();
    const double start = s.step(dt).energies.mechanical();
    double worst = 0;
    for (int n = 1; n < 10000; ++n) worst = std::max(worst, std::abs(s.step(dt).energies.mechanical() / start - 1));
    EXPECT_LT(worst, 0.005) << (kind == GrainKind::tet4 ? "tet4" : "tet10");
    EXPECT_GT(s.grain_rotation(0).angularDistance(Eigen::Quaterniond::Identity()), 1.0) << "the test must rotate the grain";
  }
}

// A free rigid box spun off its principal axes: the angular momentum is constant (no torque), the
// energy stays within 1e-4, and for a box with two equal sides the symmetry axis keeps its angle to
// the angular momentum (torque-free precession).
TEST(FdemVerify, RigidSpinConservesAngularMomentum) {
  Model m;
  add_grain(m, box_mesh({1e-3, 1e-3, 2e-3}, 0.5e-3), Eigen::Vector3d(1e-3, 2e-3, 3e-3), GrainKind::rigid, 0, 1);
  Solver s(m, kFree);
  const Eigen::Vector3d omega(2e4, 0, 3e4);
  s.set_grain_velocity(0, {0.1, 0, 0}, omega);
  const Eigen::Vector3d L0 = s.state().bodies[0].angular_momentum;
  const double dt = 2e-7;  // no element or contact limit applies: ~300 steps per revolution
  const double start = s.step(dt).energies.kinetic;
  const auto axis_angle = [&] { return (s.grain_rotation(0) * Eigen::Vector3d::UnitZ()).dot(L0.normalized()); };
  const double cone = axis_angle();
  double worst = 0;
  for (int n = 1; n < 10000; ++n) worst = std::max(worst, std::abs(s.step(dt).energies.kinetic / start - 1));
  EXPECT_LT(worst, 1e-4);
  EXPECT_LT((s.state().bodies[0].angular_momentum - L0).norm(), 1e-12 * L0.norm());
  EXPECT_NEAR(axis_angle(), cone, 1e-4);
  EXPECT_GT(s.grain_rotation(0).angularDistance(Eigen::Quaterniond::Identity()), 0.5);
  // The nodes move with the body.
  const Eigen::Matrix3d R = s.grain_rotation(0).toRotationMatrix();
  const Grain& g = m.grains[0];
  for (std::uint32_t i = g.node_begin; i < g.node_end; ++i)
    EXPECT_LT((s.state().x[i] - (s.grain_centroid(0) + R * (m.nodes[i] - s.body(0).centroid))).norm(), 1e-15);
}
