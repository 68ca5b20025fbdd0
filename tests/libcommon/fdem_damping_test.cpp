// fdem/ damping of deformable grains and selective mass scaling: stiffness-proportional (Rayleigh)
// damping decays a tetrahedron's modes at the ratio beta omega / 2, its stable step is
// (2 / omega)(sqrt(1 + xi^2) - xi) (a run just above it grows, just below it does not), local
// non-viscous damping takes (1 - alpha) / (1 + alpha) of the strain energy each half cycle, the
// energy books close with both; selective mass scaling lifts the element step to a target that the
// assembled mesh's exact highest frequency allows, with exactly the mass it reports, and the scene
// refuses it beyond its bound, outside quasi-static runs and with keys out of range.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/element.hpp"
#include "graintwin/fdem/mass_scaling.hpp"
#include "graintwin/fdem/primitives.hpp"
#include "graintwin/fdem/solver.hpp"
#include "graintwin/fdem/stages_run.hpp"
#include "support/run_tool.hpp"
#include "support/scene_text.hpp"

using namespace graintwin;
using namespace graintwin::fdem;
using test::replaced;
using test::write_text;

namespace {

constexpr double kHalfSize = 0.5e-3;  // m: the regular tetrahedron's corners are at (+-a, +-a, +-a)

SolverOptions no_contact() {
  SolverOptions o;
  o.contact.enabled = false;
  return o;
}

Material glass() { return Material{"glass", 2500, 60e9, 0.2, 0.5, 60e11, 60e11, 0.0}; }

/// One regular tetrahedron (edge 2 sqrt(2) a), 4- or 10-node (straight mid-edge nodes).
Model regular_tet(GrainKind kind) {
  const double a = kHalfSize;
  std::vector<Eigen::Vector3d> nodes{{a, a, a}, {a, -a, -a}, {-a, -a, a}, {-a, a, -a}};  // positively oriented
  if (kind == GrainKind::tet10)
    for (const auto& edge : kTet10Edges) nodes.push_back(0.5 * (nodes[edge[0]] + nodes[edge[1]]));
  std::vector<std::uint32_t> element(nodes.size());
  for (std::uint32_t k = 0; k < element.size(); ++k) element[k] = k;
  Model m;
  m.materials = {glass()};
  append_grain_elements(m, nodes, static_cast<int>(nodes.size()), element, kind, 0, 1);
  return m;
}

/// The small-vibration modes of a free model about its reference: K phi = omega^2 M phi with the
/// lumped masses M, K by central differences of the internal forces. Ascending; six rigid modes first.
struct Modes {
  Eigen::VectorXd omega;   ///< rad/s
  Eigen::MatrixXd shapes;  ///< one column per mode, 3 per node
};
/// The tangent stiffness of the model's elements at its reference, by central differences of the
/// internal forces (3 rows and columns per node).
Eigen::MatrixXd tangent_stiffness(const Model& m) {
  const ElasticElements elements(m);
  const auto n = static_cast<Eigen::Index>(3 * m.nodes.size());
  const double h = 1e-7 * kHalfSize;
  Eigen::MatrixXd K(n, n);
  for (Eigen::Index j = 0; j < n; ++j) {
    std::vector<Eigen::Vector3d> plus = m.nodes, minus = m.nodes;
    plus[j / 3][j % 3] += h;
    minus[j / 3][j % 3] -= h;
    std::vector<Eigen::Vector3d> f_plus(m.nodes.size(), Eigen::Vector3d::Zero()), f_minus = f_plus;
    elements.add_internal_forces(plus, 0, m.element_count(), f_plus);
    elements.add_internal_forces(minus, 0, m.element_count(), f_minus);
    for (Eigen::Index i = 0; i < n; ++i) K(i, j) = -(f_plus[i / 3][i % 3] - f_minus[i / 3][i % 3]) / (2 * h);
  }
  return K;
}

Modes free_modes(const Model& m, std::span<const double> mass) {
  const Eigen::MatrixXd K = tangent_stiffness(m);
  const Eigen::Index n = K.rows();
  Eigen::VectorXd inv_sqrt_m(n);
  for (Eigen::Index i = 0; i < n; ++i) inv_sqrt_m[i] = 1 / std::sqrt(mass[i / 3]);
  Eigen::MatrixXd A = inv_sqrt_m.asDiagonal() * K * inv_sqrt_m.asDiagonal();
  A = 0.5 * (A + A.transpose());
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(A);
  return {eig.eigenvalues().cwiseMax(0).cwiseSqrt(), inv_sqrt_m.asDiagonal() * eig.eigenvectors()};
}

/// The solver's node positions and velocities, to start it from a displaced state.
std::vector<Eigen::Vector3d>& positions(Solver& s) { return const_cast<std::vector<Eigen::Vector3d>&>(s.state().x); }

/// Displaces every node by `scale` times its part of `shape` (3 per node).
void displace(Solver& s, const Eigen::VectorXd& shape, double scale) {
  auto& x = positions(s);
  for (std::size_t i = 0; i < x.size(); ++i) x[i] += scale * shape.segment<3>(static_cast<Eigen::Index>(3 * i));
}

/// The local maxima of a sampled signal.
std::vector<double> peaks(const std::vector<double>& y) {
  std::vector<double> out;
  for (std::size_t n = 1; n + 1 < y.size(); ++n)
    if (y[n] > y[n - 1] && y[n] >= y[n + 1]) out.push_back(y[n]);
  return out;
}

}  // namespace

