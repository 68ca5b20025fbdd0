// fdem/implicit_grain: a deformable grain stepped implicitly in its corotated frame, alone and in the
// solver (SolverOptions::implicit_grains: a 10-node box pressed on a platen by 1 000 g rests stably
// at 70 element steps, its platen force its weight). A box pressed at
// both ends settles, at steps 25 times the element limit, to the small-strain static state under
// the same loads (fdem/elastostatic); a spinning box keeps its shape and spin; random node velocities at 100 times
// the element limit never gain energy; bad inputs are refused.
#include <gtest/gtest.h>

#include <filesystem>
#include <random>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/elastostatic.hpp"
#include "graintwin/fdem/element.hpp"
#include "graintwin/fdem/implicit_grain.hpp"
#include "graintwin/fdem/primitives.hpp"
#include "graintwin/fdem/solver.hpp"
#include "graintwin/io/h5file.hpp"
#include "support/fdem_box.hpp"

using namespace graintwin;
using Eigen::Vector3d;

namespace {

constexpr double kSide = test::kBoxSide, kLength = test::kBoxLength;  // m: the box is kSide x kSide x kLength along z

fdem::Model box(fdem::GrainKind kind) { return test::box_grain(kind); }

/// The explicit element step of the box: its smallest altitude over the dilatational wave speed.
double element_step(const fdem::Model& model) {
  double altitude = 1e300;
  for (std::size_t e = 0; e < model.element_count(); ++e) altitude = std::min(altitude, fdem::element_min_altitude(model, e));
  return altitude / fdem::dilatational_wave_speed(model.materials[0]);
}

/// A platen 1 um below the box's bottom face; options with 1 000 g of gravity pressing the model's
/// grains onto it, mass damping 5 000 /s and implicit grains.
fdem::SolverOptions on_a_platen(fdem::Model& model) {
  model.platens = {fdem::Platen{"bottom", Vector3d(0, 0, -0.5 * kLength - 1e-6), Vector3d::UnitZ(), 0.0}};
  fdem::SolverOptions options;
  options.gravity = Vector3d(0, 0, -9810);
  options.damping = 5000;
  options.implicit_grains = true;
  return options;
}

double kinetic(const std::vector<double>& mass, const std::vector<Vector3d>& v) {
  double k = 0;
  for (std::size_t i = 0; i < v.size(); ++i) k += 0.5 * mass[i] * v[i].squaredNorm();
  return k;
}

}  // namespace

TEST(ImplicitGrain, ABoxPressedAtBothEndsSettlesToTheStaticShortening) {
  const double p = 2e6;  // Pa, on the end faces' nodes as equal shares of p A
  for (const auto kind : {fdem::GrainKind::tet4, fdem::GrainKind::tet10}) {
    SCOPED_TRACE(kind == fdem::GrainKind::tet4 ? "4-node" : "10-node");
    const fdem::Model model = box(kind);
    const std::vector<double> mass = fdem::lumped_masses(model);
    const double dt = 25 * element_step(model);
    fdem::ImplicitGrain grain(model, 0, mass, dt);
    // Consistent loads of a uniform traction are not equal shares; the shortening of the box's
    // length between its end faces' mean planes is p L / E for any loads of total p A on each face.
    std::vector<Vector3d> f(model.nodes.size(), Vector3d::Zero());
    std::vector<std::size_t> top, bottom;
    for (std::size_t i = 0; i < model.nodes.size(); ++i) {
      if (std::abs(model.nodes[i].z() - 0.5 * kLength) < 1e-12) top.push_back(i);
      if (std::abs(model.nodes[i].z() + 0.5 * kLength) < 1e-12) bottom.push_back(i);
    }
    ASSERT_FALSE(top.empty());
    for (std::size_t i : top) f[i].z() = -p * kSide * kSide / static_cast<double>(top.size());
    for (std::size_t i : bottom) f[i].z() = p * kSide * kSide / static_cast<double>(bottom.size());
    std::vector<Vector3d> x = model.nodes, v(model.nodes.size(), Vector3d::Zero());
    for (int n = 0; n < 400; ++n) grain.step(x, v, f);
    // The end faces' mean planes come closer by the static solution's shortening under the same
    // loads (equal shares concentrate the load at the face's edges: 8-9 % beyond p L / E here).
    const fdem::ElastostaticState statics = fdem::ElastostaticGrain(model, 0, mass).solve(f);
    const auto mean_z = [](const std::vector<std::size_t>& face, const auto& z) {
      double sum = 0;
      for (std::size_t i : face) sum += z(i);
      return sum / static_cast<double>(face.size());
    };
    const double shortening = kLength - (mean_z(top, [&](std::size_t i) { return x[i].z(); }) -
                                         mean_z(bottom, [&](std::size_t i) { return x[i].z(); }));
    const double expected = mean_z(bottom, [&](std::size_t i) { return statics.displacement[i].z(); }) -
                            mean_z(top, [&](std::size_t i) { return statics.displacement[i].z(); });
    EXPECT_NEAR(shortening, expected, 1e-3 * expected);
    EXPECT_NEAR(expected, p * kLength / model.materials[0].young, 0.1 * expected);
    EXPECT_LT(kinetic(mass, v), 1e-6 * 0.5 * p * expected * kSide * kSide) << "at rest";
    std::printf("%s box, dt = %.3g s (25 element steps): shortening %.6g m, the static solution's %.6g m (p L / E %.4g m)\n",
                kind == fdem::GrainKind::tet4 ? "4-node" : "10-node", dt, shortening, expected,
                p * kLength / model.materials[0].young);
  }
}

