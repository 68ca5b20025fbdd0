// fdem/ elements, masses and primitive grains: the patch test (a linear displacement field gives
// uniform strain and exactly balanced internal forces), zero stress under large rigid rotations,
// HRZ lumping of 10-node tetrahedra, exact mass properties, closed outward box surfaces; 10-node
// grains split into 4-node ones on their own nodes keep their nodes, surface, volume and mass, and a
// grain whose split would invert a curved element's part keeps its 10 nodes.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <numeric>
#include <set>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/element.hpp"
#include "graintwin/fdem/primitives.hpp"

using namespace graintwin;
using namespace graintwin::fdem;

namespace {

Model box_model(GrainKind kind, const Eigen::Vector3d& size = {2e-3, 1e-3, 1.5e-3}, double h = 0.5e-3) {
  Model m;
  add_grain(m, box_mesh(size, h), Eigen::Vector3d(0.01, -0.02, 0.03), kind, 0, 7);
  return m;
}

std::vector<Eigen::Vector3d> mapped(const Model& m, const Eigen::Matrix3d& A, const Eigen::Vector3d& b) {
  std::vector<Eigen::Vector3d> x;
  for (const auto& X : m.nodes) x.push_back(A * X + b);
  return x;
}

/// Second Piola-Kirchhoff stress of St Venant-Kirchhoff for a uniform deformation gradient F.
Eigen::Matrix3d svk_pk2(const Material& mat, const Eigen::Matrix3d& F) {
  const Lame L = lame_constants(mat);
  const Eigen::Matrix3d E = 0.5 * (F.transpose() * F - Eigen::Matrix3d::Identity());
  return L.lambda * E.trace() * Eigen::Matrix3d::Identity() + 2 * L.mu * E;
}

class Kinds : public ::testing::TestWithParam<GrainKind> {};

}  // namespace

TEST(FdemShape, PartitionOfUnityAndDerivatives) {
  for (int n : {4, 10}) {
    const Eigen::Vector3d xi(0.2, 0.3, 0.1);
    double N[10], Np[10];
    Eigen::Matrix<double, 10, 3> dN;
    tet_shape_functions(n, xi, N);
    tet_shape_derivatives(n, xi, dN);
    EXPECT_NEAR(std::accumulate(N, N + n, 0.0), 1.0, 1e-15);
    for (int k = 0; k < 3; ++k) {
      const double h = 1e-6;
      tet_shape_functions(n, xi + h * Eigen::Vector3d::Unit(k), Np);
      for (int a = 0; a < n; ++a) EXPECT_NEAR((Np[a] - N[a]) / h, dN(a, k), 1e-5) << "node " << a;
    }
  }
}

TEST(FdemQuadrature, ExactRuleIntegratesDegreeSeven) {
  // int over the unit tetrahedron of x^a y^b z^c = a! b! c! / (a + b + c + 3)!
  const TetRule& r = exact_rule();
  const auto fact = [](int k) { return std::tgamma(k + 1.0); };
  for (auto [a, b, c] : {std::array{0, 0, 0}, {2, 3, 2}, {7, 0, 0}, {1, 4, 2}}) {
    double sum = 0;
    for (std::size_t q = 0; q < r.points.size(); ++q)
      sum += r.weights[q] * std::pow(r.points[q][0], a) * std::pow(r.points[q][1], b) * std::pow(r.points[q][2], c);
    EXPECT_NEAR(sum, fact(a) * fact(b) * fact(c) / fact(a + b + c + 3), 1e-15);
  }
}

TEST_P(Kinds, BoxSurfaceIsClosedOutwardAndExact) {
  const Eigen::Vector3d size(2e-3, 1e-3, 1.5e-3);
  const Model m = box_model(GetParam(), size);
  ASSERT_EQ(m.grains.size(), 1u);
  double area = 0, volume = 0;
  for (const auto& t : m.triangles) {
    const Eigen::Vector3d n = (m.nodes[t[1]] - m.nodes[t[0]]).cross(m.nodes[t[2]] - m.nodes[t[0]]);
    area += 0.5 * n.norm();
    volume += m.nodes[t[0]].dot(n) / 6;  // divergence theorem: positive only if the surface faces outward
  }
  EXPECT_NEAR(area, 2 * (size[0] * size[1] + size[1] * size[2] + size[0] * size[2]), 1e-15);
  EXPECT_NEAR(volume, size.prod(), 1e-18);
  double element_sum = 0;
  for (std::size_t e = 0; e < m.element_count(); ++e) element_sum += element_volume(m, e);
  EXPECT_NEAR(element_sum, size.prod(), 1e-18);
  EXPECT_EQ(m.element_offset.size(), m.element_count() + 1);
  EXPECT_EQ(m.nodes_of(0), GetParam() == GrainKind::tet10 ? 10u : 4u);
}

