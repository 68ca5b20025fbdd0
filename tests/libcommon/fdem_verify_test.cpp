// FDEM verification against exact answers (ctest label fdem-verify; the long ones are benchmarks):
// the longitudinal wave speed of a free bar, energy conservation over 10^4 undamped steps, a free
// rigid body's spin (angular momentum, energy, precession cone); with contact: a box bouncing off a
// platen against the spring-dashpot solution (restitution, contact time), a block on an incline
// (sticks below tan(phi) = mu, slides above at g (sin - mu cos)), an elastic sphere's rebound.
// Each check against an exact answer keeps its tolerance here; the figures these runs measure are
// golden numbers (tests/data/fdem_verify.json), far tighter, so that a change shows in review.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "graintwin/mesh/ellipsoid_grain.hpp"
#include "graintwin/fdem/primitives.hpp"
#include "graintwin/fdem/solver.hpp"
#include "support/golden.hpp"

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
    test::Golden("fdem_verify").check(fmt::format("bar_wave_speed_over_c0_{}", kind == GrainKind::tet4 ? "tet4" : "tet10"), c / c0);
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
    test::Golden("fdem_verify").check(fmt::format("energy_drift_{}", kind == GrainKind::tet4 ? "tet4" : "tet10"), worst);
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

namespace {

/// A rigid or elastic 1 mm wide box of `height` resting on (or falling onto) a floor platen of friction mu.
Model box_on_floor(GrainKind kind, double height, double gap, double mu) {
  Model m;
  add_grain(m, box_mesh({1e-3, 1e-3, height}, 0.25e-3), Eigen::Vector3d(0, 0, height / 2 + gap), kind, 0, 1);
  m.platens = {Platen{"floor", Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), mu}};
  return m;
}

/// A_node against a contact pushing along `n`: a third of the reference areas of the node's
/// surface triangles, each weighted by max(0, -n_t . n) (docs/fdem_contact.md: a face's nodes
/// carry exactly the face's area).
std::vector<double> node_areas(const Model& m, const Eigen::Vector3d& n) {
  std::vector<double> area(m.nodes.size(), 0.0);
  for (const auto& t : m.triangles) {
    const Eigen::Vector3d c = (m.nodes[t[1]] - m.nodes[t[0]]).cross(m.nodes[t[2]] - m.nodes[t[0]]);
    const double facing = std::max(0.0, -c.normalized().dot(n));
    for (std::uint32_t v : t) area[v] += 0.5 * c.norm() / 3 * facing;
  }
  return area;
}

}  // namespace

