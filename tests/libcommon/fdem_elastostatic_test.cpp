// fdem/elastostatic: a box of 4- and 10-node elements pressed between consistent face loads has
// the uniform stress -p e_z e_z in every element; pushed at one end only, it accelerates at F / m
// and its stress falls linearly along it (inertia relief); under arbitrary loads the elements'
// stresses times their volumes sum to the relieved loads' first moment (the discrete Love-Weber
// identity, exact); a grain without elements, a mesh in two pieces and loads of the wrong length
// are refused. Through the solver: a rigid cube pressed by two platens has the uniform stress of
// the platen force over its face, whose volume average is its Love-Weber stress, and the solver
// refuses deformable grains and steps without recorded node forces; in a run, a rigid grain in two
// pieces gets NaN element stresses while the others get theirs.
#include <gtest/gtest.h>

#include <random>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/elastostatic.hpp"
#include "graintwin/fdem/element.hpp"
#include "graintwin/fdem/primitives.hpp"
#include "support/fdem_box.hpp"
#include "graintwin/fdem/solver.hpp"

using namespace graintwin;
using Eigen::Matrix3d;
using Eigen::Vector3d;

namespace {

constexpr double kSide = test::kBoxSide, kLength = test::kBoxLength;  // m: the box is kSide x kSide x kLength along z

fdem::Model box(fdem::GrainKind kind) { return test::box_grain(kind); }

/// Consistent nodal loads of a uniform traction t on the box's face z = z_face: a linear face's
/// corners get A / 3 each; a quadratic face's corners nothing and its mid-edge nodes A / 3 each.
void add_face_traction(const fdem::Model& model, double z_face, const Vector3d& t, std::vector<Vector3d>& loads) {
  const auto on_face = [&](std::uint32_t v) { return std::abs(model.nodes[v].z() - z_face) < 1e-12; };
  for (std::size_t e = 0; e < model.element_count(); ++e) {
    const std::uint32_t* n = model.element_nodes.data() + model.element_offset[e];
    for (int opposite = 0; opposite < 4; ++opposite) {
      std::vector<int> corners;
      for (int k = 0; k < 4; ++k)
        if (k != opposite) corners.push_back(k);
      if (!on_face(n[corners[0]]) || !on_face(n[corners[1]]) || !on_face(n[corners[2]])) continue;
      const Vector3d &a = model.nodes[n[corners[0]]], &b = model.nodes[n[corners[1]]], &c = model.nodes[n[corners[2]]];
      const double area = 0.5 * (b - a).cross(c - a).norm();
      if (model.nodes_of(e) == 4) {
        for (int k : corners) loads[n[k]] += area / 3 * t;
        continue;
      }
      for (int edge = 0; edge < 6; ++edge) {
        const int i = fdem::kTet10Edges[edge][0], j = fdem::kTet10Edges[edge][1];
        if (i != opposite && j != opposite) loads[n[4 + edge]] += area / 3 * t;
      }
    }
  }
}

const char* name(fdem::GrainKind kind) { return kind == fdem::GrainKind::tet4 ? "4-node" : "10-node"; }

}  // namespace

TEST(Elastostatic, ABoxPressedAtBothEndsHasTheUniformStressEverywhere) {
  const double p = 2e6;  // Pa
  for (const auto kind : {fdem::GrainKind::tet4, fdem::GrainKind::tet10}) {
    SCOPED_TRACE(name(kind));
    const fdem::Model model = box(kind);
    const fdem::ElastostaticGrain grain(model, 0, fdem::lumped_masses(model));
    std::vector<Vector3d> loads(model.nodes.size(), Vector3d::Zero());
    add_face_traction(model, 0.5 * kLength, Vector3d(0, 0, -p), loads);
    add_face_traction(model, -0.5 * kLength, Vector3d(0, 0, p), loads);
    const fdem::ElastostaticState s = grain.solve(loads);
    EXPECT_LT(s.acceleration.norm(), 1e-9 * p * kSide * kSide / 1e-6);
    ASSERT_EQ(s.stress.size(), model.element_count());
    Matrix3d expected = Matrix3d::Zero();
    expected(2, 2) = -p;
    for (std::size_t e = 0; e < s.stress.size(); ++e) EXPECT_LT((s.stress[e] - expected).norm(), 1e-8 * p) << "element " << e;
    // Shortened by p L / E and widened by nu p a / E, between corners across the box (the held
    // nodes fix a frame, which may turn the box a little but never stretches it).
    const fdem::Material& m = model.materials[0];
    const auto at = [&](double x, double y, double z) {
      for (std::size_t i = 0; i < model.nodes.size(); ++i)
        if ((model.nodes[i] - Vector3d(x, y, z)).norm() < 1e-12) return s.displacement[i];
      ADD_FAILURE() << "no node at " << x << " " << y << " " << z;
      return Vector3d(Vector3d::Zero());
    };
    const double a = 0.5 * kSide, h = 0.5 * kLength, scale = p * kLength / m.young;
    EXPECT_NEAR(at(a, a, h).z() - at(a, a, -h).z(), -p * kLength / m.young, 1e-8 * scale);
    EXPECT_NEAR(at(a, a, h).x() - at(-a, a, h).x(), m.poisson * p * kSide / m.young, 1e-8 * scale);
  }
}