TEST_P(Kinds, PatchTestLinearFieldGivesUniformStressAndBalancedForces) {
  const Model m = box_model(GetParam());
  const ElasticElements el(m);
  Eigen::Matrix3d A;
  A << 1.002, 0.001, -0.0005, 0.0007, 0.998, 0.0012, -0.0003, 0.0004, 1.0015;
  const Eigen::Vector3d b(1e-4, -2e-4, 3e-4);
  const auto x = mapped(m, A, b);
  for (std::size_t e = 0; e < m.element_count(); ++e)
    for (const Eigen::Matrix3d& F : el.deformation_gradient(x, e)) EXPECT_LT((F - A).norm(), 1e-12);
  std::vector<Eigen::Vector3d> f(m.nodes.size(), Eigen::Vector3d::Zero());
  const double energy = el.add_internal_forces(x, 0, m.element_count(), f);
  // Uniform stress: the energy is psi V, and every interior node is in equilibrium.
  const Eigen::Matrix3d S = svk_pk2(m.materials[0], A);
  const Lame L = lame_constants(m.materials[0]);
  const Eigen::Matrix3d E = 0.5 * (A.transpose() * A - Eigen::Matrix3d::Identity());
  const double V = 2e-3 * 1e-3 * 1.5e-3;
  EXPECT_NEAR(energy, V * (0.5 * L.lambda * E.trace() * E.trace() + L.mu * E.squaredNorm()), 1e-9 * energy);
  const Eigen::Vector3d centre(0.01, -0.02, 0.03);
  const Eigen::Vector3d half(1e-3, 0.5e-3, 0.75e-3);
  const double scale = S.norm() * 0.5e-3 * 0.5e-3;  // stress times an element face area
  Eigen::Vector3d total = Eigen::Vector3d::Zero(), face_x = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < m.nodes.size(); ++i) {
    const Eigen::Vector3d r = (m.nodes[i] - centre).cwiseAbs();
    const bool interior = (r.array() < half.array() - 1e-12).all();
    if (interior) {
      EXPECT_LT(f[i].norm(), 1e-9 * scale) << "interior node " << i;
    }
    if (m.nodes[i][0] - centre[0] > half[0] - 1e-12) face_x += f[i];
    total += f[i];
  }
  EXPECT_LT(total.norm(), 1e-9 * scale);
  // Nodal forces on the face x = +a equal minus the traction resultant P n A0 (first Piola-Kirchhoff).
  const Eigen::Vector3d traction = A * S * Eigen::Vector3d::UnitX() * (1e-3 * 1.5e-3);
  EXPECT_LT((face_x + traction).norm(), 1e-9 * traction.norm());
  // Volume-averaged Cauchy stress is the uniform one.
  const Eigen::Matrix3d sigma = A * S * A.transpose() / A.determinant();
  EXPECT_LT((el.average_cauchy_stress(x, 0, m.element_count()) - sigma).norm(), 1e-9 * sigma.norm());
}

TEST_P(Kinds, LargeRigidRotationGivesZeroStress) {
  const Model m = box_model(GetParam());
  const ElasticElements el(m);
  for (double angle : {0.3, 1.7, 3.0}) {
    const Eigen::Matrix3d R = Eigen::AngleAxisd(angle, Eigen::Vector3d(1, 2, -0.5).normalized()).toRotationMatrix();
    const auto x = mapped(m, R, Eigen::Vector3d(0.1, 0.2, -0.3));
    std::vector<Eigen::Vector3d> f(m.nodes.size(), Eigen::Vector3d::Zero());
    EXPECT_NEAR(el.add_internal_forces(x, 0, m.element_count(), f), 0.0, 1e-15);
    for (const auto& fi : f) EXPECT_LT(fi.norm(), 1e-3);  // E = 92 GPa: 1e-3 N is a strain of 1e-14 on 1 mm^2
    EXPECT_LT(el.average_cauchy_stress(x, 0, m.element_count()).norm(), 1e-2);
  }
  // A small-strain element would see a strain of 1 - cos(angle) here; this one must not.
}

