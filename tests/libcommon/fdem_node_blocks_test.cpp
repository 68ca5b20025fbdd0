// fdem/node_blocks: on a grain's stiffness matrix (a 10-node box, and its 4-node split) plus mass, the
// block product equals Eigen's sparse product and the block LDL^T solve equals Eigen's SimplicialLDLT,
// both to round-off; the solve may overwrite its right-hand side; an indefinite matrix reports it is
// not positive definite, nor one holding a NaN; triplets above the diagonal or beyond the matrix are refused.
#include <gtest/gtest.h>

#include <Eigen/SparseCholesky>
#include <random>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/element.hpp"
#include "graintwin/fdem/node_blocks.hpp"
#include "graintwin/fdem/primitives.hpp"

using namespace graintwin;
using namespace graintwin::fdem;
using Triplet = Eigen::Triplet<double>;

namespace {

/// The lower triangle of h^2 K + M for grain 0 of `model` (a sheared box, so no entry is special).
std::vector<Triplet> system_of(const Model& model, double h2) {
  std::vector<Triplet> lower = grain_stiffness_lower(model, 0, lame_constants(model.materials[0]));
  for (Triplet& t : lower) t = Triplet(t.row(), t.col(), h2 * t.value());
  const std::vector<double> mass = lumped_masses(model);
  for (std::size_t i = 0; i < model.nodes.size(); ++i)
    for (int k = 0; k < 3; ++k) lower.emplace_back(static_cast<int>(3 * i + k), static_cast<int>(3 * i + k), mass[i]);
  return lower;
}

Model sheared_box(GrainKind kind) {
  TetMesh mesh = box_mesh(Eigen::Vector3d(2e-3, 1e-3, 1.5e-3), 0.4e-3);
  Eigen::Matrix3d A;
  A << 1.0, 0.3, -0.2, 0.1, 0.8, 0.4, -0.25, 0.05, 1.3;
  for (Eigen::Vector3d& X : mesh.nodes) X = A * X;
  Model m;
  add_grain(m, mesh, Eigen::Vector3d::Zero(), kind, 0, 1);
  return m;
}

Eigen::VectorXd random_vector(Eigen::Index n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::VectorXd v(n);
  for (Eigen::Index i = 0; i < n; ++i) v[i] = u(rng);
  return v;
}

std::span<double> all(Eigen::VectorXd& v) { return {v.data(), static_cast<std::size_t>(v.size())}; }

class Meshes : public ::testing::TestWithParam<bool> {};  // split into 4-node elements or not

}  // namespace

TEST_P(Meshes, BlockProductAndSolveEqualEigensOnAGrainSystem) {
  Model model = sheared_box(GrainKind::tet10);
  if (GetParam()) split_into_linear_grains(model);
  const std::size_t nodes = model.nodes.size();
  const auto n = static_cast<Eigen::Index>(3 * nodes);
  const std::vector<Triplet> lower = system_of(model, 1e-14);  // h = 1e-7 s: stiffness and mass both count
  Eigen::SparseMatrix<double> L(n, n);
  L.setFromTriplets(lower.begin(), lower.end());
  const Eigen::SparseMatrix<double> A = L.selfadjointView<Eigen::Lower>();

  Eigen::VectorXd x = random_vector(n, 1), y(n);
  SymmetricNodeBlocks blocks(nodes, lower);
  blocks.multiply(all(x), all(y));
  const Eigen::VectorXd expected_product = A * x;
  EXPECT_LT((y - expected_product).norm(), 1e-13 * expected_product.norm());

  const NodeBlockLdlt factor(nodes, lower);
  ASSERT_TRUE(factor.positive_definite());
  const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> eigen(L);
  Eigen::VectorXd b = random_vector(n, 2), solved(n);
  factor.solve(all(b), all(solved));
  const Eigen::VectorXd expected = eigen.solve(b);
  EXPECT_LT((solved - expected).norm(), 1e-11 * expected.norm());
  EXPECT_LT((A * solved - b).norm(), 1e-11 * b.norm());
  factor.solve(all(b), all(b));  // in place
  EXPECT_EQ(b, solved);
}

INSTANTIATE_TEST_SUITE_P(NodeBlocks, Meshes, ::testing::Bool(),
                         [](const auto& info) { return info.param ? "split_tet4" : "tet10"; });

TEST(NodeBlocks, AnIndefiniteMatrixIsNotPositiveDefinite) {
  // K alone is singular (rigid motions); K less a little mass is indefinite.
  const Model model = sheared_box(GrainKind::tet4);
  std::vector<Triplet> lower = grain_stiffness_lower(model, 0, lame_constants(model.materials[0]));
  for (std::size_t i = 0; i < 3 * model.nodes.size(); ++i) lower.emplace_back(static_cast<int>(i), static_cast<int>(i), -1.0);
  EXPECT_FALSE(NodeBlockLdlt(model.nodes.size(), lower).positive_definite());
  // A NaN entry (a node at NaN upstream) is not a factorisation either.
  std::vector<Triplet> nan_entry = system_of(model, 1e-14);
  nan_entry.emplace_back(0, 0, std::numeric_limits<double>::quiet_NaN());
  EXPECT_FALSE(NodeBlockLdlt(model.nodes.size(), nan_entry).positive_definite());
}

TEST(NodeBlocks, TripletsOutsideTheLowerTriangleAreRefused) {
  const std::vector<Triplet> upper{{0, 1, 1.0}}, beyond{{6, 0, 1.0}};
  EXPECT_THROW(SymmetricNodeBlocks(2, upper), UsageError);
  EXPECT_THROW(NodeBlockLdlt(2, beyond), UsageError);
}