TEST(ImplicitGrain, ASpinningBoxKeepsItsShapeAndItsSpin) {
  const fdem::Model model = box(fdem::GrainKind::tet10);
  const std::vector<double> mass = fdem::lumped_masses(model);
  const double dt = 1e-6;  // omega dt = 1e-3, far beyond the element step
  ASSERT_GT(dt, 10 * element_step(model));
  fdem::ImplicitGrain grain(model, 0, mass, dt);
  const Vector3d omega(300, 600, 800);  // rad/s, tip speeds about 1 m/s
  std::vector<Vector3d> x = model.nodes, v(model.nodes.size());
  for (std::size_t i = 0; i < x.size(); ++i) v[i] = omega.cross(x[i]);
  const std::vector<Vector3d> f(model.nodes.size(), Vector3d::Zero());
  const auto spin = [&] {  // angular momentum about the mass centre
    Vector3d c = Vector3d::Zero(), L = Vector3d::Zero();
    double m = 0;
    for (std::size_t i = 0; i < x.size(); ++i) c += mass[i] * x[i], m += mass[i];
    c /= m;
    for (std::size_t i = 0; i < x.size(); ++i) L += mass[i] * (x[i] - c).cross(v[i]);
    return L;
  };
  const Vector3d L0 = spin();
  const double k0 = kinetic(mass, v);
  double strain = 0;
  for (int n = 0; n < 2000; ++n) strain = grain.step(x, v, f).strain_end;  // 2 rad about the axis
  EXPECT_LT((spin() - L0).norm(), 0.02 * L0.norm());
  EXPECT_NEAR(kinetic(mass, v), k0, 0.03 * k0);
  EXPECT_LT(strain, 1e-3 * k0) << "the box keeps its shape while it turns";
  double largest = 0;
  for (const Vector3d& u : grain.displacement(x)) largest = std::max(largest, u.norm());
  EXPECT_LT(largest, 1e-4 * kLength);
}

TEST(ImplicitGrain, NeverGainsEnergyFarBeyondTheElementStep) {
  const fdem::Model model = box(fdem::GrainKind::tet10);
  const std::vector<double> mass = fdem::lumped_masses(model);
  fdem::ImplicitGrain grain(model, 0, mass, 100 * element_step(model));
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0.0, 0.1);  // m/s per component, every node its own
  std::vector<Vector3d> x = model.nodes, v(model.nodes.size());
  for (Vector3d& w : v) w = Vector3d(noise(rng), noise(rng), noise(rng));
  const std::vector<Vector3d> f(model.nodes.size(), Vector3d::Zero());
  double energy = kinetic(mass, v), strain = 0;
  for (int n = 0; n < 300; ++n) {
    strain = grain.step(x, v, f).strain_end;
    const double now = kinetic(mass, v) + strain;
    ASSERT_LE(now, energy * (1 + 1e-9)) << "step " << n;
    energy = now;
  }
  for (const Vector3d& y : x) ASSERT_TRUE(y.allFinite());
}