TEST(Elastostatic, ABoxPushedAtOneEndAcceleratesAndItsStressFallsAlongIt) {
  const double p = 2e6;
  for (const auto kind : {fdem::GrainKind::tet4, fdem::GrainKind::tet10}) {
    SCOPED_TRACE(name(kind));
    const fdem::Model model = box(kind);
    const std::vector<double> mass = fdem::lumped_masses(model);
    const fdem::ElastostaticGrain grain(model, 0, mass);
    std::vector<Vector3d> loads(model.nodes.size(), Vector3d::Zero());
    add_face_traction(model, 0.5 * kLength, Vector3d(0, 0, -p), loads);
    const fdem::ElastostaticState s = grain.solve(loads);
    double total = 0;
    for (const double m : mass) total += m;
    EXPECT_NEAR(s.acceleration.z(), -p * kSide * kSide / total, 1e-12 * p * kSide * kSide / total);
    EXPECT_LT(s.angular_acceleration.norm(), 1e-6 * p * kSide * kSide / total / kLength);
    // sigma_zz(z) = -p (z - z_bottom) / L: the part below z carries what accelerates it.
    for (std::size_t e = 0; e < model.element_count(); ++e) {
      const std::uint32_t* n = model.element_nodes.data() + model.element_offset[e];
      const double z = 0.25 * (model.nodes[n[0]] + model.nodes[n[1]] + model.nodes[n[2]] + model.nodes[n[3]]).z();
      EXPECT_NEAR(s.stress[e](2, 2), -p * (z + 0.5 * kLength) / kLength, (kind == fdem::GrainKind::tet4 ? 0.05 : 0.02) * p)
          << "element " << e << " at z " << z;
    }
  }
}

