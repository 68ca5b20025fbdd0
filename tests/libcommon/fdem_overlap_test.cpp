// fdem/ initial overlaps: grains that touch or overlap within the tolerance pass; deeper overlaps of
// two grains or of a grain and a platen are refused naming the grains, the depth, the tolerance and
// the scene key that relaxes them; relaxation moves the grains apart (rigid translations) until they
// touch within a hundredth of the tolerance, and refuses when they have no room to part.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/contact.hpp"
#include "graintwin/fdem/element.hpp"
#include "graintwin/fdem/initial_overlap.hpp"
#include "graintwin/fdem/primitives.hpp"
#include "graintwin/fdem/solver.hpp"

using namespace graintwin;
using namespace graintwin::fdem;

namespace {

constexpr double kMm = 1e-3;

/// Two 1 mm cubes (0.25 mm cells), the second `offset` from the first along x; a bottom platen
/// `below` under their bottom faces (negative: the cubes reach behind it).
Model two_cubes(double offset, double below = 0.1 * kMm) {
  Model m;
  const TetMesh cube = box_mesh(Eigen::Vector3d::Constant(kMm), 0.25 * kMm);
  add_grain(m, cube, Eigen::Vector3d::Zero(), GrainKind::rigid, 0, 1);
  add_grain(m, cube, Eigen::Vector3d(offset, 0, 0), GrainKind::tet4, 0, 2);
  m.platens = {Platen{"bottom", Eigen::Vector3d(0, 0, -0.5 * kMm - below), Eigen::Vector3d::UnitZ(), 0}};
  return m;
}

/// settle_initial_overlaps on a solver of `m` (which relaxation moves).
OverlapSettlement settle(Model& m, const OverlapOptions& options) {
  Solver solver(m, SolverOptions{});
  return settle_initial_overlaps(solver, m, options, "scene.toml");
}

std::string refusal(Model m, const OverlapOptions& options) {
  try {
    settle(m, options);
  } catch (const UsageError& e) {
    return e.message();
  }
  return "accepted";
}

/// The deepest overlap of the model's grains and platens as they stand.
double deepest(const Model& m) {
  ContactModel contact(m, lumped_masses(m), ContactOptions{});
  std::vector<PlatenState> platens;
  for (const Platen& p : m.platens) platens.push_back({p.point, p.normal, Eigen::Vector3d::Zero(), 0});
  double d = 0;
  for (const Overlap& o : contact.overlaps(m.nodes, platens)) d = std::max(d, o.depth);
  return d;
}

}  // namespace

TEST(FdemOverlap, NothingIsCheckedWithoutContact) {
  Model m = two_cubes(0.5 * kMm, -0.3 * kMm);
  SolverOptions no_contact;
  no_contact.contact.enabled = false;
  Solver solver(m, no_contact);
  EXPECT_EQ(settle_initial_overlaps(solver, m, {}, "scene.toml").beyond, 0u);
}

TEST(FdemOverlap, TouchingAndSlightlyOverlappingGrainsPass) {
  // Touching faces, a platen touching, and an overlap of 1 % of the diameter (CT-derived grains
  // overlap like this, up to 7 % at the platens on sand_small): within the default tolerance of
  // 10 % (124 um here).
  for (const double offset : {1.0 * kMm, 0.99 * kMm, 1.5 * kMm}) {
    Model m = two_cubes(offset, 0.0);
    const OverlapSettlement s = settle(m, {});
    EXPECT_EQ(s.beyond, 0u) << offset;
    EXPECT_NEAR(s.deepest, std::max(0.0, kMm - offset), 1e-12) << offset;
    EXPECT_EQ(s.passes, 0u);
  }
}

TEST(FdemOverlap, DeepOverlapsAreRefusedNamingGrainsDepthToleranceAndTheKeyThatRelaxes) {
  // Half a cube through the other (its corners lie on the other's faces: the triangle centroids
  // find it), and a cube 0.3 mm behind a platen.
  std::string message = refusal(two_cubes(0.5 * kMm), {});
  EXPECT_NE(message.find("scene.toml: grains label 1 and label 2 overlap by"), std::string::npos) << message;
  EXPECT_NE(message.find("beyond the tolerance of 0.124 mm ([run] overlap_tolerance = 0.1 x the smaller grain's "
                         "equivalent diameter, 1.24 mm)"),
            std::string::npos)
      << message;
  EXPECT_NE(message.find("set [run] relax_overlaps = true"), std::string::npos) << message;
  message = refusal(two_cubes(3 * kMm, -0.3 * kMm), {});
  EXPECT_NE(message.find("grain label 1 reaches 0.3 mm behind platen 'bottom' at the start"), std::string::npos) << message;
  EXPECT_NE(message.find("(2 overlaps in all are beyond theirs)"), std::string::npos) << message;
  // A tolerance of 0.3 accepts both cubes' 0.3 mm (the grain's 1.24 mm diameter x 0.3 = 0.37 mm).
  EXPECT_EQ(refusal(two_cubes(3 * kMm, -0.3 * kMm), {0.3, false}), "accepted");
}

TEST(FdemOverlap, RelaxationPartsTheGrainsAndLiftsThemOutOfThePlaten) {
  Model m = two_cubes(0.5 * kMm, -0.3 * kMm);
  const Eigen::Vector3d before[2] = {body_properties(m, 0).centroid, body_properties(m, 1).centroid};
  const OverlapSettlement s = settle(m, {0.05, true});
  EXPECT_EQ(s.beyond, 3u);  // the pair and both cubes in the platen
  EXPECT_GT(s.passes, 0u);
  EXPECT_EQ(s.moved_grains, 2u);
  // At most a hundredth of the tolerance is left, and the grains only moved: apart along x until
  // their faces touch, up out of the platen onto it (within a hundredth of the tolerance each way).
  const double tolerance = 0.05 * std::cbrt(6 / std::numbers::pi) * kMm, slack = 0.011 * tolerance;
  EXPECT_LE(s.deepest_after, 0.01 * tolerance);
  EXPECT_LE(deepest(m), 0.01 * tolerance);
  const Eigen::Vector3d after[2] = {body_properties(m, 0).centroid, body_properties(m, 1).centroid};
  EXPECT_NEAR(after[1].x() - after[0].x(), kMm, slack);
  for (int g = 0; g < 2; ++g) EXPECT_NEAR(after[g].z() - before[g].z(), 0.3 * kMm, slack) << g;
  for (int g = 0; g < 2; ++g) EXPECT_NEAR(after[g].y(), before[g].y(), 1e-15) << g;
  EXPECT_NEAR(s.largest_move, (after[0] - before[0]).norm(), 1e-12);
  // The relaxed model passes the check as it is.
  EXPECT_EQ(settle(m, {}).beyond, 0u);
}

TEST(FdemOverlap, RelaxationRefusesGrainsWithNoRoomToPart) {
  // A 1 mm cube between platens 0.8 mm apart.
  Model m = two_cubes(3 * kMm, -0.1 * kMm);
  m.platens.push_back(Platen{"top", Eigen::Vector3d(0, 0, 0.4 * kMm), -Eigen::Vector3d::UnitZ(), 0});
  const std::string message = refusal(m, {0.05, true});
  EXPECT_NE(message.find("relaxing the initial overlaps ([run] relax_overlaps) left grain label"), std::string::npos)
      << message;
  EXPECT_NE(message.find("they have no room to part"), std::string::npos) << message;
}