TEST(ImplicitGrain, RefusesBadInputs) {
  const fdem::Model model = box(fdem::GrainKind::tet4);
  const std::vector<double> mass = fdem::lumped_masses(model);
  EXPECT_THROW(fdem::ImplicitGrain(model, 0, mass, 0.0), UsageError);
  EXPECT_THROW(fdem::ImplicitGrain(model, 0, std::vector<double>(3, 1.0), 1e-7), UsageError);
  std::vector<double> massless(mass.size(), 0.0);
  EXPECT_THROW(fdem::ImplicitGrain(model, 0, massless, 1e-7), DataError);
  fdem::SolverOptions options;
  options.implicit_grains = true;
  options.stiffness_damping = 1e-8;
  EXPECT_THROW(fdem::Solver(model, options), UsageError) << "stiffness damping is not in the implicit step";
  options.stiffness_damping = 0;
  options.local_damping = 0.1;
  EXPECT_THROW(fdem::Solver(model, options), UsageError) << "nor local damping";
}

TEST(ImplicitGrain, ABoxPressedOnAPlatenByGravityRestsStablyAtTheRigidContactStep) {
  // The question before fdemrun may use implicit grains: does explicit penalty contact stay stable
  // on them at the step the rigid twin's contact allows (contact seeing each node as a rigid grain's)?
  // A 10-node box 1 um above a platen, under 1 000 g (so that it presses in), damped, stepped at the
  // solver's stable step with implicit grains, far beyond its element step.
  fdem::Model model = box(fdem::GrainKind::tet10);
  const fdem::SolverOptions options = on_a_platen(model);
  fdem::Solver solver(model, options);
  const fdem::StepLimits limits = solver.time_step_limits();
  const double dt = limits.stable();
  const double element = fdem::Solver(model, fdem::SolverOptions{}).time_step_limits().element_stable;
  EXPECT_GT(dt, 10 * element) << "the implicit grain's step is the contact's, beyond its elements'";
  double mass = 0;
  for (double m : fdem::lumped_masses(model)) mass += m;
  const double weight = mass * 9810;
  fdem::Energies e;
  const int steps = 4000;
  double first_mechanical = 0;
  for (int n = 0; n < steps; ++n) {
    const fdem::StepReport r = solver.step(dt);
    e = r.energies;
    if (n == 0) first_mechanical = e.mechanical();
  }
  const double force = solver.platen_force(0).z();
  std::printf("10-node box on a platen: dt %.3g s (%.0f element steps), after %d steps platen force %.5g N against the "
              "weight %.5g N, kinetic %.3g J, strain %.3g J, contact elastic %.3g J; books: mechanical + dissipated - work "
              "- start %.3g J\n",
              dt, dt / element, steps, force, weight, e.kinetic, e.strain, e.contact_elastic,
              e.mechanical() + e.dissipated - e.external_work - first_mechanical);
  std::printf("dissipated %.4g J, external work %.4g J, first mechanical %.4g J\n", e.dissipated, e.external_work, first_mechanical);
  EXPECT_NEAR(std::abs(force), weight, 0.01 * weight) << "at rest on the platen";
  // At rest its elements' average stress is the Love-Weber stress of its contact forces (the
  // implicit step holds its internal forces: the step's node forces are the contact's alone).
  const Eigen::Matrix3d elements = solver.grain_stress(0), contact = solver.love_weber_stresses()[0];
  EXPECT_NEAR(contact(2, 2), elements(2, 2), 1e-3 * std::abs(elements(2, 2)));
  EXPECT_LT(e.kinetic, 1e-3 * (e.strain + e.contact_elastic));
  EXPECT_GT(e.strain, 0.0);
}