TEST(FdemDamping, StiffnessDampingDecaysEachModeAtBetaOmegaOverTwo) {
  // A mode of frequency omega under C = beta K decays at the ratio xi = beta omega / 2: the same
  // beta damps the highest mode 1 / xi times more than the lowest, which is what settles a grain's
  // own vibrations (and what shortens its step). Measured by the logarithmic decrement of the
  // mode's coordinate, for the lowest and highest modes of both element orders.
  for (GrainKind kind : {GrainKind::tet4, GrainKind::tet10}) {
    const Model m = regular_tet(kind);
    const Modes modes = free_modes(m, Solver(m, no_contact()).node_mass());
    for (const Eigen::Index k : {Eigen::Index(6), modes.omega.size() - 1}) {
      const double omega = modes.omega[k], xi = 0.05;
      SolverOptions o = no_contact();
      o.stiffness_damping = 2 * xi / omega;
      Solver s(m, o);
      const Eigen::VectorXd phi = modes.shapes.col(k) / modes.shapes.col(k).cwiseAbs().maxCoeff();
      displace(s, phi, 1e-6 * kHalfSize);
      Eigen::VectorXd mass_phi(phi.size());  // M phi, to project the motion on the mode
      for (Eigen::Index i = 0; i < phi.size(); ++i) mass_phi[i] = s.node_mass()[i / 3] * phi[i];
      const double dt = 2 * std::numbers::pi / omega / 100;
      std::vector<double> q;
      for (int n = 0; n < 600; ++n) {
        double sum = 0;
        for (std::size_t i = 0; i < m.nodes.size(); ++i)
          sum += mass_phi.segment<3>(static_cast<Eigen::Index>(3 * i)).dot(s.state().x[i] - m.nodes[i]);
        q.push_back(sum / mass_phi.dot(phi));
        s.step(dt);
      }
      const std::vector<double> top = peaks(q);
      ASSERT_GE(top.size(), 4u);
      const double decrement = std::log(top.front() / top.back()) / double(top.size() - 1);
      const double measured = decrement / std::sqrt(4 * std::numbers::pi * std::numbers::pi + decrement * decrement);
      EXPECT_NEAR(measured, xi, 0.01 * xi) << enum_name(kGrainKindNames, kind) << " mode " << k << " at " << omega << " rad/s";
    }
  }
}