TEST(Elastostatic, ElementStressesSumToTheRelievedLoadsFirstMoment) {
  std::mt19937 random(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (const auto kind : {fdem::GrainKind::tet4, fdem::GrainKind::tet10}) {
    SCOPED_TRACE(name(kind));
    fdem::Model model = box(kind);
    for (Vector3d& x : model.nodes) x += Vector3d(3e-3, -1e-3, 7e-3);  // away from the origin
    const std::vector<double> mass = fdem::lumped_masses(model);
    const fdem::ElastostaticGrain grain(model, 0, mass);
    std::vector<Vector3d> loads(model.nodes.size());
    for (Vector3d& f : loads) f = Vector3d(normal(random), normal(random), normal(random));
    const fdem::ElastostaticState s = grain.solve(loads);
    double total = 0;
    Vector3d centre = Vector3d::Zero();
    for (std::size_t i = 0; i < mass.size(); ++i) total += mass[i], centre += mass[i] * model.nodes[i];
    centre /= total;
    Matrix3d moment = Matrix3d::Zero(), summed = Matrix3d::Zero();
    for (std::size_t i = 0; i < loads.size(); ++i) {
      const Vector3d r = model.nodes[i] - centre;
      const Vector3d relieved = loads[i] - mass[i] * (s.acceleration + s.angular_acceleration.cross(r));
      moment += model.nodes[i] * relieved.transpose();
    }
    for (std::size_t e = 0; e < model.element_count(); ++e) summed += fdem::element_volume(model, e) * s.stress[e];
    EXPECT_LT((moment - moment.transpose()).norm(), 1e-10 * moment.norm());  // no net moment left
    EXPECT_LT((summed - moment).norm(), 1e-9 * moment.norm());
  }
}

TEST(Elastostatic, RefusesWhatItCannotSolve) {
  const fdem::Model model = box(fdem::GrainKind::tet4);
  const std::vector<double> mass = fdem::lumped_masses(model);
  const fdem::ElastostaticGrain grain(model, 0, mass);
  EXPECT_THROW(grain.solve(std::vector<Vector3d>(model.nodes.size() - 1, Vector3d::Zero())), UsageError);
  EXPECT_THROW(fdem::ElastostaticGrain(model, 0, std::vector<double>(3, 1.0)), DataError);
  // Two tetrahedra apart, one grain: its stiffness is singular.
  fdem::Model apart;
  const std::vector<Vector3d> nodes = {Vector3d(0, 0, 0), Vector3d(1e-3, 0, 0), Vector3d(0, 1e-3, 0), Vector3d(0, 0, 1e-3),
                                       Vector3d(5e-3, 0, 0), Vector3d(6e-3, 0, 0), Vector3d(5e-3, 1e-3, 0), Vector3d(5e-3, 0, 1e-3)};
  const std::vector<std::uint32_t> tets = {0, 1, 2, 3, 4, 5, 6, 7};
  fdem::append_grain_elements(apart, nodes, 4, tets, fdem::GrainKind::tet4, 0, 1);
  try {
    fdem::ElastostaticGrain(apart, 0, fdem::lumped_masses(apart));
    FAIL() << "a grain in two pieces was accepted";
  } catch (const DataError& e) {
    EXPECT_NE(e.message().find("singular"), std::string::npos) << e.message();
  }
  // A grain without elements.
  fdem::Model empty = model;
  empty.grains[0].element_end = empty.grains[0].element_begin;
  EXPECT_THROW(fdem::ElastostaticGrain(empty, 0, mass), DataError);
}

TEST(Elastostatic, ARigidCubeBetweenPlatensThroughTheSolver) {
  constexpr double edge = 1e-3, cut = 1e-6;  // m; each platen starts 1 um inside the cube
  fdem::Model model;
  fdem::add_grain(model, fdem::box_mesh(Vector3d::Constant(edge), 0.25e-3), Vector3d::Zero(), fdem::GrainKind::rigid, 0, 1);
  // A deformable flat box beside it, out of the platens' reach.
  fdem::add_grain(model, fdem::box_mesh(Vector3d(edge, edge, 0.5 * edge), 0.5e-3), Vector3d(3 * edge, 0, 0), fdem::GrainKind::tet4, 0, 2);
  model.platens = {fdem::Platen{"bottom", Vector3d(0, 0, -0.5 * edge + cut), Vector3d::UnitZ(), 0.0},
                   fdem::Platen{"top", Vector3d(0, 0, 0.5 * edge - cut), -Vector3d::UnitZ(), 0.0}};
  fdem::Solver solver(model, fdem::SolverOptions{});
  const double dt = 0.5 * solver.time_step_limits().stable();
  solver.step(dt);
  EXPECT_THROW(solver.elastostatic_stresses(0), UsageError);  // the step's node forces were not kept
  solver.contact_model()->record_node_forces(true);
  solver.step(dt);
  EXPECT_THROW(solver.elastostatic_stresses(1), UsageError);  // deformable: it has its own stresses
  const std::vector<Matrix3d> stress = solver.elastostatic_stresses(0);
  ASSERT_EQ(stress.size(), model.grains[0].element_end - model.grains[0].element_begin);
  const double F = solver.platen_force(1).z();
  ASSERT_GT(F, 0);
  Matrix3d expected = Matrix3d::Zero();
  expected(2, 2) = -F / (edge * edge);
  Matrix3d average = Matrix3d::Zero();
  double volume = 0;
  for (std::size_t e = 0; e < stress.size(); ++e) {
    EXPECT_LT((stress[e] - expected).norm(), 1e-6 * F / (edge * edge)) << "element " << e;
    const double v = fdem::element_volume(model, model.grains[0].element_begin + e);
    average += v * stress[e], volume += v;
  }
  EXPECT_LT((average / volume - solver.grain_stress(0)).norm(), 1e-9 * F / (edge * edge));
}

TEST(Elastostatic, ARigidGrainInPiecesGetsNanStressesInARun) {
  fdem::Model model;
  fdem::add_grain(model, fdem::box_mesh(Vector3d::Constant(1e-3), 0.5e-3), Vector3d::Zero(), fdem::GrainKind::rigid, 0, 1);
  const std::vector<Vector3d> nodes = {Vector3d(3e-3, 0, 0), Vector3d(4e-3, 0, 0), Vector3d(3e-3, 1e-3, 0), Vector3d(3e-3, 0, 1e-3),
                                       Vector3d(6e-3, 0, 0), Vector3d(7e-3, 0, 0), Vector3d(6e-3, 1e-3, 0), Vector3d(6e-3, 0, 1e-3)};
  fdem::append_grain_elements(model, nodes, 4, std::vector<std::uint32_t>{0, 1, 2, 3, 4, 5, 6, 7}, fdem::GrainKind::rigid, 0, 2);
  fdem::SolverOptions options;
  options.elastostatic_stress = true;
  options.gravity = Vector3d(0, 0, -9.81);
  fdem::Solver solver(model, options);
  solver.step(0.5 * solver.time_step_limits().stable());
  EXPECT_TRUE(solver.carries_element_stress(0) && solver.carries_element_stress(1));
  // The box under gravity alone: relieved by its own fall, no stress.
  EXPECT_LT(solver.element_stress(model.grains[0].element_begin).norm(), 1e-6);
  EXPECT_TRUE(solver.element_stress(model.grains[1].element_begin).array().isNaN().all());
}