TEST(ImplicitGrain, BooksOfAFallingDampedGrainClose) {
  // Free fall with mass damping, a spin and a squeeze: the books kept as leapfrog keeps them (work
  // and kinetic energy at the step's mean velocity) close within 1e-5 of the work (what is left: the
  // reported kinetic energy at the mean velocity against the end velocity's in the books). Booked
  // at the end velocities they lost h F^2 / (2 m) a step to a dissipation that never happened: 7e-4.
  fdem::Model model = box(fdem::GrainKind::tet10);
  fdem::SolverOptions options;
  options.gravity = Vector3d(0, 0, -9810);
  options.damping = 2000;
  options.implicit_grains = true;
  fdem::Solver solver(model, options);
  solver.set_grain_velocity(0, Vector3d::Zero(), Vector3d(0, 0, 300));
  for (std::size_t i = 0; i < model.nodes.size(); ++i)  // and squeezed along its length
    solver.set_node_state(static_cast<std::uint32_t>(i), model.nodes[i], solver.state().v[i] + Vector3d(0, 0, -0.2 * model.nodes[i].z() / kLength));
  const double dt = 50 * element_step(model);
  fdem::Energies first, e;
  for (int n = 0; n < 1000; ++n) {
    e = solver.step(dt).energies;
    if (n == 0) first = e;
  }
  const double residual = e.mechanical() + e.dissipated - e.external_work - first.mechanical();
  std::printf("falling box: work %.4g J, dissipated %.4g J, residual %.3g J\n", e.external_work, e.dissipated, residual);
  EXPECT_GT(e.dissipated, 0.0);
  EXPECT_LT(std::abs(residual), 3e-5 * e.external_work);
}

TEST(ImplicitGrain, ARestartGoesOnAsTheUninterruptedRun) {
  // An implicit grain keeps no state beyond positions and velocities: its strain energy at a step's
  // start comes from its positions, so a restarted run books and moves as the uninterrupted one.
  fdem::Model model = box(fdem::GrainKind::tet10);
  const fdem::SolverOptions options = on_a_platen(model);
  fdem::Solver uninterrupted(model, options);
  const double dt = uninterrupted.time_step_limits().stable();
  const auto path = std::filesystem::temp_directory_path() / "fdem_implicit_grain_restart_test.h5";
  for (int n = 0; n < 300; ++n) uninterrupted.step(dt);
  {
    io::H5File file = io::H5File::create(path);
    uninterrupted.save(file, "/solver");
  }
  fdem::Solver restarted(model, options);
  restarted.load(io::H5File::open(path), "/solver");
  std::filesystem::remove(path);
  for (int n = 0; n < 200; ++n) {
    const fdem::Energies a = uninterrupted.step(dt).energies, b = restarted.step(dt).energies;
    ASSERT_EQ(a.strain, b.strain) << "step " << n;
    ASSERT_EQ(a.kinetic, b.kinetic) << "step " << n;
    ASSERT_GT(a.strain, 0.0);
  }
  EXPECT_EQ(uninterrupted.state().x, restarted.state().x);
}

TEST(ImplicitGrain, AStackOfTwoGrainsRestsOnItsPlaten) {
  // Two 10-node boxes, one on the other, fall onto a platen: the second grain's nodes lie past the
  // first's in the model's arrays, and grain-grain contact acts on implicit grains from both sides.
  fdem::Model model = box(fdem::GrainKind::tet10);
  fdem::add_grain(model, fdem::box_mesh(Vector3d(kSide, kSide, kLength), 0.25e-3), Vector3d(0, 0, kLength + 2e-6), fdem::GrainKind::tet10,
                  0, 2);
  const fdem::SolverOptions options = on_a_platen(model);
  fdem::Solver solver(model, options);
  // The contact step assumes 12 nodes of a grain pressed at once (rigid_contact_nodes); two faces of
  // 10-node triangles pressed flat press about 100 (at the full step the upper box's sideways motion
  // flips sign every step and never settles), so half of it.
  const double dt = solver.time_step_limits().stable() / 2;
  EXPECT_GT(dt, 20 * fdem::Solver(model, fdem::SolverOptions{}).time_step_limits().element_stable);
  for (int n = 0; n < 3000; ++n) solver.step(dt);
  double mass = 0;
  for (double m : fdem::lumped_masses(model)) mass += m;
  const double weight = mass * 9810;
  EXPECT_NEAR(std::abs(solver.platen_force(0).z()), weight, 1e-3 * weight);
  // The upper box rests on the lower one, a box's length above it, not sunk in.
  const double gap = solver.grain_centroid(1).z() - solver.grain_centroid(0).z();
  EXPECT_NEAR(gap, kLength, 1e-2 * kLength);
  EXPECT_LT(solver.grain_velocity(1).norm(), 1e-3);  // m/s: it landed at 0.14 m/s
}