TEST_P(Kinds, InternalForcesAreMinusTheStrainEnergyGradient) {
  // A non-uniform large deformation, so every element is strained differently; the forces (the
  // 4-node elements' own fast path) must be minus the central-difference gradient of the energy.
  const Model m = box_model(GetParam());
  const ElasticElements el(m);
  std::vector<Eigen::Vector3d> x = m.nodes;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const Eigen::Vector3d d = m.nodes[i] - Eigen::Vector3d(0.01, -0.02, 0.03);
    x[i] += Eigen::Vector3d(0.05 * d[1] * d[2] / 1e-3, 0.03 * d[0] * d[0] / 1e-3, -0.04 * d[0] * d[1] / 1e-3) +
            2e-6 * Eigen::Vector3d(std::sin(3.0 * i), std::cos(5.0 * i), std::sin(7.0 * i + 1));
  }
  std::vector<Eigen::Vector3d> f(m.nodes.size(), Eigen::Vector3d::Zero());
  const double energy = el.add_internal_forces(x, 0, m.element_count(), f);
  EXPECT_NEAR(energy, el.strain_energy(x, 0, m.element_count()), 1e-12 * energy);
  double largest = 0;
  for (const auto& fi : f) largest = std::max(largest, fi.norm());
  const double step = 1e-9;
  for (std::size_t i = 0; i < x.size(); i += 7)
    for (int k = 0; k < 3; ++k) {
      auto plus = x, minus = x;
      plus[i][k] += step;
      minus[i][k] -= step;
      const double gradient =
          (el.strain_energy(plus, 0, m.element_count()) - el.strain_energy(minus, 0, m.element_count())) / (2 * step);
      EXPECT_NEAR(f[i][k], -gradient, 1e-6 * largest) << "node " << i << " axis " << k;
    }
}

TEST(FdemMass, HrzTet10CornersPositiveAndTotalExact) {
  Model m;
  TetMesh one;
  one.nodes = {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1e-3, 0, 0), Eigen::Vector3d(0.2e-3, 1.1e-3, 0),
               Eigen::Vector3d(0.3e-3, 0.2e-3, 0.9e-3)};
  one.tets = {{0, 1, 2, 3}};
  add_grain(m, one, Eigen::Vector3d::Zero(), GrainKind::tet10, 0, 1);
  const auto mass = lumped_masses(m);
  const double total = m.materials[0].density * element_volume(m, 0);
  const std::uint32_t* n = m.element_nodes.data();
  for (int a = 0; a < 4; ++a) EXPECT_NEAR(mass[n[a]], total / 36, 1e-12 * total);
  for (int a = 4; a < 10; ++a) EXPECT_NEAR(mass[n[a]], 4 * total / 27, 1e-12 * total);
  // A curved element (one mid-edge node pushed out) still gets positive masses summing to its mass.
  m.nodes[n[4]] += Eigen::Vector3d(0, -0.15e-3, 0);
  const auto curved = lumped_masses(m);
  double sum = 0;
  for (double v : curved) {
    EXPECT_GT(v, 0);
    sum += v;
  }
  EXPECT_NEAR(sum, m.materials[0].density * element_volume(m, 0), 1e-12 * total);
}