TEST(FdemDamping, StableStepUnderStiffnessDampingIsTheFormulaAndARunAboveItGrows) {
  const Model m = regular_tet(GrainKind::tet4);
  SolverOptions o = no_contact();
  o.element_safety = 1;
  const Modes modes = free_modes(m, Solver(m, o).node_mass());
  const double omega_max = modes.omega.maxCoeff();
  // The element limit k h_min / c bounds the exact 2 / omega_max from below (k = 0.671 against the
  // regular tetrahedron's 0.707 at nu = 0.2).
  const double bound = Solver(m, o).time_step_limits().element_critical * omega_max / 2;
  EXPECT_LE(bound, 1.0);
  EXPECT_GT(bound, 0.9);

  o.stiffness_damping = 1 / omega_max;  // xi = 0.5 at the highest mode
  const double exact = damped_critical_step(2 / omega_max, o.stiffness_damping);
  EXPECT_NEAR(exact, 2 / omega_max * (std::sqrt(1.25) - 0.5), 1e-12 * exact);
  EXPECT_NEAR(undamped_critical_step(exact, o.stiffness_damping), 2 / omega_max, 1e-12 / omega_max);
  // The solver's limit is the same formula on its critical step.
  const StepLimits limits = Solver(m, o).time_step_limits();
  EXPECT_EQ(limits.stiffness_damping, o.stiffness_damping);
  EXPECT_NEAR(limits.element_stable, damped_critical_step(limits.element_critical, o.stiffness_damping), 1e-12 * exact);
  EXPECT_LT(limits.element_stable, exact);

  // A run from a rough displacement (every mode) at a step 2 % below the formula loses energy; 2 %
  // above, its highest mode grows until the health check stops it; undamped, the same step is stable.
  const auto grows = [&](const SolverOptions& options, double dt) {
    Solver s(m, options);
    auto& x = positions(s);
    for (std::size_t i = 0; i < x.size(); ++i)
      x[i] += 1e-4 * kHalfSize * Eigen::Vector3d(std::sin(7.0 * i + 1), std::cos(3.0 * i), std::sin(11.0 * i + 2));
    double first = 0, last = 0;
    try {
      for (int n = 0; n < 3000; ++n) {
        last = s.step(dt).energies.mechanical();
        if (n == 0) first = last;
      }
    } catch (const DataError&) {
      return true;
    }
    return last > first;
  };
  EXPECT_FALSE(grows(o, 0.98 * exact));
  EXPECT_TRUE(grows(o, 1.02 * exact));
  SolverOptions undamped = o;
  undamped.stiffness_damping = 0;
  EXPECT_FALSE(grows(undamped, 1.02 * exact));
}

TEST(FdemDamping, LocalDampingTakesItsShareOfEveryHalfCycle) {
  // The regular tetrahedron's breathing mode moves every node along its radius, so the per-
  // component law -alpha |f_k| sign(v_k) acts on it as on one degree of freedom: out of a turning
  // point the spring drives with (1 - alpha) of its force, into the next it brakes with (1 + alpha),
  // so the strain energy at successive turning points falls by (1 - alpha) / (1 + alpha).
  const Model m = regular_tet(GrainKind::tet4);
  SolverOptions o = no_contact();
  o.local_damping = 0.2;
  Solver s(m, o);
  const Modes modes = free_modes(m, s.node_mass());
  auto& x = positions(s);
  for (Eigen::Vector3d& p : x) p *= 1 + 1e-5;
  const double dt = 2 * std::numbers::pi / modes.omega.maxCoeff() / 400;
  std::vector<double> strain;
  StepReport r;
  for (int n = 0; n < 1000; ++n) strain.push_back((r = s.step(dt)).energies.strain);
  const std::vector<double> top = peaks(strain);
  ASSERT_GE(top.size(), 3u);
  for (std::size_t k = 1; k < top.size(); ++k) EXPECT_NEAR(top[k] / top[k - 1], 0.8 / 1.2, 0.005) << "turning point " << k;
  // The energy lost is booked as dissipated.
  EXPECT_NEAR(r.energies.mechanical() + r.energies.dissipated, strain.front(), 2e-3 * strain.front());
}

