// The bonded-ball membrane (fdem/membrane.hpp) against exact answers: the spring constants of eq. 24
// and the lattice's own elastic constants, the volume of a known cylinder, uniaxial tension against
// FL/(EA), an open tube under internal pressure against thin-shell theory, and a rigid rotation
// that must store no energy. The ratios these checks measure to the exact answers are golden
// numbers (tests/data/fdem_membrane.json), far tighter than the checks' own tolerances.
#include "graintwin/fdem/membrane.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <functional>
#include <numbers>
#include <random>

#include "graintwin/core/error.hpp"
#include "support/golden.hpp"

using namespace graintwin;
using namespace graintwin::fdem;

namespace {

constexpr double kPi = std::numbers::pi;

/// A latex membrane of ball-centre radius R = ratio x r (r = 50 um), `height_radii` radii high.
Membrane tube(double ratio, double height_radii = 2.0, MembraneMaterial material = {}) {
  const double r = 50e-6, radius = ratio * r;
  return build_membrane(material, Eigen::Vector2d(1e-3, -2e-3), radius, 0.0, height_radii * radius, r);
}

/// Mean z and mean distance from the axis of the balls of ring k.
std::pair<double, double> ring_mean(const Membrane& m, const std::vector<Eigen::Vector3d>& x, std::size_t k) {
  double z = 0, rho = 0;
  for (std::size_t i = 0; i < m.per_ring; ++i) {
    const Eigen::Vector3d& p = x[k * m.per_ring + i];
    z += p[2];
    rho += std::hypot(p[0] - m.axis_xy[0], p[1] - m.axis_xy[1]);
  }
  return {z / double(m.per_ring), rho / double(m.per_ring)};
}

}  // namespace

TEST(MembraneStiffness, Equation24AndTheLatticeConstants) {
  MembraneMaterial latex;  // E 1.25 MPa, nu 0.2, t 0.3 mm
  const BondStiffness k = bond_stiffness(latex);
  const double et = 1.25e6 * 0.3e-3;
  EXPECT_NEAR(k.normal, et / (std::sqrt(3.0) * 0.8), 1e-12 * k.normal);
  EXPECT_NEAR(k.shear, et * 0.4 / (std::sqrt(3.0) * 0.96), 1e-12 * k.normal);
  for (double nu : {-0.5, 0.0, 0.2, 1.0 / 3.0}) {
    latex.poisson = nu;
    const BondStiffness kk = bond_stiffness(latex);
    EXPECT_NEAR(lattice_poisson(kk), nu, 1e-12);
    EXPECT_NEAR(lattice_young_thickness(kk), et, 1e-9 * et);
  }
  EXPECT_NEAR(bond_stiffness(latex).shear, 0.0, 1e-12);  // nu = 1/3: normal springs only
}

TEST(MembraneStiffness, PoissonAboveOneThirdIsRefused) {
  MembraneMaterial latex;
  latex.poisson = 0.45;
  try {
    bond_stiffness(latex);
    FAIL() << "nu = 0.45 accepted";
  } catch (const UsageError& e) {
    EXPECT_NE(e.message().find("1/3"), std::string::npos) << e.message();
  }
  latex.poisson = -1.0;
  EXPECT_THROW(bond_stiffness(latex), UsageError);
  latex = {};
  latex.thickness = 0;
  EXPECT_THROW(bond_stiffness(latex), UsageError);
}