TEST_P(Kinds, LumpedMassTotalAndBodyProperties) {
  const Eigen::Vector3d size(2e-3, 1e-3, 1.5e-3);
  const Model m = box_model(GetParam(), size);
  const auto mass = lumped_masses(m);
  const double expected = m.materials[0].density * size.prod();
  EXPECT_NEAR(std::accumulate(mass.begin(), mass.end(), 0.0), expected, 1e-12 * expected);
  for (double v : mass) EXPECT_GT(v, 0);
  const BodyProperties b = body_properties(m, 0);
  EXPECT_NEAR(b.mass, expected, 1e-12 * expected);
  EXPECT_LT((b.centroid - Eigen::Vector3d(0.01, -0.02, 0.03)).norm(), 1e-15);
  const Eigen::Vector3d s2 = size.cwiseProduct(size);
  const Eigen::Vector3d I = expected / 12 * Eigen::Vector3d(s2[1] + s2[2], s2[0] + s2[2], s2[0] + s2[1]);
  EXPECT_LT((b.inertia - Eigen::Matrix3d(I.asDiagonal())).norm(), 1e-9 * I.norm());
}

TEST(FdemElements, FourNodeBodyPropertiesInClosedFormMatchTheExactRule) {
  // A sheared, stretched box: tet4 takes the closed form, the same straight mesh as tet10 the
  // 125-point rule (exact to degree 7), so the two must agree to round-off.
  TetMesh mesh = box_mesh(Eigen::Vector3d(2e-3, 1e-3, 1.5e-3), 0.5e-3);
  Eigen::Matrix3d A;
  A << 1.0, 0.3, -0.2, 0.1, 0.8, 0.4, -0.25, 0.05, 1.3;
  for (Eigen::Vector3d& X : mesh.nodes) X = A * X;
  Model four, ten;
  add_grain(four, mesh, Eigen::Vector3d(0.01, -0.02, 0.03), GrainKind::tet4, 0, 1);
  add_grain(ten, mesh, Eigen::Vector3d(0.01, -0.02, 0.03), GrainKind::tet10, 0, 1);
  const BodyProperties a = body_properties(four, 0), b = body_properties(ten, 0);
  EXPECT_NEAR(a.volume, b.volume, 1e-12 * b.volume);
  EXPECT_LT((a.centroid - b.centroid).norm(), 1e-15);
  EXPECT_LT((a.inertia - b.inertia).norm(), 1e-10 * b.inertia.norm());
}

TEST(FdemElements, InvertedElementIsRefusedWithItsName) {
  Model m = box_model(GrainKind::tet4);
  std::swap(m.element_nodes[1], m.element_nodes[2]);
  try {
    ElasticElements el(m);
    FAIL() << "an inverted element was accepted";
  } catch (const DataError& e) {
    EXPECT_NE(e.message().find("element 0 (grain label 7) is inverted"), std::string::npos) << e.message();
  }
}