TEST(FdemDamping, EnergyBooksCloseWithStiffnessAndLocalDamping) {
  // A deformable box dropped spinning on a platen under gravity, with both dampings and mass-
  // proportional damping: kinetic + strain + contact + dissipated = energy at the start + external
  // work, and the two dampings dissipate far more than the mass-proportional one alone (whose books,
  // in this rough edge impact, end 1.7 % (tet10) and 3.4 % (tet4) above the start: not checked here).
  for (GrainKind kind : {GrainKind::tet4, GrainKind::tet10}) {
    Model m;
    m.materials = {glass()};
    add_grain(m, box_mesh({1e-3, 1e-3, 0.5e-3}, 0.25e-3), Eigen::Vector3d(0, 0, 0.25e-3 + 1e-6), kind, 0, 1);
    m.platens = {Platen{"floor", Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), 0}};
    const auto books = [&](double beta_share, double local) {
      SolverOptions o;
      o.gravity = Eigen::Vector3d(0, 0, -9.81);
      o.damping = 100;
      o.local_damping = local;
      const double critical = Solver(m, o).time_step_limits().element_critical;
      o.stiffness_damping = beta_share * critical;
      Solver s(m, o);
      s.set_grain_velocity(0, {0.1, 0, -0.5}, {0, 300, 0});
      const double dt = 0.9 * s.time_step_limits().stable();
      const Energies start = s.step(dt).energies;
      Energies end;
      for (int n = 0; n < 4000; ++n) end = s.step(dt).energies;
      EXPECT_GT(end.strain + end.contact_elastic, 0) << "the box never touched the platen";
      if (local > 0) {
        EXPECT_NEAR(end.mechanical() + end.dissipated - end.external_work, start.mechanical(), 0.01 * start.mechanical())
            << enum_name(kGrainKindNames, kind) << " beta " << o.stiffness_damping << " s, local " << local;
      }
      return end.dissipated;
    };
    const double without = books(0, 0), with = books(2, 0.3);
    EXPECT_GT(with, 1.5 * without) << enum_name(kGrainKindNames, kind);
  }
}

TEST(FdemDamping, ElementStiffnessIsTheTangentOfTheElementForces) {
  for (GrainKind kind : {GrainKind::tet4, GrainKind::tet10}) {
    const Model m = regular_tet(kind);
    const Eigen::MatrixXd tangent = tangent_stiffness(m);
    ElementStiffness K;
    const int n = element_stiffness(m, 0, lame_constants(m.materials[0]), K);
    ASSERT_EQ(3 * n, tangent.rows());
    EXPECT_LT((K.topLeftCorner(3 * n, 3 * n) - tangent).norm(), 1e-6 * tangent.norm()) << enum_name(kGrainKindNames, kind);
  }
}

namespace {

/// A unit box of cells^3 cubes whose first inner plane of nodes across x is moved to 0.2 of the way
/// from the face: a layer of flat elements among larger ones, as slivers in a grain's mesh. A
/// monotone map of x keeps every element positively oriented.
TetMesh thin_layer_box(int cells) {
  const double size = 1e-3, h = size / cells;
  TetMesh mesh = box_mesh(Eigen::Vector3d::Constant(size), h);
  for (Eigen::Vector3d& p : mesh.nodes)
    if (std::abs(p.x() - (h - size / 2)) < 1e-9 * size) p.x() = 0.2 * h - size / 2;
  return mesh;
}

/// The thin-layer box as a grain of `kind`, beside a rigid box that must get no mass.
Model thin_layer_model(GrainKind kind) {
  Model m;
  m.materials = {glass()};
  add_grain(m, thin_layer_box(kind == GrainKind::tet10 ? 2 : 4), Eigen::Vector3d::Zero(), kind, 0, 1);
  add_grain(m, box_mesh(Eigen::Vector3d::Constant(1e-3), 1e-3), Eigen::Vector3d(3e-3, 0, 0), GrainKind::rigid, 0, 2);
  return m;
}

}  // namespace