// A rigid box falls flat onto a platen without gravity: its bottom nodes penetrate alike, so the
// contact is one spring-dashpot K = sum k_i, C = sum 2 beta sqrt(m_i k_i) on the body mass M
// (k_i = p_n A_i with the facing node areas, m_i the masses contact gives the nodes of a rigid
// grain: the body's effective mass at each over rigid_contact_nodes). Contact time is the
// time the platen force is not zero (after it, the nodes still overlap a little, force-free). With zeta = C / (2 sqrt(K M)), omega_d =
// omega sqrt(1 - zeta^2) and the force clamped at zero (it never pulls), contact ends when
// k delta + c delta' = 0: omega_d t_c = pi - atan(2 zeta sqrt(1 - zeta^2) / (1 - 2 zeta^2)), and
// e = exp(-zeta omega t_c) |cos(omega_d t_c) - zeta omega / omega_d sin(omega_d t_c)|.
// Tolerances: 1 % on e and on t_c (plus one step), for dt = an eighth of the stable step.
TEST(FdemVerify, BoxBouncesOffAPlatenLikeTheSpringDashpot) {
  for (double beta : {0.03, 0.3}) {
    Model m = box_on_floor(GrainKind::rigid, 1e-3, 0, 0);
    m.materials[0].damping_ratio = beta;
    const double v0 = 0.1;
    Solver s(m, SolverOptions{});
    s.set_grain_velocity(0, {0, 0, -v0}, Eigen::Vector3d::Zero());
    const std::vector<double> area = node_areas(m, Eigen::Vector3d::UnitZ());
    double K = 0, C = 0;
    for (std::size_t i = 0; i < m.nodes.size(); ++i)
      if (std::abs(m.nodes[i].z()) < 1e-12) {
        const double k = m.materials[0].normal_penalty * area[i];
        K += k, C += 2 * beta * std::sqrt(s.contact_node_mass()[i] * k);
      }
    const double M = s.body(0).mass, omega = std::sqrt(K / M), zeta = C / (2 * std::sqrt(K * M));
    const double wd = omega * std::sqrt(1 - zeta * zeta);
    const double t_c = (std::numbers::pi - std::atan(2 * zeta * std::sqrt(1 - zeta * zeta) / (1 - 2 * zeta * zeta))) / wd;
    const double e = std::exp(-zeta * omega * t_c) * std::abs(std::cos(wd * t_c) - zeta * omega / wd * std::sin(wd * t_c));
    const double dt = s.time_step_limits().stable() / 8;
    std::int64_t first = -1, last = -1;
    for (std::int64_t n = 0; n < 100000 && (last < 0 || n < last + 10); ++n) {
      s.step(dt);
      if (s.platen_force(0).norm() > 0) {
        if (first < 0) first = n;
      } else if (first >= 0 && last < 0) {
        last = n;
      }
    }
    ASSERT_GT(last, first + 50) << "too few steps in contact to resolve it";
    EXPECT_NEAR((last - first) * dt, t_c, 0.01 * t_c + dt) << "beta " << beta;
    EXPECT_NEAR(s.grain_velocity(0).z() / v0, e, 0.01 * e) << "beta " << beta;
    test::Golden measured("fdem_verify");
    measured.check(fmt::format("box_bounce_beta_{}_restitution_over_exact", beta), s.grain_velocity(0).z() / v0 / e);
    measured.check(fmt::format("box_bounce_beta_{}_contact_time_over_exact", beta), (last - first) * dt / t_c);
    EXPECT_LT(s.grain_velocity(0).head<2>().norm(), 1e-6 * v0);  // no spurious sideways kick
  }
}

// A block on a plane tilted by phi (gravity tilted instead): the Coulomb limit holds it when
// tan(phi) < mu; above, it slides at a = g (sin phi - mu cos phi). The block is flat (1 x 1 x
// 0.25 mm), so the tipping moment leaves every bottom node pressed: a cube at tan(phi) = 0.8 mu
// rocks, its uphill nodes open and lose their spring history, and it creeps (measured 3.5e-9 m in
// 0.4 ms, 0.6 % of a frictionless slide; docs/fdemrun.md). The block first settles on its
// normal spring (damped), then the acceleration is measured between 0.2 and 0.6 ms. Tolerances:
// sliding acceleration within 1 %; a held block moves (between the same times) less than 1e-3 of
// what a frictionless block would (it rocks on its tangential springs by ~1e-12 m).
TEST(FdemVerify, BlockOnAnInclineSticksBelowTanPhiEqualsMuAndSlidesAbove) {
  const double mu = 0.5, g = 9.81;
  for (GrainKind kind : {GrainKind::rigid, GrainKind::tet4})
    for (double tan_phi : {0.3, 0.6}) {
      const double phi = std::atan(tan_phi);
      SolverOptions o;
      o.gravity = g * Eigen::Vector3d(std::sin(phi), 0, -std::cos(phi));
      const Model m = box_on_floor(kind, 0.25e-3, 0, mu);
      Solver s(m, o);
      const double dt = s.time_step_limits().stable();
      const auto run_to = [&](double t) {
        while (s.state().time < t) s.step(dt);
        return std::tuple{s.state().time, s.grain_velocity(0).x(), s.grain_centroid(0).x()};
      };
      const auto [t1, v1, x1] = run_to(2e-4);
      const auto [t2, v2, x2] = run_to(6e-4);
      const double sliding = g * (std::sin(phi) - mu * std::cos(phi));
      if (tan_phi < mu) {
        EXPECT_LT(std::abs(x2 - x1), 1e-3 * g * std::sin(phi) * (t2 * t2 - t1 * t1) / 2) << "kind " << int(kind);
        RecordProperty(fmt::format("kind_{}_held_creep_m", int(kind)), fmt::format("{:.3g}", std::abs(x2 - x1)));
      } else {
        EXPECT_NEAR((v2 - v1) / (t2 - t1), sliding, 0.01 * sliding) << "kind " << int(kind);
        test::Golden("fdem_verify").check(
            fmt::format("incline_{}_sliding_acceleration_over_exact", kind == GrainKind::rigid ? "rigid" : "tet4"),
            (v2 - v1) / (t2 - t1) / sliding);
      }
    }
}