TEST(FdemElements, TenNodeGrainsSplitIntoEightFourNodeOnesOnTheirNodes) {
  // A sheared 10-node box beside a 4-node one: the split keeps every node, the surface triangles
  // (the 10-node faces' quarters are the split elements' boundary), the volume and the mass, and
  // every part lies on its parent's nodes with a positive orientation.
  TetMesh mesh = box_mesh(Eigen::Vector3d(2e-3, 1e-3, 1.5e-3), 0.5e-3);
  Eigen::Matrix3d A;
  A << 1.0, 0.3, -0.2, 0.1, 0.8, 0.4, -0.25, 0.05, 1.3;
  for (Eigen::Vector3d& X : mesh.nodes) X = A * X;
  Model m;
  add_grain(m, mesh, Eigen::Vector3d::Zero(), GrainKind::tet10, 0, 1);
  add_grain(m, box_mesh(Eigen::Vector3d(1e-3, 1e-3, 1e-3), 0.5e-3), Eigen::Vector3d(5e-3, 0, 0), GrainKind::rigid, 0, 2);
  const Model before = m;
  const auto mass_before = lumped_masses(before);
  split_into_linear_grains(m);
  EXPECT_EQ(m.nodes, before.nodes);
  EXPECT_EQ(m.triangles, before.triangles);
  const std::size_t tens = before.grains[0].element_end - before.grains[0].element_begin;
  const std::size_t fours = before.grains[1].element_end - before.grains[1].element_begin;
  ASSERT_EQ(m.element_count(), 8 * tens + fours);
  for (std::size_t g = 0; g < 2; ++g) {
    const Grain& grain = m.grains[g];
    EXPECT_EQ(grain.kind, GrainKind::tet4);
    double volume = 0, volume_before = 0;
    std::vector<std::uint32_t> elements;
    for (std::uint32_t e = grain.element_begin; e < grain.element_end; ++e) {
      ASSERT_EQ(m.nodes_of(e), 4u);
      EXPECT_EQ(m.element_grain[e], g);
      EXPECT_GT(element_volume(m, e), 0) << "element " << e;
      volume += element_volume(m, e);
      elements.insert(elements.end(), m.element_nodes.begin() + m.element_offset[e], m.element_nodes.begin() + m.element_offset[e + 1]);
    }
    for (std::uint32_t e = before.grains[g].element_begin; e < before.grains[g].element_end; ++e) volume_before += element_volume(before, e);
    EXPECT_NEAR(volume, volume_before, 1e-12 * volume_before);
    // The split elements' own boundary is the grain's surface, triangle for triangle.
    const auto boundary = boundary_triangles(4, elements);
    const auto sorted = [](std::array<std::uint32_t, 3> t) { return std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end()), t; };
    std::set<std::array<std::uint32_t, 3>> a, b;
    for (const auto& t : boundary) a.insert(sorted(t));
    for (std::uint32_t t = grain.triangle_begin; t < grain.triangle_end; ++t) b.insert(sorted(m.triangles[t]));
    EXPECT_EQ(a, b) << "grain " << g;
  }
  // Each 10-node element's eight parts use only its own nodes.
  for (std::size_t e = 0; e < tens; ++e) {
    const std::set<std::uint32_t> parent(before.element_nodes.begin() + before.element_offset[e],
                                         before.element_nodes.begin() + before.element_offset[e + 1]);
    for (std::size_t k = 8 * e; k < 8 * e + 8; ++k)
      for (std::uint32_t i = m.element_offset[k]; i < m.element_offset[k + 1]; ++i) EXPECT_TRUE(parent.count(m.element_nodes[i]));
  }
  const auto mass = lumped_masses(m);
  const double total = std::accumulate(mass_before.begin(), mass_before.end(), 0.0);
  EXPECT_NEAR(std::accumulate(mass.begin(), mass.end(), 0.0), total, 1e-12 * total);
  for (double v : mass) EXPECT_GT(v, 0);
}

TEST(FdemElements, AGrainWhoseSplitWouldInvertACurvedElementKeepsItsTenNodes) {
  // Grain 0's mid-edge node of one edge pushed past the edge's end: its corner parts turn inside
  // out, so it keeps its 10-node elements; grain 1 beside it is split.
  Model m = box_model(GrainKind::tet10, {0.5e-3, 0.5e-3, 0.5e-3}, 0.5e-3);
  add_grain(m, box_mesh({0.5e-3, 0.5e-3, 0.5e-3}, 0.5e-3), Eigen::Vector3d(2e-3, 0, 0), GrainKind::tet10, 0, 8);
  const std::uint32_t* n = m.element_nodes.data() + m.element_offset[2];
  m.nodes[n[4]] = m.nodes[n[1]] + 0.5 * (m.nodes[n[1]] - m.nodes[n[0]]);
  const Model before = m;
  EXPECT_EQ(split_into_linear_grains(m), std::vector<std::uint32_t>{0});
  EXPECT_EQ(m.grains[0].kind, GrainKind::tet10);
  EXPECT_EQ(m.grains[1].kind, GrainKind::tet4);
  const std::uint32_t tens = before.grains[0].element_end;
  ASSERT_EQ(m.grains[0].element_end, tens);
  EXPECT_TRUE(std::equal(m.element_nodes.begin(), m.element_nodes.begin() + m.element_offset[tens], before.element_nodes.begin()));
  EXPECT_EQ(m.grains[1].element_begin, tens);
  EXPECT_EQ(m.grains[1].element_end - m.grains[1].element_begin, 8 * (before.grains[1].element_end - before.grains[1].element_begin));
  EXPECT_EQ(m.element_offset.back(), m.element_nodes.size());
}

INSTANTIATE_TEST_SUITE_P(Fdem, Kinds, ::testing::Values(GrainKind::tet4, GrainKind::tet10),
                         [](const auto& info) { return info.param == GrainKind::tet4 ? "tet4" : "tet10"; });