TEST(FdemDamping, SelectiveMassScalingGuaranteesItsTargetOnTheAssembledMesh) {
  // The exact highest frequency of the scaled mesh (its modes with the scaled lumped masses) allows
  // the target, with or without stiffness damping, and the mass added is the mass reported, all on
  // the deformable grain's nodes.
  for (GrainKind kind : {GrainKind::tet4, GrainKind::tet10})
    for (const double multiple : {2.0, 4.0})
      for (const double beta_share : {0.0, 1.0}) {
        const Model m = thin_layer_model(kind);
        SolverOptions o = no_contact();
        const double critical = Solver(m, o).time_step_limits().element_critical;
        o.stiffness_damping = beta_share * critical;
        Solver s(m, o);
        const std::vector<double> before(s.node_mass().begin(), s.node_mass().end());
        const double target = multiple * s.time_step_limits().element_stable;
        const SelectiveMassScaling out = scale_limiting_nodes(s, target, o.stiffness_damping, 1.0, "test");
        const std::string what = fmt::format("{} at {} x, beta {:g} s", enum_name(kGrainKindNames, kind), multiple, o.stiffness_damping);
        const StepLimits limits = s.time_step_limits();
        EXPECT_TRUE(limits.guaranteed) << what;
        EXPECT_GE(out.step_after, target) << what;
        EXPECT_NEAR(out.step_after, target, 1e-9 * target) << what;
        EXPECT_EQ(limits.element_stable, out.step_after) << what;
        EXPECT_LT(out.guaranteed_before, out.step_before) << what;
        const double omega = free_modes(m, s.node_mass()).omega.maxCoeff();
        EXPECT_GE(damped_critical_step(2 / omega, o.stiffness_damping) * o.element_safety, target) << what;
        double added = 0;
        std::size_t heavier = 0;
        for (std::size_t v = 0; v < before.size(); ++v) {
          added += s.node_mass()[v] - before[v];
          heavier += s.node_mass()[v] > before[v] ? 1 : 0;
          if (v >= m.grains[1].node_begin) {
            EXPECT_EQ(s.node_mass()[v], before[v]) << what << ": the rigid box's node " << v;
          }
        }
        EXPECT_EQ(heavier, out.nodes) << what;
        EXPECT_LT(out.nodes, m.grains[0].node_end) << what << ": the mass goes where the layer is";
        EXPECT_NEAR(added, out.added_mass, 1e-12 * out.added_mass) << what;
        EXPECT_NEAR(out.grains_mass, s.body(0).mass + s.body(1).mass, 1e-15) << what;
        // A target the elements already allow adds nothing.
        Solver fresh(m, o);
        EXPECT_EQ(scale_limiting_nodes(fresh, 0.5 * out.step_before, o.stiffness_damping, 1.0, "test").nodes, 0u) << what;
      }
}

TEST(FdemDamping, SelectiveMassScalingRunsAtItsTargetWhereTheUnscaledMeshRunsAway) {
  // Shaken in its highest mode, the thin-layer tet10 box keeps its energy for 3 000 steps at four
  // times its element limit once scaled, and runs away at that step without the scaling.
  const Model m = thin_layer_model(GrainKind::tet10);
  const SolverOptions o = no_contact();
  Solver plain(m, o);
  const Modes modes = free_modes(m, plain.node_mass());
  const Eigen::VectorXd highest = modes.shapes.col(modes.omega.size() - 1) / modes.shapes.col(modes.omega.size() - 1).cwiseAbs().maxCoeff();
  const double dt = 4 * plain.time_step_limits().element_stable;
  const auto energy_growth = [&](Solver& s) {
    displace(s, highest, 1e-6 * kHalfSize);
    const double start = s.step(dt).energies.mechanical();
    double end = start;
    try {
      for (int n = 0; n < 3000; ++n) end = s.step(dt).energies.mechanical();
    } catch (const DataError&) {
      return std::numeric_limits<double>::infinity();  // the solver's runaway stop
    }
    return end / start;
  };
  Solver scaled(m, o);
  scale_limiting_nodes(scaled, dt, 0, 1.0, "test");
  // A stable central-difference run's energy, from half-step velocities, swings within a factor of
  // 1 / (1 - (omega dt / 2)^2) of the start, at most 2.8 at the element safety's omega dt <= 1.6.
  EXPECT_LT(energy_growth(scaled), 3.0);
  EXPECT_GT(energy_growth(plain), 1e3);
}