// An elastic (tet4) glass sphere (R = 1 mm, h = R / 3, no contact damping) dropped at 1 m/s on a
// rigid platen rebounds, and the energy books balance: kinetic before = kinetic + strain + contact
// after + dissipated, within 1 %. The Hertz contact radius here (33 um) is far below the element
// size, so the lowest node alone carries the contact: the impact is the penalty spring
// k = p_n A_pole on the sphere's mass, t_c = pi sqrt(M / k), F_max = v0 sqrt(M k) (the sphere's
// own compliance adds a little: tolerance +3 % / -0.5 %). That is 3.1 x the Hertz time and 0.27 x
// its peak force: Hertz needs elements well below the contact radius (the benchmark).
TEST(FdemVerify, ElasticSphereReboundsOnItsContactNodesSpring) {
  Model m;
  m.materials[0] = Material{"glass", 2500, 48e9, 0.2, 0.0, 48e11, 48e11, 0.0};
  GrainSpec sphere;
  sphere.shape = PrimitiveShape::sphere;
  sphere.size = Eigen::Vector3d::Constant(1e-3);
  sphere.position = Eigen::Vector3d(0, 0, 1e-3 + 1e-7);
  sphere.element_size = 1e-3 / 3;
  sphere.kind = GrainKind::tet4;
  sphere.label = 1;
  mesh::append_ellipsoid_grain(m, sphere);
  m.platens = {Platen{"floor", Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), 0}};
  const double v0 = 1.0;
  Solver s(m, SolverOptions{});
  s.set_grain_velocity(0, {0, 0, -v0}, Eigen::Vector3d::Zero());
  const double dt = s.time_step_limits().stable();
  const double M = s.body(0).mass;
  std::int64_t first = -1, last = -1;
  Energies start;
  double peak = 0;
  for (std::int64_t n = 0; n < 200000 && (last < 0 || n < last + 200); ++n) {
    const StepReport r = s.step(dt);
    if (n == 0) start = r.energies;
    const double f = s.platen_force(0).norm();
    peak = std::max(peak, f);
    if (f > 0) {
      if (first < 0) first = n;
      last = -1;
    } else if (first >= 0 && last < 0) {
      last = n;
    }
  }
  const Energies end = s.step(dt).energies;
  ASSERT_GT(first, -1);
  ASSERT_GT(last, first);
  EXPECT_GT(s.grain_velocity(0).z(), 0.5 * v0);  // it comes back up
  EXPECT_NEAR(end.mechanical() + end.dissipated, start.mechanical(), 0.01 * start.mechanical());
  const std::vector<double> area = node_areas(m, Eigen::Vector3d::UnitZ());
  std::size_t pole = 0;
  for (std::size_t i = 0; i < m.nodes.size(); ++i)
    if (m.nodes[i].z() < m.nodes[pole].z()) pole = i;
  const double k_pole = 48e11 * area[pole], t_pole = std::numbers::pi * std::sqrt(M / k_pole);
  const double t_c = (last - first) * dt;
  EXPECT_GT(t_c, 0.995 * t_pole);
  EXPECT_LT(t_c, 1.03 * t_pole);
  EXPECT_NEAR(peak / (v0 * std::sqrt(M * k_pole)), 1.0, 0.03);
  const double hertz = 2.868 * std::pow(M * M / (1e-3 * std::pow(48e9 / (1 - 0.04), 2) * v0), 0.2);
  RecordProperty("contact_time_over_hertz", std::to_string(t_c / hertz));
  test::Golden measured("fdem_verify");
  measured.check("elastic_sphere_contact_time_over_single_node", t_c / t_pole);
  measured.check("elastic_sphere_peak_force_over_single_node", peak / (v0 * std::sqrt(M * k_pole)));
  measured.check("elastic_sphere_rebound_over_v0", s.grain_velocity(0).z() / v0);
}