TEST(MembraneLattice, HexagonalBallsTouchAndTrianglesFaceOutwards) {
  const Membrane m = tube(40);
  ASSERT_EQ(m.balls(), m.rings * m.per_ring);
  EXPECT_EQ(m.per_ring, std::size_t(std::lround(2 * kPi * 40 / 2)));
  // Interior balls have six bonds; end-ring balls four.
  std::vector<int> degree(m.balls(), 0);
  for (const auto& b : m.bonds) ++degree[b[0]], ++degree[b[1]];
  for (std::size_t i = 0; i < m.balls(); ++i) {
    const std::size_t k = m.ring_of(i);
    EXPECT_EQ(degree[i], k == 0 || k + 1 == m.rings ? 4 : 6) << "ball " << i;
  }
  for (double len : m.rest_length) EXPECT_NEAR(len, 2 * m.ball_radius, 0.02 * m.ball_radius);
  EXPECT_EQ(m.triangles.size(), 2 * m.per_ring * (m.rings - 1));
  for (const auto& t : m.triangles) {
    const Eigen::Vector3d n = (m.reference[t[1]] - m.reference[t[0]]).cross(m.reference[t[2]] - m.reference[t[0]]);
    const Eigen::Vector3d c = (m.reference[t[0]] + m.reference[t[1]] + m.reference[t[2]]) / 3;
    EXPECT_GT(n.dot(Eigen::Vector3d(c[0] - m.axis_xy[0], c[1] - m.axis_xy[1], 0)), 0);
  }
  EXPECT_THROW(build_membrane({}, Eigen::Vector2d::Zero(), 1e-3, 0, 1e-3, 4e-4), UsageError);  // 8 balls per ring
}

TEST(MembraneBallSize, AThirdOfD50InsideTheRatioWindow) {
  EXPECT_DOUBLE_EQ(choose_ball_radius(10e-3, 0.551e-3), 0.551e-3 / 3);  // ratio 54
  EXPECT_DOUBLE_EQ(choose_ball_radius(6e-3, 0.551e-3), 6e-3 / 35);      // d50 / 3 gives 33 -> 35
  EXPECT_DOUBLE_EQ(choose_ball_radius(30e-3, 0.1e-3), 30e-3 / 100);
  EXPECT_THROW(choose_ball_radius(0, 1e-3), UsageError);
}

TEST(MembraneVolume, KnownCylinderWithinAPerMilleAndBothFormulasAgree) {
  const Membrane m = tube(40, 3.0);
  const double inner = m.radius - m.ball_radius;
  const double zb = 0.5 * m.radius, zt = 2.3 * m.radius;
  const double exact = kPi * inner * inner * (zt - zb);
  const EnclosedVolumes at_rest = enclosed_volumes(m, m.reference, zb, zt);
  const double v27 = at_rest.volume, v28 = at_rest.radial;
  EXPECT_NEAR(v27, exact, 1e-3 * exact);
  test::Golden("fdem_membrane").check("volume_over_cylinder", v27 / exact);
  EXPECT_NEAR(v28, v27, 1e-10 * exact);
  // Any deformation: both are exact for the same closed polyhedron, so they agree to round-off.
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.1 * m.ball_radius);
  std::vector<Eigen::Vector3d> x = m.reference;
  for (auto& p : x) {
    const double z = p[2] / (3 * m.radius);
    p[0] += 0.2 * m.radius * z * (1 - z) * (p[0] - m.axis_xy[0]) / m.radius + noise(rng);  // bulge
    p[1] += noise(rng);
    p[2] += noise(rng);
  }
  const EnclosedVolumes bulged = enclosed_volumes(m, x, zb, zt);
  EXPECT_NEAR(bulged.radial, bulged.volume, 1e-10 * exact);
  EXPECT_THROW(enclosed_volumes(m, m.reference, -0.1 * m.radius, zt), DataError);  // below the membrane
  EXPECT_THROW(enclosed_volumes(m, m.reference, zt, zb), UsageError);
}