namespace {

/// The two-box scene (a tet10 box of 24 elements, a rigid box) with [run] `keys` added.
std::string two_boxes_with(const std::string& keys) { return replaced(test::kTwoBoxScene, "[run]\n", "[run]\n" + keys + "\n"); }

std::string usage_error(const std::function<void()>& run) {
  try {
    run();
  } catch (const UsageError& e) {
    return e.message();
  }
  return "no error";
}

}  // namespace

TEST(FdemDamping, SelectiveMassScalingBeyondItsBoundIsRefusedWithTheNumbers) {
  const test::TempDir dir;
  const Scene scene = read_scene(write_text(dir, "s.toml", two_boxes_with("damping = 1000\nelement_step_target = 1e-6")));
  Model model = build_model(scene);
  const std::string message = usage_error([&] { start_run(scene, model, "s.toml"); });
  for (const char* part : {"s.toml: selective mass scaling to an element step of 1e-06 s", "% of the grains' mass",
                           " nodes, up to ", "above the bound of 1 %", "[run] element_step_target", "max_added_mass_share"})
    EXPECT_NE(message.find(part), std::string::npos) << part << " in: " << message;
  const Scene raised = read_scene(
      write_text(dir, "r.toml", two_boxes_with("damping = 1000\nelement_step_target = 1e-6\nmax_added_mass_share = 1")));
  Model raised_model = build_model(raised);
  EXPECT_NE(usage_error([&] { start_run(raised, raised_model, "r.toml"); }).find("above the bound of 100 %"), std::string::npos);

  // Within its bound it runs at the target, and the run's parameters carry what it added.
  const double limit = Solver(raised_model, SolverOptions{}).time_step_limits().element_stable;
  const Scene fits = read_scene(write_text(
      dir, "f.toml",
      two_boxes_with(fmt::format("damping = 1000\nelement_step_target = {:.17g}\nmax_added_mass_share = 0.1", 1.2 * limit))));
  Model fits_model = build_model(fits);
  const RunStart start = start_run(fits, fits_model, "f.toml");
  const Solver& solver = *start.solver;
  const SelectiveMassScaling& scaling = start.selective_scaling;
  double added = 0;
  for (const double a : solver.added_node_mass()) added += a;
  EXPECT_GT(scaling.nodes, 0u);
  EXPECT_NEAR(scaling.added_share(), added / (solver.body(0).mass + solver.body(1).mass), 1e-12);
  const RunSchedule schedule = schedule_run(fits, solver, "f.toml");
  EXPECT_NEAR(schedule.dt, 1.2 * limit, 1e-9 * limit);
  const nlohmann::json p = run_parameters(fits, "f.toml", "", start, schedule, 1, "");
  EXPECT_EQ(p["selective_mass_scaling"]["nodes"], scaling.nodes);
  EXPECT_NEAR(p["selective_mass_scaling"]["added_mass_share"].get<double>(), scaling.added_share(), 1e-15);
  EXPECT_EQ(p["selective_mass_scaling"]["max_added_mass_share"], 0.1);
  EXPECT_EQ(p["damping"]["mass_proportional"], 1000.0);
}

TEST(FdemDamping, SelectiveMassScalingOutsideQuasiStaticRunsIsRefused) {
  const test::TempDir dir;
  EXPECT_NE(usage_error([&] { read_scene(write_text(dir, "u.toml", two_boxes_with("element_step_target = 1e-7"))); })
                .find("u.toml: [run] element_step_target (selective mass scaling) is for quasi-static runs only, a [triaxial] "
                      "test or stages that all damp the grains, and stage 'still' has no damping"),
            std::string::npos);
  // Every stage must damp, by any of the three kinds.
  const std::string one_damped = replaced(two_boxes_with("element_step_target = 1e-7"), "name = \"still\"",
                                          "name = \"still\"\nlocal_damping = 0.7");
  EXPECT_NE(usage_error([&] { read_scene(write_text(dir, "one.toml", one_damped)); }).find("stage 'press' has no damping"),
            std::string::npos);
  EXPECT_EQ(usage_error([&] {
              read_scene(write_text(dir, "ok.toml", replaced(one_damped, "name = \"press\"", "name = \"press\"\nstiffness_damping = 1e-9")));
            }),
            "no error");
}

TEST(FdemDamping, SceneKeysOutOfRangeAreRefusedNamingTableAndKey) {
  const test::TempDir dir;
  const auto error = [&](const std::string& text) { return usage_error([&] { read_scene(write_text(dir, "k.toml", text)); }); };
  const auto found = [&](const std::string& keys, const std::string& part) {
    EXPECT_NE(error(two_boxes_with(keys)).find(part), std::string::npos) << keys;
  };
  found("stiffness_damping = -1e-9", "k.toml: [run]: stiffness_damping must not be negative");
  found("local_damping = 1", "k.toml: [run]: local_damping must lie in [0, 1)");
  found("element_step_target = -1", "k.toml: [run]: element_step_target must not be negative");
  found("damping = 1\nelement_step_target = 1e-7\nmax_added_mass_share = 0", "max_added_mass_share must lie in (0, 1]");
  found("max_added_mass_share = 0.05", "max_added_mass_share bounds selective mass scaling, which element_step_target asks for");
  found("stiffness_dampng = 1e-9", "key 'stiffness_dampng' is unknown; did you mean 'stiffness_damping'?");
  const auto stage_error = [&](const std::string& key) {
    return error(replaced(test::kTwoBoxScene, "name = \"still\"", "name = \"still\"\n" + key));
  };
  EXPECT_NE(stage_error("local_damping = -0.1").find("k.toml: [[stages]] 1: local_damping must lie in [0, 1)"), std::string::npos);
  EXPECT_NE(stage_error("stiffness_damping = -1").find("k.toml: [[stages]] 1: stiffness_damping must not be negative"),
            std::string::npos);
}

TEST(FdemDamping, TheScheduleAllowsForTheLargestStiffnessDampingOfAnyStage) {
  const test::TempDir dir;
  const std::string damped_press = replaced(test::kTwoBoxScene, "name = \"press\"", "name = \"press\"\nstiffness_damping = 1e-7");
  const Scene scene = read_scene(write_text(dir, "two.toml", damped_press));
  EXPECT_EQ(scene.largest_stiffness_damping(), 1e-7);
  Model model = build_model(scene);
  const RunStart start = start_run(scene, model, "two.toml");
  const RunSchedule s = schedule_run(scene, *start.solver, "two.toml");
  EXPECT_EQ(s.limits.stiffness_damping, 1e-7);
  EXPECT_NEAR(s.dt, scene.element_safety * damped_critical_step(s.limits.element_critical, 1e-7), 1e-12 * s.dt);
  EXPECT_LT(s.dt, 0.5 * scene.element_safety * s.limits.element_critical);
  // A [run] time_step the undamped stage would allow is refused for the damped one.
  const Scene too_long = read_scene(write_text(dir, "fixed.toml", replaced(damped_press, "[run]\n", fmt::format("[run]\ntime_step = {:.6g}\n", 1.01 * s.dt))));
  EXPECT_NE(usage_error([&] { schedule_run(too_long, *start.solver, "fixed.toml"); }).find("damped by stiffness_damping 1e-07 s"),
            std::string::npos);
}