TEST(MembraneTension, StretchesByFLOverEA) {
  const Membrane m = tube(36, 2.0);
  const double area = 2 * kPi * m.radius * m.material.thickness;
  const double total = 1e-3 * m.material.young * area;  // 0.1 % strain
  const std::size_t last = m.rings - 1;
  const double wave = std::sqrt(m.material.young / m.material.density);
  const double height = m.reference.back()[2] - m.reference.front()[2];
  const MembraneState s = relax_membrane(m, 2 * kPi * wave / height, [&](const MembraneState&, std::vector<Eigen::Vector3d>& f) {
    for (std::size_t i = 0; i < m.per_ring; ++i) {
      f[i][2] -= total / double(m.per_ring);
      f[last * m.per_ring + i][2] += total / double(m.per_ring);
    }
  });
  const std::size_t k1 = m.rings / 4, k2 = 3 * m.rings / 4;
  const double gauge = ring_mean(m, m.reference, k2).first - ring_mean(m, m.reference, k1).first;
  const double stretched = ring_mean(m, s.x, k2).first - ring_mean(m, s.x, k1).first;
  const double strain = stretched / gauge - 1, expected = total / (m.material.young * area);
  EXPECT_NEAR(strain, expected, 0.05 * expected);
  // Lateral contraction by the lattice's Poisson ratio.
  const double radial = (ring_mean(m, s.x, m.rings / 2).second - m.radius) / m.radius;
  EXPECT_NEAR(radial, -m.material.poisson * expected, 0.1 * m.material.poisson * expected);
  test::Golden measured("fdem_membrane");
  measured.check("tension_strain_over_fl_ea", strain / expected);
  measured.check("tension_contraction_over_poisson", radial / (-m.material.poisson * expected));
}

TEST(MembranePressure, OpenTubeExpandsAsThinShellTheorySays) {
  const Membrane m = tube(36, 1.5);
  const double pressure = 1e3;  // Pa inside: hoop strain p R / (E t) = 0.53 %
  // Critical for the breathing mode, omega = sqrt(E / (rho (1 - nu^2))) / R.
  const double breathing = std::sqrt(m.material.young / (m.material.density * (1 - 0.04))) / m.radius;
  const MembraneState s = relax_membrane(m, 2 * breathing, [&](const MembraneState& st, std::vector<Eigen::Vector3d>& f) {
    add_pressure_forces(m, st.x, -pressure, f);
  });
  const double expected = pressure * m.radius / (m.material.young * m.material.thickness);
  const double hoop = ring_mean(m, s.x, m.rings / 2).second / m.radius - 1;
  EXPECT_NEAR(hoop, expected, 0.03 * expected);
  test::Golden("fdem_membrane").check("pressure_hoop_strain_over_thin_shell", hoop / expected);
}

TEST(MembraneObjectivity, ARigidRotationStoresNoShear) {
  // The balls are carried through half a radian of rigid rotation about a tilted axis, with the
  // matching velocities and spins; the bonds must stay unloaded. Without the spins the contact
  // points would slide past each other and the shear springs would load: the test can tell.
  const Membrane m = tube(36, 1.0);
  const Eigen::Vector3d omega(300.0, -200.0, 500.0);  // rad/s
  const Eigen::Vector3d centre(m.axis_xy[0], m.axis_xy[1], 0.5 * m.radius);
  const double dt = membrane_stable_time_step(m);
  const int steps = int(0.5 / (omega.norm() * dt));
  const auto largest_shear = [&](bool with_spin) {
    MembraneState s = rest_state(m);
    std::vector<Eigen::Vector3d> f(m.balls()), moment(m.balls());
    double elastic = 0;
    for (int step = 0; step <= steps; ++step) {
      const Eigen::Matrix3d R = Eigen::AngleAxisd(omega.norm() * dt * step, omega.normalized()).toRotationMatrix();
      for (std::size_t i = 0; i < m.balls(); ++i) {
        s.x[i] = centre + R * (m.reference[i] - centre);
        s.v[i] = omega.cross(s.x[i] - centre);
        s.spin[i] = with_spin ? omega : Eigen::Vector3d::Zero();
      }
      elastic = add_bond_forces(m, s, dt, f, moment);
    }
    double largest = 0;
    for (const auto& v : s.shear) largest = std::max(largest, v.norm());
    return std::make_pair(largest, elastic);
  };
  const auto [shear, elastic] = largest_shear(true);
  const double scale = m.stiffness.normal * m.ball_radius;  // a bond stretched by its ball radius
  EXPECT_LT(shear, 1e-9 * scale);
  EXPECT_LT(elastic, 1e-18 * scale * m.ball_radius);
  EXPECT_GT(largest_shear(false).first, 1e-3 * scale);
}
