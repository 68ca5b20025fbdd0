// fdem/ contact: closest points, the node law (penalty, clamped dashpot, tangential spring and
// slip), the broad phase against an all-pairs check, and ContactModel on tet-meshed boxes: exact
// normal force of a pressed face, equal and opposite forces, friction against a platen, restart
// from a saved history bit for bit, same forces for any thread count.
#include <gtest/gtest.h>
#include <omp.h>

#include <Eigen/Geometry>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <random>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/contact.hpp"
#include "graintwin/fdem/contact_broadphase.hpp"
#include "graintwin/fdem/contact_bvh.hpp"
#include "graintwin/fdem/contact_geometry.hpp"
#include "graintwin/fdem/contact_law.hpp"
#include "graintwin/fdem/primitives.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/mesh/gmsh_adapter.hpp"
#include "graintwin/mesh/tet_mesh.hpp"

using namespace graintwin;
using namespace graintwin::fdem;

namespace {

constexpr double kMm = 1e-3;

std::vector<Eigen::Vector3d> zeros(std::size_t n) { return std::vector<Eigen::Vector3d>(n, Eigen::Vector3d::Zero()); }

/// What per-node forces f on the grains of m add up to about the centres of `poses`.
std::vector<RigidLoad> loads_of(const Model& m, const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Vector3d>& f,
                                const std::vector<RigidPose>& poses) {
  std::vector<RigidLoad> loads(m.grains.size());
  for (std::size_t g = 0; g < m.grains.size(); ++g)
    for (std::uint32_t n = m.grains[g].node_begin; n < m.grains[g].node_end; ++n) loads[g].add(x[n] - poses[g].centre, f[n]);
  return loads;
}

/// Whether two sets of rigid loads are the same, bit for bit.
::testing::AssertionResult same_loads(std::span<const RigidLoad> a, std::span<const RigidLoad> b) {
  if (a.size() != b.size()) return ::testing::AssertionFailure() << a.size() << " against " << b.size() << " grains";
  for (std::size_t g = 0; g < a.size(); ++g)
    if (a[g].force != b[g].force || a[g].moment != b[g].moment)
      return ::testing::AssertionFailure() << "grain " << g << ": force " << a[g].force.transpose() << " against "
                                           << b[g].force.transpose();
  return ::testing::AssertionSuccess();
}

/// Whether two sets of rigid loads agree within `tolerance` times the largest force and moment.
::testing::AssertionResult near_loads(std::span<const RigidLoad> a, std::span<const RigidLoad> b, double tolerance) {
  double force = 0, moment = 0;
  for (const RigidLoad& l : b) force = std::max(force, l.force.norm()), moment = std::max(moment, l.moment.norm());
  for (std::size_t g = 0; g < a.size(); ++g)
    if ((a[g].force - b[g].force).norm() > tolerance * force || (a[g].moment - b[g].moment).norm() > tolerance * moment)
      return ::testing::AssertionFailure() << "grain " << g << ": force " << a[g].force.transpose() << " against "
                                           << b[g].force.transpose();
  return ::testing::AssertionSuccess();
}

/// A 2 x 2 x 1 mm slab (0.25 mm cells, top face at z = 0.5 mm) and, on it, a 1 mm cube pressed in
/// by `overlap`. The cube's footprint [-0.625, 0.375]^2 mm holds exactly 4 x 4 of the slab's top
/// nodes, each 0.125 mm from the cube's sides, so both directions see exactly the footprint area.
Model pressed_cubes(double overlap, double damping_ratio = 0.0) {
  Model m;
  m.materials[0].damping_ratio = damping_ratio;
  add_grain(m, box_mesh({2 * kMm, 2 * kMm, 1 * kMm}, 0.25 * kMm), Eigen::Vector3d::Zero(), GrainKind::tet4, 0, 1);
  add_grain(m, box_mesh({1 * kMm, 1 * kMm, 1 * kMm}, 0.25 * kMm),
            Eigen::Vector3d(-0.125 * kMm, -0.125 * kMm, 1 * kMm - overlap), GrainKind::tet4, 0, 2);
  return m;
}

std::vector<double> unit_masses(const Model& m) { return std::vector<double>(m.nodes.size(), 1e-6); }

// `count` rigid faceted spheres of `radius` at the origin (facets of about a quarter of the radius).
Model faceted_spheres(double radius, std::uint32_t count) {
  mesh::TetOptions o;
  o.size = 0.25 * radius;
  Model m;
  for (std::uint32_t g = 0; g < count; ++g)
    mesh::append_grain(m, mesh::mesh_ellipsoid(Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(radius),
                                               Eigen::Quaterniond::Identity(), o), g + 1, GrainKind::rigid);
  return m;
}

TEST(ClosestPoint, FaceEdgeAndCornerRegions) {
  const Eigen::Vector3d a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  TrianglePoint r = closest_point_on_triangle({0.25, 0.25, -2}, a, b, c);
  EXPECT_EQ(r.feature, TriangleFeature::face);
  EXPECT_NEAR((r.point - Eigen::Vector3d(0.25, 0.25, 0)).norm(), 0, 1e-15);
  EXPECT_NEAR((r.weights - Eigen::Vector3d(0.5, 0.25, 0.25)).norm(), 0, 1e-15);
  r = closest_point_on_triangle({0.5, -1, 1}, a, b, c);
  EXPECT_EQ(r.feature, TriangleFeature::edge_ab);
  EXPECT_NEAR((r.point - Eigen::Vector3d(0.5, 0, 0)).norm(), 0, 1e-15);
  r = closest_point_on_triangle({1, 1, 0}, a, b, c);
  EXPECT_EQ(r.feature, TriangleFeature::edge_bc);
  EXPECT_NEAR((r.point - Eigen::Vector3d(0.5, 0.5, 0)).norm(), 0, 1e-15);
  r = closest_point_on_triangle({-1, 0.5, 0}, a, b, c);
  EXPECT_EQ(r.feature, TriangleFeature::edge_ca);
  r = closest_point_on_triangle({-1, -1, 3}, a, b, c);
  EXPECT_EQ(r.feature, TriangleFeature::vertex_a);
  r = closest_point_on_triangle({3, -1, 0}, a, b, c);
  EXPECT_EQ(r.feature, TriangleFeature::vertex_b);
  EXPECT_NEAR((r.weights - Eigen::Vector3d(0, 1, 0)).norm(), 0, 0);
  r = closest_point_on_triangle({-0.5, 3, 0}, a, b, c);
  EXPECT_EQ(r.feature, TriangleFeature::vertex_c);
}

TEST(ContactLaw, PenaltyForceIsStiffnessTimesOverlap) {
  const ContactLaw law = contact_law(1e12, 1e12, 2e-8, 1e-6, 0.0, 0.5);
  EXPECT_EQ(law.normal_stiffness, 2e4);
  const Eigen::Vector3d n = Eigen::Vector3d(1, 2, 2) / 3.0;
  const NodeContactForce r = node_contact_force(law, n, 3e-6, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 1e-8);
  EXPECT_DOUBLE_EQ(r.normal_force, 2e4 * 3e-6);
  EXPECT_NEAR((r.force - 2e4 * 3e-6 * n).norm(), 0, 1e-15);
  EXPECT_DOUBLE_EQ(r.elastic_energy, 0.5 * 2e4 * 3e-6 * 3e-6);
  EXPECT_EQ(r.dissipated, 0);
}

TEST(ContactLaw, DashpotNeverPulls) {
  const ContactLaw law = contact_law(1e12, 1e12, 1e-8, 1e-6, 0.5, 0.5);
  const Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  // Closing: the dashpot adds to the spring.
  NodeContactForce r = node_contact_force(law, n, 1e-6, -1.0 * n, Eigen::Vector3d::Zero(), 1e-8);
  EXPECT_GT(r.normal_force, law.normal_stiffness * 1e-6);
  // Opening fast: spring minus dashpot would be negative; the force is clamped at zero.
  const double fast = 10 * law.normal_stiffness * 1e-6 / law.normal_damping;
  r = node_contact_force(law, n, 1e-6, fast * n, Eigen::Vector3d::Zero(), 1e-8);
  EXPECT_EQ(r.normal_force, 0);
  EXPECT_EQ(r.force.norm(), 0);
  EXPECT_GT(r.dissipated, 0);
  // Opening slowly: less than the spring, still pushing.
  r = node_contact_force(law, n, 1e-6, 0.05 * fast * n, Eigen::Vector3d::Zero(), 1e-8);
  EXPECT_GT(r.normal_force, 0);
  EXPECT_LT(r.normal_force, law.normal_stiffness * 1e-6);
}

TEST(ContactLaw, TangentialSpringGrowsThenSlipsAtCoulombLimit) {
  const ContactLaw law = contact_law(1e12, 0.5e12, 1e-8, 1e-6, 0.0, 0.3);
  const Eigen::Vector3d n = Eigen::Vector3d::UnitZ(), slide(2.0, 0, 0);
  const double overlap = 1e-6, dt = 1e-8;
  const double cap = 0.3 * law.normal_stiffness * overlap;
  Eigen::Vector3d spring = Eigen::Vector3d::Zero();
  int slipped_at = -1;
  for (int step = 1; step <= 40; ++step) {
    const NodeContactForce r = node_contact_force(law, n, overlap, slide, spring, dt);
    const double elastic = law.tangential_stiffness * slide.x() * dt * step;
    if (elastic <= cap) {
      EXPECT_FALSE(r.slipping) << step;
      EXPECT_NEAR(r.force.x(), -elastic, 1e-12 * cap) << step;
      EXPECT_EQ(r.dissipated, 0);
    } else {
      if (slipped_at < 0) slipped_at = step;
      EXPECT_TRUE(r.slipping) << step;
      EXPECT_NEAR(r.force.x(), -cap, 1e-12 * cap) << step;
      EXPECT_GT(r.dissipated, 0);
    }
    EXPECT_NEAR(r.force.z(), law.normal_stiffness * overlap, 1e-12 * cap);
    spring = r.spring;
  }
  EXPECT_GT(slipped_at, 1);
  EXPECT_LT(slipped_at, 40);
}

TEST(ContactLaw, SpringIsRotatedIntoTheNewTangentPlane) {
  const ContactLaw law = contact_law(1e12, 1e12, 1e-8, 1e-6, 0.0, 1.0);
  const Eigen::Vector3d tilted = Eigen::Vector3d(0.6, 0, 0.8);
  const NodeContactForce r =
      node_contact_force(law, tilted, 1e-6, Eigen::Vector3d::Zero(), Eigen::Vector3d(1e-3, 0, 0), 1e-8);
  EXPECT_NEAR(r.spring.dot(tilted), 0, 1e-18);
  EXPECT_NEAR(r.spring.norm(), 1e-3, 1e-18);
}

TEST(BroadPhase, FindsExactlyTheOverlappingPairs) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> pos(0, 10), size(0.1, 1.5);
  std::vector<Aabb> boxes;
  for (int i = 0; i < 300; ++i) {
    Aabb b;
    const Eigen::Vector3d lo(pos(rng), pos(rng), pos(rng));
    b.grow(lo);
    b.grow(lo + Eigen::Vector3d(size(rng), size(rng), size(rng)));
    boxes.push_back(b);
  }
  boxes.push_back({});  // empty: in no pair
  Aabb far;             // far away and large: coarsens nothing it should not
  far.grow(Eigen::Vector3d(1e4, 1e4, 1e4));
  far.grow(Eigen::Vector3d(1e4 + 3, 1e4 + 3, 1e4 + 3));
  boxes.push_back(far);
  Aabb touching = boxes[0];  // touching along a face counts
  touching.lo.x() = boxes[0].hi.x();
  touching.hi.x() = boxes[0].hi.x() + 0.5;
  boxes.push_back(touching);
  std::vector<BoxPair> expected;
  for (std::uint32_t i = 0; i < boxes.size(); ++i)
    for (std::uint32_t j = i + 1; j < boxes.size(); ++j)
      if ((boxes[i].lo.array() <= boxes[i].hi.array()).all() && (boxes[j].lo.array() <= boxes[j].hi.array()).all() &&
          boxes[i].overlaps(boxes[j]))
        expected.emplace_back(i, j);
  const std::vector<BoxPair> found = overlapping_box_pairs(boxes);
  EXPECT_GT(expected.size(), 100u);
  EXPECT_EQ(found, expected);
}

TEST(SurfaceTrees, NearestTriangleMatchesBruteForceAfterRefit) {
  Model m;
  add_grain(m, box_mesh({1 * kMm, 0.7 * kMm, 0.5 * kMm}, 0.1 * kMm), Eigen::Vector3d::Zero(), GrainKind::tet4, 0, 1);
  SurfaceTrees trees(m);
  // Refit to a rotated and sheared configuration: the tree must follow without a rebuild.
  Eigen::Matrix3d A = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  A(0, 1) += 0.2;
  std::vector<Eigen::Vector3d> x;
  for (const auto& p : m.nodes) x.push_back(A * p + Eigen::Vector3d(1e-3, 0, 0));
  trees.refit(0, x);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.8 * kMm, 0.8 * kMm);
  int found = 0;
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector3d p = Eigen::Vector3d(1e-3 + u(rng), u(rng), u(rng));
    double best = std::numeric_limits<double>::infinity();
    for (const auto& t : m.triangles)
      best = std::min(best, (closest_point_on_triangle(p, x[t[0]], x[t[1]], x[t[2]]).point - p).squaredNorm());
    SurfaceTrees::Nearest near;
    const double radius = 0.2 * kMm;
    const bool hit = trees.nearest(0, p, radius, x, near);
    EXPECT_EQ(hit, best < radius * radius) << i;
    if (hit) {
      ++found;
      EXPECT_EQ(near.distance2, best) << i;
      EXPECT_LT(near.tested, m.triangles.size() / 4) << i;
    }
  }
  EXPECT_GT(found, 100);
}

TEST(SurfaceTrees, PlacedByARigidMotionTheTreeStillFindsTheNearestTriangle) {
  // A rigid grain's bounds are placed by its motion instead of refitted: they must contain the
  // moved triangles and equal the refit at no rotation; it is then searched in its body frame, and
  // must find what the refitted tree finds in the world (to round-off: ties may go another way).
  Model m;
  add_grain(m, box_mesh({1 * kMm, 0.7 * kMm, 0.5 * kMm}, 0.1 * kMm), Eigen::Vector3d::Zero(), GrainKind::rigid, 0, 1);
  SurfaceTrees placed(m), refitted(m);
  const Eigen::Vector3d t(1e-3, -2e-4, 3e-4);
  std::vector<Eigen::Vector3d> x;
  for (const auto& p : m.nodes) x.push_back(p + t);
  placed.place(0, Eigen::Matrix3d::Identity(), t);
  refitted.refit(0, x);
  EXPECT_TRUE(placed.bounds(0).lo.isApprox(refitted.bounds(0).lo, 1e-12));
  EXPECT_TRUE(placed.bounds(0).hi.isApprox(refitted.bounds(0).hi, 1e-12));
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  x.clear();
  for (const auto& p : m.nodes) x.push_back(R * p + t);
  placed.place(0, R, t);
  refitted.refit(0, x);
  EXPECT_TRUE((placed.bounds(0).lo.array() <= refitted.bounds(0).lo.array() + 1e-15).all());
  EXPECT_TRUE((placed.bounds(0).hi.array() >= refitted.bounds(0).hi.array() - 1e-15).all());
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> u(-0.8 * kMm, 0.8 * kMm);
  int found = 0;
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector3d p = t + Eigen::Vector3d(u(rng), u(rng), u(rng));
    SurfaceTrees::Nearest a, b;
    const double radius = 0.2 * kMm;
    const bool hit = placed.nearest_in_body(0, R.transpose() * (p - t), radius, a);
    ASSERT_EQ(hit, refitted.nearest(0, p, radius, x, b)) << i;
    if (hit) {
      ++found;
      EXPECT_NEAR(a.distance2, b.distance2, 1e-12 * b.distance2 + 1e-24) << i;
      EXPECT_LT((R * a.closest.point + t - b.closest.point).norm(), 1e-12 * kMm) << i;
    }
  }
  EXPECT_GT(found, 100);
}

TEST(SurfaceTrees, TrianglesWithinTwoMarginsHoldTheNearestOneMarginAway) {
  // The search memo's claim (fdem/contact.cpp SearchMemo): with d the distance from `at` to a
  // grain's surface, the triangle nearest to any q with |q - at| <= m is among those within
  // d + 2m of `at`, and the nearest of those is the search's own (same triangle, same distance).
  // Points near a faceted sphere (edges and corners nearby), displaced by exactly m in random
  // directions, the worst case; slots_within_in_body must also list exactly the brute-force set.
  const double radius = 0.5 * kMm, m_margin = 0.01 * radius;
  const Model m = faceted_spheres(radius, 1);
  SurfaceTrees trees(m);
  std::mt19937 rng(5);
  std::normal_distribution<double> gauss;
  std::uniform_real_distribution<double> depth(-0.03 * radius, 0.01 * radius);
  const auto random_direction = [&] { return Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)).normalized(); };
  int switched = 0;
  for (int i = 0; i < 400; ++i) {
    const Eigen::Vector3d at = (radius + depth(rng)) * random_direction();
    SurfaceTrees::Nearest there;
    ASSERT_TRUE(trees.nearest_in_body(0, at, radius, there));
    const double reach = std::sqrt(there.distance2) + 2 * m_margin;
    std::array<std::uint32_t, 64> within{};
    const std::size_t count = trees.slots_within_in_body(0, at, reach, within);
    ASSERT_LE(count, within.size());
    std::size_t brute = 0;
    for (std::uint32_t slot = 0; slot < m.triangles.size(); ++slot)
      brute += (trees.closest_in_slot(slot, at).point - at).squaredNorm() <= reach * reach;
    ASSERT_EQ(count, brute) << i;
    for (int k = 0; k < 20; ++k) {
      const Eigen::Vector3d q = at + m_margin * random_direction();
      SurfaceTrees::Nearest searched;
      ASSERT_TRUE(trees.nearest_in_body(0, q, radius, searched));
      std::uint32_t best = 0;
      double best2 = std::numeric_limits<double>::infinity();
      for (std::size_t j = 0; j < count; ++j) {
        const std::uint32_t t = trees.slot_triangle(within[j]);
        const double d2 = (trees.closest_in_slot(within[j], q).point - q).squaredNorm();
        if (d2 < best2 || (d2 == best2 && t < best)) best = t, best2 = d2;
      }
      ASSERT_EQ(best, searched.triangle) << i << " " << k;
      ASSERT_EQ(best2, searched.distance2) << i << " " << k;
      switched += best != there.triangle;
    }
  }
  EXPECT_GT(switched, 200);  // the nearest triangle does change within the margin
}

TEST(SurfaceTrees, AHintNeverChangesTheNearestTriangle) {
  // Points just off the box's corners and edge midpoints are as close to several triangles (ties
  // go to the lowest index), random points to one; any hint, near or far, must
  // give the same triangle as no hint.
  Model m;
  add_grain(m, box_mesh({1 * kMm, 0.7 * kMm, 0.5 * kMm}, 0.1 * kMm), Eigen::Vector3d::Zero(), GrainKind::tet4, 0, 1);
  SurfaceTrees trees(m);
  std::vector<Eigen::Vector3d> points;
  for (const auto& t : m.triangles) {
    const Eigen::Vector3d n = (m.nodes[t[1]] - m.nodes[t[0]]).cross(m.nodes[t[2]] - m.nodes[t[0]]).normalized();
    points.push_back(m.nodes[t[0]] + 0.01 * kMm * n);                              // above a corner
    points.push_back(0.5 * (m.nodes[t[0]] + m.nodes[t[1]]) - 0.01 * kMm * n);      // below an edge
  }
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u(-0.6 * kMm, 0.6 * kMm);
  for (int i = 0; i < 200; ++i) points.push_back({u(rng), u(rng), u(rng)});
  std::uniform_int_distribution<std::uint32_t> any(0, static_cast<std::uint32_t>(m.triangles.size() - 1));
  const double radius = 0.2 * kMm;
  int ties = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    SurfaceTrees::Nearest plain, hinted;
    const bool hit = trees.nearest(0, points[i], radius, m.nodes, plain);
    if (!hit) continue;
    int tied = 0;
    for (std::uint32_t t = 0; t < m.triangles.size(); ++t) {
      const auto& tri = m.triangles[t];
      const double d2 = (closest_point_on_triangle(points[i], m.nodes[tri[0]], m.nodes[tri[1]], m.nodes[tri[2]]).point -
                         points[i]).squaredNorm();
      if (d2 != plain.distance2) continue;
      ++tied;
      ASSERT_TRUE(trees.nearest(0, points[i], radius, m.nodes, hinted, t)) << i;  // hint: a tied triangle
      EXPECT_EQ(hinted.triangle, plain.triangle) << i;
    }
    ties += tied > 1;
    ASSERT_TRUE(trees.nearest(0, points[i], radius, m.nodes, hinted, any(rng))) << i;  // hint: any triangle
    EXPECT_EQ(hinted.triangle, plain.triangle) << i;
    EXPECT_EQ(hinted.distance2, plain.distance2) << i;
  }
  EXPECT_GT(ties, 100);
}

TEST(ContactModel, PressedFaceCarriesPenaltyTimesAreaTimesOverlap) {
  const double overlap = 1e-6;
  const Model m = pressed_cubes(overlap);
  ContactModel contact(m, unit_masses(m), {});
  auto f = zeros(m.nodes.size());
  const ContactStepStats stats = contact.add_forces(m.nodes, zeros(m.nodes.size()), {}, 1e-9, f);
  const double expected = m.materials[0].normal_penalty * (1 * kMm * 1 * kMm) * overlap;

  Eigen::Vector3d on_cube = Eigen::Vector3d::Zero(), total = Eigen::Vector3d::Zero(), torque = Eigen::Vector3d::Zero();
  for (std::uint32_t n = 0; n < m.nodes.size(); ++n) {
    total += f[n];
    torque += m.nodes[n].cross(f[n]);
    if (n >= m.grains[1].node_begin) on_cube += f[n];
  }
  EXPECT_NEAR(on_cube.z(), expected, 1e-12 * expected);
  EXPECT_NEAR(on_cube.head<2>().norm(), 0, 1e-12 * expected);
  EXPECT_NEAR(total.norm(), 0, 1e-12 * expected);
  EXPECT_NEAR(torque.norm(), 0, 1e-12 * expected * kMm);
  // 5 x 5 cube bottom nodes and 4 x 4 slab top nodes.
  EXPECT_EQ(stats.node_contacts, 25u + 16u);
  EXPECT_NEAR(stats.max_overlap, overlap, 1e-15);
  EXPECT_NEAR(stats.elastic_energy, 0.5 * expected * overlap, 1e-12 * expected * overlap);

  const std::span<const ContactRecord> records = contact.contacts();
  ASSERT_EQ(records.size(), 1u);
  EXPECT_EQ(records[0].a, 0u);
  EXPECT_EQ(records[0].b, 1u);
  EXPECT_NEAR((records[0].normal - Eigen::Vector3d::UnitZ()).norm(), 0, 1e-12);
  EXPECT_NEAR((records[0].force - on_cube).norm(), 0, 1e-12 * expected);
  EXPECT_NEAR(records[0].point.z(), 0.5 * kMm - 0.5 * overlap, 1e-12);
}

TEST(ContactModel, OverlapsAreFoundAtAnyDepthUnlikeTheStepsSearch) {
  // The cube 0.3 mm into the slab: the step's search looks only a tenth of the smallest grain deep
  // (0.1 mm), the overlap check finds the cube's bottom nodes 0.3 mm inside the slab.
  const Model m = pressed_cubes(0.3 * kMm);
  ContactModel contact(m, unit_masses(m), {});
  const std::vector<PlatenState> platen{{Eigen::Vector3d(0, 0, -0.4 * kMm), Eigen::Vector3d::UnitZ()}};
  const std::vector<Overlap> overlaps = contact.overlaps(m.nodes, platen);
  ASSERT_EQ(overlaps.size(), 2u);
  EXPECT_EQ(overlaps[0].a, 0u);
  EXPECT_EQ(overlaps[0].b, 1u);
  EXPECT_NEAR(overlaps[0].depth, 0.3 * kMm, 1e-15);
  EXPECT_EQ(overlaps[1].a, 0u);  // the slab's bottom face 0.1 mm behind the platen
  EXPECT_EQ(overlaps[1].b, 2u);
  EXPECT_NEAR(overlaps[1].depth, 0.1 * kMm, 1e-15);
  auto f = zeros(m.nodes.size());
  EXPECT_LT(contact.add_forces(m.nodes, zeros(m.nodes.size()), {}, 1e-9, f).max_overlap, 0.11 * kMm);
  // Two one-cell cubes half through each other: every corner lies on the other's faces (depth 0),
  // the face triangles' centroids are a third of the edge inside.
  Model coarse;
  const TetMesh cube = box_mesh(Eigen::Vector3d::Constant(kMm), kMm);
  add_grain(coarse, cube, Eigen::Vector3d::Zero(), GrainKind::rigid, 0, 1);
  add_grain(coarse, cube, Eigen::Vector3d(0.5 * kMm, 0, 0), GrainKind::rigid, 0, 2);
  const std::vector<Overlap> through = ContactModel(coarse, unit_masses(coarse), {}).overlaps(coarse.nodes, {});
  ASSERT_EQ(through.size(), 1u);
  EXPECT_NEAR(through[0].depth, kMm / 3, 1e-15);
  // Touching: nothing beyond round-off; apart: nothing.
  const Model touching = pressed_cubes(0), apart = pressed_cubes(-1e-7);
  for (const Overlap& o : ContactModel(touching, unit_masses(touching), {}).overlaps(touching.nodes, {}))
    EXPECT_LT(o.depth, 1e-18);
  EXPECT_TRUE(ContactModel(apart, unit_masses(apart), {}).overlaps(apart.nodes, {}).empty());
}

TEST(ContactModel, OverlapsOfTheMovedGrainsAloneAfterAnOverlapCheck) {
  // Three cubes in a row, each pair 0.3 mm through each other, the first 0.1 mm behind a platen.
  Model m;
  const TetMesh cube = box_mesh(Eigen::Vector3d::Constant(kMm), 0.5 * kMm);
  for (int g = 0; g < 3; ++g) add_grain(m, cube, Eigen::Vector3d(0.7 * kMm * g, 0, 0), GrainKind::rigid, 0, g + 1);
  const std::vector<PlatenState> platen{{Eigen::Vector3d(0.1 * kMm - 0.5 * kMm, 0, 0), Eigen::Vector3d::UnitX()}};
  ContactModel contact(m, unit_masses(m), {});
  ASSERT_EQ(contact.overlaps(m.nodes, platen).size(), 3u);
  // The last cube moves 0.2 mm away: only its pair is measured again (0.1 mm deep now).
  std::vector<Eigen::Vector3d> x = m.nodes;
  for (std::uint32_t i = m.grains[2].node_begin; i < m.grains[2].node_end; ++i) x[i].x() += 0.2 * kMm;
  const std::vector<std::uint8_t> moved{0, 0, 1};
  const std::vector<Overlap> again = contact.overlaps(x, platen, moved);
  ASSERT_EQ(again.size(), 1u);
  EXPECT_EQ(again[0].a, 1u);
  EXPECT_EQ(again[0].b, 2u);
  EXPECT_NEAR(again[0].depth, 0.1 * kMm, 1e-15);
  // The same as a full check of the moved configuration, for that pair.
  const std::vector<Overlap> full = ContactModel(m, unit_masses(m), {}).overlaps(x, platen);
  ASSERT_EQ(full.size(), 3u);
  EXPECT_NEAR(full[2].depth, again[0].depth, 1e-15);
  // After a step the flags are not trusted: every grain is measured.
  auto f = zeros(m.nodes.size());
  contact.add_forces(x, zeros(m.nodes.size()), {}, 1e-9, f);
  EXPECT_EQ(contact.overlaps(x, platen, moved).size(), 3u);
  EXPECT_THROW(contact.overlaps(x, platen, std::vector<std::uint8_t>{1}), DataError);
}

namespace {
/// The upward contact force on pressed_cubes' cube in one step with it pushed `extra` further down.
double upward_force_on_cube(const Model& m, ContactModel& contact, double extra) {
  std::vector<Eigen::Vector3d> x = m.nodes;
  for (std::uint32_t i = m.grains[1].node_begin; i < m.grains[1].node_end; ++i) x[i].z() -= extra;
  auto f = zeros(m.nodes.size());
  contact.add_forces(x, zeros(m.nodes.size()), {}, 1e-9, f);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::uint32_t i = m.grains[1].node_begin; i < m.grains[1].node_end; ++i) sum += f[i];
  return sum.z();
}
}  // namespace

TEST(ContactModel, KeptInitialOverlapsCarryNoForceAndOnlyTheOverlapBeyondThemPushes) {
  // The cube starts 0.05 mm into the slab, as a scanned twin's grains overlap where they touch.
  const Model m = pressed_cubes(0.05 * kMm);
  const auto force_on_cube = [&](ContactModel& contact, double extra) { return upward_force_on_cube(m, contact, extra); };
  ContactModel plain(m, unit_masses(m), {}), kept(m, unit_masses(m), {});
  kept.keep_initial_overlaps(kept.overlaps(m.nodes, {}));
  EXPECT_GT(force_on_cube(plain, 0.0), 0.0);
  EXPECT_EQ(force_on_cube(kept, 0.0), 0.0) << "the start's overlap is force-free";
  // Pressed 0.01 mm further: the kept contact pushes as a fresh one 0.01 mm deep does.
  const double pressed = force_on_cube(kept, 0.01 * kMm);
  const Model shallow = pressed_cubes(0.01 * kMm);
  ContactModel fresh(shallow, unit_masses(shallow), {});
  const double expected = upward_force_on_cube(shallow, fresh, 0.0);
  EXPECT_NEAR(pressed, expected, 1e-9 * std::abs(expected));
  // Opened to 0.03 mm deep, the offset shrinks to it and stays there: back at the start's 0.05 mm the
  // contact pushes like a fresh 0.02 mm one.
  EXPECT_EQ(force_on_cube(kept, -0.02 * kMm), 0.0);
  EXPECT_GT(force_on_cube(kept, 0.0), 0.0);
  // Only the first step adopts: a contact made later has no offset.
  ContactModel late(m, unit_masses(m), {});
  late.keep_initial_overlaps(late.overlaps(m.nodes, {}));
  EXPECT_EQ(force_on_cube(late, -0.1 * kMm), 0.0);  // apart: no contact, and the adoption is spent
  EXPECT_GT(force_on_cube(late, 0.0), 0.0);
}

TEST(ContactModel, KeptInitialOverlapsDeeperThanTheSearchAreFoundAndKept) {
  // 0.2 mm in: twice the deepest penetration a step looks for (a tenth of the cube's 1 mm side), as
  // where a scanned twin's meshes overlap by a couple of voxels. The pair's search looks deeper.
  const double start = 0.2 * kMm, further = 0.01 * kMm;
  const Model m = pressed_cubes(start);
  const auto force_on_cube = [&](ContactModel& contact, double extra) { return upward_force_on_cube(m, contact, extra); };
  ContactModel kept(m, unit_masses(m), {});
  const std::vector<Overlap> overlaps = kept.overlaps(m.nodes, {});
  ASSERT_EQ(overlaps.size(), 1u);
  EXPECT_NEAR(overlaps[0].depth, start, 1e-12);
  kept.keep_initial_overlaps(overlaps);
  EXPECT_EQ(force_on_cube(kept, 0.0), 0.0);
  // Pressed further, the deep nodes push. Not quite as a fresh contact of that depth does: the
  // slab's nodes within 0.2 mm of the cube's sides are closer to those sides than to its bottom, so
  // their overlaps (and offsets) are horizontal and pressing down adds nothing to them. Without the
  // deeper search no node would be found at all, and the cube would sink freely.
  const double pressed = force_on_cube(kept, further);
  const Model shallow = pressed_cubes(further);
  ContactModel fresh(shallow, unit_masses(shallow), {});
  const double expected = upward_force_on_cube(shallow, fresh, 0.0);
  ASSERT_GT(expected, 0.0);
  EXPECT_GT(pressed, 0.5 * expected);
  EXPECT_LE(pressed, expected * (1 + 1e-9));
  // A restart keeps the offsets and the pair's deeper search: the same force again.
  const auto path = std::filesystem::temp_directory_path() / "fdem_contact_kept_overlap_test.h5";
  {
    io::H5File file = io::H5File::create(path);
    kept.save(file, "/contact");
  }
  ContactModel restarted(m, unit_masses(m), {});
  restarted.load(io::H5File::open(path), "/contact");
  std::filesystem::remove(path);
  EXPECT_EQ(force_on_cube(restarted, further), pressed);
}

TEST(ContactModel, OverlapsOfSixteenThousandGrainsComeThroughTheBroadPhase) {
  // 16 000 faceted spheres on a cubic lattice 0.9 diameters apart: each overlaps its six lattice
  // neighbours by about a tenth of a diameter and no other grain (the diagonal ones are 1.27
  // diameters apart). Every overlap is found, and only those, in a few seconds (docs/fdemrun.md).
  const double radius = 0.25 * kMm, pitch = 0.9 * 2 * radius;
  mesh::TetOptions o;
  o.size = 0.4 * radius;
  const mesh::TetMesh sphere = mesh::mesh_ellipsoid(Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(radius),
                                                    Eigen::Quaterniond::Identity(), o);
  constexpr int kSide[3] = {25, 25, 26};
  Model m;
  for (int i = 0; i < kSide[0]; ++i)
    for (int j = 0; j < kSide[1]; ++j)
      for (int k = 0; k < kSide[2]; ++k) {
        mesh::TetMesh placed = sphere;
        for (Eigen::Vector3d& p : placed.nodes) p += pitch * Eigen::Vector3d(i, j, k);
        mesh::append_grain(m, placed, static_cast<std::uint32_t>(m.grains.size() + 1), GrainKind::rigid);
      }
  ASSERT_EQ(m.grains.size(), 16250u);
  ContactModel contact(m, unit_masses(m), {});
  const auto start = std::chrono::steady_clock::now();
  const std::vector<Overlap> overlaps = contact.overlaps(m.nodes, {});
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("overlaps of %zu grains: %.2f s\n", m.grains.size(), seconds);
  const auto index = [&](int i, int j, int k) { return static_cast<std::uint32_t>((i * kSide[1] + j) * kSide[2] + k); };
  std::size_t expected = 0;
  for (int d = 0; d < 3; ++d) expected += static_cast<std::size_t>(kSide[0] * kSide[1] * kSide[2] / kSide[d] * (kSide[d] - 1));
  ASSERT_EQ(overlaps.size(), expected);
  for (const Overlap& ov : overlaps) {
    const std::uint32_t step = ov.b - ov.a;
    EXPECT_TRUE(step == 1 || step == index(0, 1, 0) || step == index(1, 0, 0)) << ov.a << " " << ov.b;
    // A tenth of the diameter between the true spheres; the facets cut a little off.
    EXPECT_GT(ov.depth, 0.05 * radius);
    EXPECT_LT(ov.depth, 0.2 * radius);
  }
}

TEST(ContactModel, NoForceAcrossAGap) {
  const Model m = pressed_cubes(-1e-7);
  ContactModel contact(m, unit_masses(m), {});
  auto f = zeros(m.nodes.size());
  const ContactStepStats stats = contact.add_forces(m.nodes, zeros(m.nodes.size()), {}, 1e-9, f);
  EXPECT_EQ(stats.pairs, 1u);  // the skin keeps the pair a candidate
  EXPECT_EQ(stats.node_contacts, 0u);
  EXPECT_TRUE(contact.contacts().empty());
  for (const auto& v : f) EXPECT_EQ(v.norm(), 0);
}

TEST(ContactModel, BroadPhaseRebuildsOnlyAfterHalfTheSkin) {
  const Model m = pressed_cubes(1e-6);
  ContactModel contact(m, unit_masses(m), {});
  auto x = m.nodes;
  auto f = zeros(m.nodes.size());
  EXPECT_TRUE(contact.add_forces(x, zeros(x.size()), {}, 1e-9, f).rebuilt);
  for (std::uint32_t n = m.grains[1].node_begin; n < m.grains[1].node_end; ++n) x[n].x() += 0.4 * contact.skin();
  EXPECT_FALSE(contact.add_forces(x, zeros(x.size()), {}, 1e-9, f).rebuilt);
  for (std::uint32_t n = m.grains[1].node_begin; n < m.grains[1].node_end; ++n) x[n].x() += 0.2 * contact.skin();
  EXPECT_TRUE(contact.add_forces(x, zeros(x.size()), {}, 1e-9, f).rebuilt);
  EXPECT_EQ(contact.rebuild_count(), 2u);
}

/// The 1 mm cube alone, resting on a platen `overlap` deep and sliding along x.
struct SlidingCube {
  Model model;
  PlatenState platen;
  std::vector<Eigen::Vector3d> x, v;
  double dt = 1e-9, overlap = 1e-6;
  SlidingCube() {
    model.materials[0].damping_ratio = 0;
    add_grain(model, box_mesh({1 * kMm, 1 * kMm, 1 * kMm}, 0.25 * kMm), Eigen::Vector3d::Zero(), GrainKind::tet4, 0, 1);
    platen.point = Eigen::Vector3d(0, 0, -0.5 * kMm + overlap);
    platen.friction = 0.4;
    x = model.nodes;
    v.assign(x.size(), Eigen::Vector3d(100.0, 0, 0));  // 0.1 um per step
  }
  Eigen::Vector3d step(ContactModel& contact) {
    auto f = zeros(x.size());
    contact.add_forces(x, v, {&platen, 1}, dt, f);
    for (std::size_t n = 0; n < x.size(); ++n) x[n] += v[n] * dt;
    Eigen::Vector3d total = Eigen::Vector3d::Zero();
    for (const auto& fn : f) total += fn;
    return total;
  }
};

TEST(ContactModel, PlatenFrictionGrowsWithSlipThenHoldsMuTimesNormalForce) {
  SlidingCube s;
  ContactModel contact(s.model, unit_masses(s.model), {});
  const Material& mat = s.model.materials[0];
  const double area = 1 * kMm * 1 * kMm;
  const double normal = mat.normal_penalty * area * s.overlap;
  const double cap = s.platen.friction * normal;
  for (int step = 1; step <= 12; ++step) {
    const Eigen::Vector3d total = s.step(contact);
    EXPECT_NEAR(total.z(), normal, 1e-12 * normal);
    const double elastic = mat.tangential_penalty * area * 100.0 * s.dt * step;
    EXPECT_NEAR(total.x(), -std::min(elastic, cap), 1e-9 * cap) << step;
  }
  const std::span<const ContactRecord> records = contact.contacts();
  ASSERT_EQ(records.size(), 1u);
  EXPECT_EQ(records[0].b, 1u);  // grains.size() + platen 0
  EXPECT_NEAR((records[0].normal + Eigen::Vector3d::UnitZ()).norm(), 0, 1e-12);
}

TEST(ContactModel, HistoryIsDroppedWhenTheContactOpens) {
  SlidingCube s;
  ContactModel contact(s.model, unit_masses(s.model), {});
  const double area = 1 * kMm * 1 * kMm;
  const double one_step = s.model.materials[0].tangential_penalty * area * 100.0 * s.dt;
  for (int step = 0; step < 3; ++step) s.step(contact);
  EXPECT_NEAR(s.step(contact).x(), -4 * one_step, 1e-9 * one_step);
  // Lift the cube clear for one step: no contact, so no spring survives.
  for (auto& p : s.x) p.z() += 2 * s.overlap;
  EXPECT_EQ(s.step(contact).norm(), 0);
  EXPECT_TRUE(contact.contacts().empty());
  for (auto& p : s.x) p.z() -= 2 * s.overlap;
  EXPECT_NEAR(s.step(contact).x(), -one_step, 1e-9 * one_step);
}

TEST(ContactModel, RestartFromSavedHistoryIsExact) {
  const auto path = std::filesystem::temp_directory_path() / "fdem_contact_history_test.h5";
  SlidingCube run, restarted;
  ContactModel contact(run.model, unit_masses(run.model), {});
  for (int step = 0; step < 3; ++step) run.step(contact);
  {
    io::H5File file = io::H5File::create(path);
    contact.save(file, "/contact");
  }
  ContactModel fresh(restarted.model, unit_masses(restarted.model), {});
  fresh.load(io::H5File::open(path), "/contact");
  restarted.x = run.x;
  for (int step = 0; step < 5; ++step) {
    auto fa = zeros(run.x.size()), fb = zeros(run.x.size());
    contact.add_forces(run.x, run.v, {&run.platen, 1}, run.dt, fa);
    fresh.add_forces(restarted.x, restarted.v, {&restarted.platen, 1}, restarted.dt, fb);
    for (std::size_t n = 0; n < fa.size(); ++n) ASSERT_EQ(fa[n], fb[n]) << "step " << step << " node " << n;
    for (std::size_t n = 0; n < run.x.size(); ++n) run.x[n] = restarted.x[n] = run.x[n] + run.v[n] * run.dt;
  }
  std::filesystem::remove(path);
}

TEST(ContactModel, LoadRefusesAHistoryOfAnotherModel) {
  const auto path = std::filesystem::temp_directory_path() / "fdem_contact_bad_history_test.h5";
  {
    io::H5File file = io::H5File::create(path);
    file.set_attr("/", "entries", 1LL);
    file.write<std::uint32_t>("/pair", std::vector<std::uint32_t>{0, 7}.data(), {1, 2});
    file.write<std::uint32_t>("/node", std::vector<std::uint32_t>{99999});
    file.write<double>("/spring", std::vector<double>{0, 0, 0}.data(), {1, 3});
  }
  SlidingCube s;
  ContactModel contact(s.model, unit_masses(s.model), {});
  try {
    contact.load(io::H5File::open(path), "/");
    FAIL() << "a foreign history was accepted";
  } catch (const DataError& e) {
    EXPECT_NE(e.message().find(path.filename().string()), std::string::npos) << e.message();
  }
  std::filesystem::remove(path);
}

TEST(ContactModel, SameForcesForAnyThreadCount) {
  // 2 x 2 x 2 jittered, overlapping 0.5 mm cubes on a platen, spinning and sinking: many
  // candidate pairs, every kind of closest feature and the friction history.
  Model m;
  m.materials[0].damping_ratio = 0.05;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> jitter(-0.01 * kMm, 0.01 * kMm);
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d at(0.49 * kMm * (i & 1) + jitter(rng), 0.49 * kMm * ((i >> 1) & 1) + jitter(rng),
                             0.49 * kMm * (i >> 2) + jitter(rng));
    add_grain(m, box_mesh({0.5 * kMm, 0.5 * kMm, 0.5 * kMm}, 0.25 * kMm), at, GrainKind::tet4, 0, i + 1);
  }
  PlatenState floor;
  floor.point = Eigen::Vector3d(0, 0, -0.24 * kMm);
  floor.friction = 0.3;
  std::vector<Eigen::Vector3d> v = zeros(m.nodes.size());
  for (std::uint32_t g = 0; g < m.grains.size(); ++g)
    for (std::uint32_t n = m.grains[g].node_begin; n < m.grains[g].node_end; ++n)
      v[n] = Eigen::Vector3d(0, 0, 30.0 * (g % 3)).cross(m.nodes[n]) + Eigen::Vector3d(0.1 * g, 0, -0.2);
  std::vector<std::vector<Eigen::Vector3d>> forces;
  for (int threads : {1, 2, 3}) {
    omp_set_num_threads(threads);
    ContactModel contact(m, unit_masses(m), {});
    auto y = m.nodes;
    std::vector<Eigen::Vector3d> f;
    for (int step = 0; step < 4; ++step) {
      f = zeros(m.nodes.size());
      const ContactStepStats stats = contact.add_forces(y, v, {&floor, 1}, 1e-8, f);
      EXPECT_GE(stats.pairs, 12u);
      for (std::size_t n = 0; n < y.size(); ++n) y[n] += v[n] * 1e-8;
    }
    forces.push_back(f);
  }
  omp_set_num_threads(omp_get_num_procs());
  EXPECT_EQ(forces[0], forces[1]);
  EXPECT_EQ(forces[0], forces[2]);
  double sum = 0;
  for (const auto& fn : forces[0]) sum += fn.norm();
  EXPECT_GT(sum, 0);
}

/// 8 cubes of 0.5 mm in a 2 x 2 x 2 block, 1.5 skins apart to 1.5 skins overlapping, turning,
/// closing in on the block's centre by 0.04 skin a step for 20 steps and then moving out again:
/// nodes come into contact from beyond the near-node lists' reach within one list's life, and
/// nodes deeper than that reach (past the deepest detectable penetration) come back up into it.
/// At step 30 one cube jumps by 1.5 skins. `pace` scales the closing and turning speeds.
struct ClosingCubes {
  static constexpr int kSteps = 40, kTurn = 20, kJump = 30;
  static constexpr double kDt = 1e-8;
  Model m;
  double side = 0.5 * kMm;
  double skin = 0.05 * std::sqrt(3.0) * side;  // the automatic skin of these cubes
  double pace = 1;
  std::vector<Eigen::Vector3d> centre, axis;
  PlatenState floor;

  explicit ClosingCubes(GrainKind kind, double pace = 1) : pace(pace) {
    m.materials[0].damping_ratio = 0.05;
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> gap(-1.5 * skin, 1.5 * skin), unit(-1, 1);
    for (int i = 0; i < 8; ++i) {
      const Eigen::Vector3d cell((i & 1) - 0.5, ((i >> 1) & 1) - 0.5, (i >> 2) - 0.5);
      centre.push_back(cell * side + cell.cwiseProduct(Eigen::Vector3d(gap(rng), gap(rng), gap(rng))));
      axis.push_back(Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).normalized());
      add_grain(m, box_mesh({side, side, side}, 0.125 * kMm), Eigen::Vector3d::Zero(), kind, 0, i + 1);
    }
    floor.point = Eigen::Vector3d(0, 0, -side);
    floor.friction = 0.3;
  }

  /// How the grains are given to contact: deformable without poses, rigid by their poses, or
  /// deformable with their frames and a strain that breathes (up to 2 %, a tenth of the skin at a
  /// cube's corner) on top.
  enum class Poses { none, rigid, framed };
  /// Node positions, velocities and the grains' poses at `step`.
  void place(int step, Poses given, std::vector<Eigen::Vector3d>& x, std::vector<Eigen::Vector3d>& v,
             std::vector<RigidPose>& poses) const {
    const bool rigid = given == Poses::rigid;
    x.resize(m.nodes.size());
    v.resize(m.nodes.size());
    poses.resize(m.grains.size());
    for (std::uint32_t g = 0; g < m.grains.size(); ++g) {
      const double closed = pace * 0.04 * skin * (step < kTurn ? step : 2 * kTurn - step) +
                            (step >= kJump && g == 5 ? 1.5 * skin : 0.0);
      const Eigen::Vector3d at = centre[g] - closed * centre[g].normalized();
      const Eigen::Matrix3d R = Eigen::AngleAxisd(pace * 0.002 * step, axis[g]).toRotationMatrix();
      const Eigen::Vector3d velocity = pace * (step < kTurn ? -0.04 : 0.04) * skin / kDt * centre[g].normalized();
      const Eigen::Vector3d omega = pace * 0.002 / kDt * axis[g];
      // The reference centroid is taken at the origin (the boxes are meshed around it).
      poses[g] = rigid ? RigidPose::of_body(R, at, Eigen::Vector3d::Zero(), velocity, omega)
                 : given == Poses::framed ? RigidPose::of_frame(R, at, Eigen::Vector3d::Zero())
                                          : RigidPose{};
      const double strain = given == Poses::framed ? 0.02 * std::sin(0.3 * step + g) : 0.0;
      const Eigen::Vector3d stretch(1 + strain, 1 - 0.5 * strain, 1 + 0.3 * strain);
      for (std::uint32_t n = m.grains[g].node_begin; n < m.grains[g].node_end; ++n) {
        x[n] = R * stretch.cwiseProduct(m.nodes[n]) + at;
        v[n] = velocity + omega.cross(x[n] - at);
      }
    }
  }
};

/// Forces with the near-node lists must equal, bit for bit, those found by testing every surface node.
/// Returns the rigid or framed pairs' lists built again between the broad phase's rebuilds.
std::size_t expect_near_node_lists_match_every_node(ClosingCubes::Poses given, double pace = 1) {
  const ClosingCubes c(given == ClosingCubes::Poses::rigid ? GrainKind::rigid : GrainKind::tet4, pace);
  ContactOptions listed, every;
  every.near_node_lists = false;
  ContactModel with_lists(c.m, unit_masses(c.m), listed), without(c.m, unit_masses(c.m), every);
  EXPECT_DOUBLE_EQ(with_lists.skin(), c.skin);
  std::vector<Eigen::Vector3d> x, v;
  std::vector<RigidPose> poses;
  std::size_t contacts = 0, checks_with = 0, checks_without = 0, pair_lists = 0;
  for (int step = 0; step < ClosingCubes::kSteps; ++step) {
    c.place(step, given, x, v, poses);
    auto fa = zeros(x.size()), fb = zeros(x.size());
    const ContactStepStats a = with_lists.add_forces(x, v, {&c.floor, 1}, ClosingCubes::kDt, fa, poses);
    const ContactStepStats b = without.add_forces(x, v, {&c.floor, 1}, ClosingCubes::kDt, fb, poses);
    for (std::size_t n = 0; n < x.size(); ++n) {
      EXPECT_EQ(fa[n], fb[n]) << "step " << step << " node " << n;
      if (fa[n] != fb[n]) return pair_lists;
    }
    EXPECT_TRUE(same_loads(with_lists.rigid_loads(), without.rigid_loads())) << "step " << step;
    EXPECT_EQ(a.node_contacts, b.node_contacts) << step;
    EXPECT_EQ(a.elastic_energy, b.elastic_energy) << step;
    contacts += a.node_contacts;
    checks_with += a.node_checks;
    checks_without += b.node_checks;
    pair_lists += a.pair_lists_built;
  }
  EXPECT_GE(with_lists.rebuild_count(), pace == 1 ? 4u : 2u);  // several lists' lives, the jump included
  EXPECT_GT(contacts, 1000u);
  EXPECT_LT(checks_with, checks_without / 3);  // the lists do save work
  return pair_lists;
}

TEST(ContactModel, NearNodeListsGiveTheSameForcesAsTestingEveryNode) {
  expect_near_node_lists_match_every_node(ClosingCubes::Poses::none);
}

TEST(ContactModel, NearNodeListsGiveTheSameForcesForRigidGrainsPlacedByTheirPoses) {
  expect_near_node_lists_match_every_node(ClosingCubes::Poses::rigid);
}

TEST(ContactModel, RigidPairsListsOutliveTheBroadPhaseUntilThePairMovesASkin) {
  // At half the pace, a pair's relative motion reaches a skin between the broad phase's
  // rebuilds (lists built again alone) and lists survive rebuilds that other grains triggered
  // (the jump at step 30); forces must still match testing every node bit for bit.
  EXPECT_GT(expect_near_node_lists_match_every_node(ClosingCubes::Poses::rigid, 0.5), 0u);
}

TEST(ContactModel, FramedPairsListsOutliveTheBroadPhaseWhileFramesAndStrainsMoveLessThanASkin) {
  // Deformable cubes with their frames, straining on top: their lists last as rigid pairs' do,
  // with each grain's deviation from its frame counted in the pair's motion, and forces still match
  // testing every node bit for bit.
  EXPECT_GT(expect_near_node_lists_match_every_node(ClosingCubes::Poses::framed, 0.5), 0u);
  expect_near_node_lists_match_every_node(ClosingCubes::Poses::framed);
}

TEST(ContactModel, RigidGrainsSearchedInTheirBodyFramesGiveTheWorldSearchsForces) {
  // With poses, rigid grains are searched in their body frames and listed nodes reach them through
  // one affine map per pair, and their forces go to their loads; without poses the same positions go
  // through refitted world trees and the forces to the nodes. The two must find the same node
  // contacts, and the loads must be what the node forces add up to, to round-off.
  const ClosingCubes c(GrainKind::rigid);
  ContactModel body(c.m, unit_masses(c.m), {}), world(c.m, unit_masses(c.m), {});
  std::vector<Eigen::Vector3d> x, v;
  std::vector<RigidPose> poses;
  std::size_t contacts = 0;
  for (int step = 0; step < ClosingCubes::kSteps; ++step) {
    c.place(step, ClosingCubes::Poses::rigid, x, v, poses);
    auto fa = zeros(x.size()), fb = zeros(x.size());
    const ContactStepStats a = body.add_forces(x, v, {&c.floor, 1}, ClosingCubes::kDt, fa, poses);
    const ContactStepStats b = world.add_forces(x, v, {&c.floor, 1}, ClosingCubes::kDt, fb);
    ASSERT_EQ(a.node_contacts, b.node_contacts) << step;
    ASSERT_EQ(fa, zeros(x.size())) << "rigid grains' nodes got forces at step " << step;
    ASSERT_TRUE(near_loads(body.rigid_loads(), loads_of(c.m, x, fb, poses), 1e-9)) << "step " << step;
    ASSERT_NEAR(a.elastic_energy, b.elastic_energy, 1e-9 * b.elastic_energy) << step;
    contacts += a.node_contacts;
  }
  EXPECT_GT(contacts, 1000u);
}

TEST(RigidLoad, TorqueIsTheSumOfArmsCrossForces) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  RigidLoad load;
  Eigen::Vector3d force = Eigen::Vector3d::Zero(), torque = Eigen::Vector3d::Zero();
  for (int k = 0; k < 5; ++k) {
    const Eigen::Vector3d r(u(rng), u(rng), u(rng)), f(u(rng), u(rng), u(rng));
    load.add(r, f);
    force += f;
    torque += r.cross(f);
  }
  EXPECT_LT((load.force - force).norm(), 1e-15);
  EXPECT_LT((load.torque() - torque).norm(), 1e-14);
}

TEST(ContactModel, ABallOnAnImplicitGrainPressesItsFootprint) {
  // A membrane ball pressed into a face of a deformable cube: on a plain deformable grain its force
  // acts on one triangle's corners; on an implicit (framed) grain it is shared by the surface nodes
  // within the ball's radius of the contact point, by area and nearness (a stiff ball on three nodes
  // of a quasi-static grain is unstable). The same total force either way, balancing the ball's.
  Model m;
  const double side = 0.5e-3, radius = 0.1e-3;
  add_grain(m, box_mesh({side, side, side}, side / 8), Eigen::Vector3d::Zero(), GrainKind::tet4, 0, 1);
  const std::vector<Eigen::Vector3d> centre{Eigen::Vector3d(0.01e-3, -0.02e-3, 0.5 * side + radius - 1e-6)}, still = zeros(1);
  const BallContactOptions balls{radius, 1e-8, 0.3};
  const Eigen::Vector3d touched(centre[0].x(), centre[0].y(), 0.5 * side);
  for (const bool framed : {false, true}) {
    ContactModel contact(m, unit_masses(m), {});
    const std::vector<RigidPose> poses{framed ? RigidPose::of_frame(Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero())
                                              : RigidPose{}};
    auto f = zeros(m.nodes.size()), ball_force = zeros(1), ball_moment = zeros(1);
    contact.add_forces(m.nodes, zeros(m.nodes.size()), {}, 1e-9, f, poses);
    add_ball_contacts(contact.add_ball_forces(m.nodes, zeros(m.nodes.size()), centre, still, still, balls, 1e-9, f), ball_force, ball_moment);
    ASSERT_GT(ball_force[0].z(), 0);
    Eigen::Vector3d total = Eigen::Vector3d::Zero();
    std::size_t pressed = 0;
    for (std::size_t n = 0; n < m.nodes.size(); ++n) {
      if (f[n].isZero()) continue;
      ++pressed;
      total += f[n];
      EXPECT_LT((m.nodes[n] - touched).norm(), framed ? radius : side / 8 * 1.5) << "node " << n;
    }
    EXPECT_LT((total + ball_force[0]).norm(), 1e-12 * ball_force[0].norm());
    if (framed) EXPECT_GE(pressed, 6u);
    else EXPECT_LE(pressed, 3u);
  }
}

TEST(ContactModel, RigidGrainsNodesComeFromTheirPosesAndTheirForcesGoToTheirLoads) {
  // With poses, a rigid grain's nodes are placed by its pose: the node arrays may hold anything
  // (here NaN), the grain, platen, wall and ball forces must be those of nodes placed in the arrays,
  // bit for bit, and go to the grains' loads, not to the nodes. Without poses the same grains get
  // node forces; the loads must be what those add up to.
  const ClosingCubes c(GrainKind::rigid);
  ContactModel placed(c.m, unit_masses(c.m), {}), unread(c.m, unit_masses(c.m), {}), world(c.m, unit_masses(c.m), {});
  std::vector<Eigen::Vector3d> x, v;
  std::vector<RigidPose> poses;
  const Eigen::Vector3d nan = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  CylinderWallState wall;
  wall.radius = 0.45 * c.side;  // cuts the block's vertical edges
  const std::vector<Eigen::Vector3d> balls = {Eigen::Vector3d(c.side, 0, 0), Eigen::Vector3d(0, -c.side, 0.25 * c.side)};
  const BallContactOptions ball_options{0.1 * c.side, 1e-9, 0.3};
  const double dt = ClosingCubes::kDt;
  std::size_t contacts = 0, ball_contacts = 0, wall_contacts = 0;
  for (int step = 0; step < ClosingCubes::kSteps; ++step) {
    c.place(step, ClosingCubes::Poses::rigid, x, v, poses);
    const std::vector<Eigen::Vector3d> garbage(x.size(), nan), still = zeros(balls.size());
    auto fa = zeros(x.size()), fb = zeros(x.size()), fw = zeros(x.size());
    auto ball_fa = zeros(balls.size()), ball_fb = ball_fa, ball_fw = ball_fa, moment_a = ball_fa, moment_b = ball_fa,
         moment_w = ball_fa;
    const ContactStepStats a = placed.add_forces(x, v, {&c.floor, 1}, dt, fa, poses);
    const ContactStepStats b = unread.add_forces(garbage, garbage, {&c.floor, 1}, dt, fb, poses);
    world.add_forces(x, v, {&c.floor, 1}, dt, fw);
    const BoundaryContactStats wall_a = wall_contact_stats(placed.add_wall_forces(x, v, wall, dt, fa));
    const BoundaryContactStats wall_b = wall_contact_stats(unread.add_wall_forces(garbage, garbage, wall, dt, fb));
    world.add_wall_forces(x, v, wall, dt, fw);
    ball_contacts += add_ball_contacts(placed.add_ball_forces(x, v, balls, still, still, ball_options, dt, fa), ball_fa, moment_a).contacts;
    add_ball_contacts(unread.add_ball_forces(garbage, garbage, balls, still, still, ball_options, dt, fb), ball_fb, moment_b);
    add_ball_contacts(world.add_ball_forces(x, v, balls, still, still, ball_options, dt, fw), ball_fw, moment_w);
    ASSERT_EQ(a.node_contacts, b.node_contacts) << step;
    ASSERT_EQ(wall_a.contacts, wall_b.contacts) << step;
    ASSERT_EQ(ball_fa, ball_fb) << step;
    ASSERT_TRUE(same_loads(placed.rigid_loads(), unread.rigid_loads())) << "step " << step;
    ASSERT_EQ(fa, zeros(x.size())) << "rigid grains' nodes got forces at step " << step;
    ASSERT_EQ(fb, zeros(x.size())) << step;
    ASSERT_TRUE(near_loads(placed.rigid_loads(), loads_of(c.m, x, fw, poses), 1e-9)) << "step " << step;
    contacts += a.node_contacts;
    wall_contacts += wall_a.contacts;
  }
  EXPECT_GT(contacts, 1000u);
  EXPECT_GT(wall_contacts, 100u);
  EXPECT_GT(ball_contacts, 10u);
}

TEST(ContactModel, SearchMemosOfRigidGrainsGiveTheForcesOfSearchingAnew) {
  // Two coarse faceted spheres (R = 0.5 mm, facets of about 0.4 R) pressed about 10 % of R into
  // each other. One breathes in and out along the line of centres (up to 0.2 memo margin a step)
  // while it rolls and slides over the other, slowly for 300 steps (nodes mostly enter and leave
  // the other grain, normal to its surface), then at up to 0.3 margin a step (nodes cross edges
  // and corners, and the closest triangle keeps changing among the remembered ones). At step 500
  // it jumps. Forces must match searching anew, bit for bit.
  const double radius = 0.5 * kMm;
  const Model m = faceted_spheres(radius, 2);
  ContactOptions anew;
  anew.search_memos = false;
  ContactModel remembering(m, unit_masses(m), {}), searching(m, unit_masses(m), anew);
  const double margin = 0.05 * remembering.skin();  // kMemoMarginFraction
  const Eigen::Vector3d orbit_axis = Eigen::Vector3d(1, 2, 3).normalized(), spin_axis = Eigen::Vector3d(-2, 1, 1).normalized();
  constexpr int kSteps = 600, kJump = 500;
  const auto pose_at = [&](int step) {
    const double t = step + (step >= kJump ? 100.0 : 0.0);
    const double slid = 0.01 * margin * std::min(t, 300.0) + 0.15 * margin * std::max(t - 300, 0.0);
    const Eigen::Vector3d direction = Eigen::AngleAxisd(slid / (1.9 * radius), orbit_axis) * orbit_axis.unitOrthogonal();
    const Eigen::Matrix3d turn = Eigen::AngleAxisd(slid / radius, spin_axis).toRotationMatrix();
    const double breathing = 5 * margin * std::sin(2 * std::numbers::pi * t / 150);  // 0.2 margin a step at most
    return RigidPose::of_body(turn, (1.97 * radius - breathing) * direction, Eigen::Vector3d::Zero());
  };
  std::vector<Eigen::Vector3d> x(m.nodes.size()), v = zeros(m.nodes.size());
  std::vector<RigidPose> poses(2, RigidPose::of_body(Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()));
  std::size_t contacts = 0, tested_remembering = 0, tested_searching = 0;
  const double dt = 1e-8;
  for (int step = 0; step < kSteps; ++step) {
    poses[1] = pose_at(step);
    const RigidPose next = pose_at(step + 1);
    // The moving grain's velocities: from this pose to the next in one step.
    poses[1].velocity = (next.centre - poses[1].centre) / dt;
    const Eigen::AngleAxisd turn(Eigen::Matrix3d(next.rotation * poses[1].rotation.transpose()));
    poses[1].angular_velocity = turn.angle() / dt * turn.axis();
    for (std::uint32_t n = 0; n < m.nodes.size(); ++n) {
      const bool moving = n >= m.grains[1].node_begin;
      x[n] = moving ? Eigen::Vector3d(poses[1].rotation * m.nodes[n] + poses[1].translation) : m.nodes[n];
      if (moving) v[n] = (next.rotation * m.nodes[n] + next.translation - x[n]) / dt;
    }
    auto fa = zeros(x.size()), fb = zeros(x.size());
    const ContactStepStats a = remembering.add_forces(x, v, {}, dt, fa, poses);
    const ContactStepStats b = searching.add_forces(x, v, {}, dt, fb, poses);
    ASSERT_TRUE(same_loads(remembering.rigid_loads(), searching.rigid_loads())) << "step " << step;
    ASSERT_EQ(a.node_contacts, b.node_contacts) << step;
    ASSERT_EQ(a.elastic_energy, b.elastic_energy) << step;
    contacts += a.node_contacts;
    tested_remembering += a.triangle_checks;
    tested_searching += b.triangle_checks;
  }
  EXPECT_GT(contacts, 2000u);
  EXPECT_LT(tested_remembering, tested_searching / 3);  // the memos do save searches
}

TEST(ContactModel, MembraneBallMemosGiveTheForcesOfSearchingAnew) {
  // Forty balls around a faceted rigid sphere that turns slowly. Each breathes along its direction
  // between 0.3 of its radius clear of the surface and 0.1 of it pressed in (up to 0.2 memo margin
  // a step), while drifting sideways; at step 450 all jump sideways by half the skin (the ball lists
  // are built again and keep their memos). Forces on the balls and the grain must match searching
  // anew, bit for bit: a ball outside at d keeps its memo only while it moves less than d - its
  // radius (the test fails with d).
  const double radius = 0.5 * kMm, ball = 0.15 * radius;
  const Model m = faceted_spheres(radius, 1);
  ContactOptions anew;
  anew.search_memos = false;
  ContactModel remembering(m, unit_masses(m), {}), searching(m, unit_masses(m), anew);
  const double margin = 0.05 * remembering.skin();  // kMemoMarginFraction
  const double amplitude = 0.2 * ball, omega = 0.2 * margin / amplitude;
  constexpr int kBalls = 40, kSteps = 600, kJump = 450;
  std::vector<Eigen::Vector3d> direction(kBalls);
  for (int b = 0; b < kBalls; ++b) {  // a Fibonacci sphere
    const double z = 1 - (2 * b + 1.0) / kBalls, phi = b * std::numbers::pi * (3 - std::sqrt(5.0));
    direction[b] = Eigen::Vector3d(std::sqrt(1 - z * z) * std::cos(phi), std::sqrt(1 - z * z) * std::sin(phi), z);
  }
  const BallContactOptions ball_options{ball, 1e-9, 0.3};
  const double dt = 1e-8;
  std::vector<Eigen::Vector3d> x(m.nodes.size()), v = zeros(m.nodes.size()), centres(kBalls);
  const std::vector<Eigen::Vector3d> still = zeros(kBalls);
  std::size_t contacts = 0, clear = 0;
  for (int step = 0; step < kSteps; ++step) {
    const Eigen::Matrix3d turn = Eigen::AngleAxisd(2e-4 * step, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix();
    const std::vector<RigidPose> poses = {RigidPose::of_body(turn, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero())};
    for (std::uint32_t n = 0; n < m.nodes.size(); ++n) x[n] = turn * m.nodes[n];
    for (int b = 0; b < kBalls; ++b) {
      const double slid = 0.05 * margin * step + (step >= kJump ? 0.5 * remembering.skin() : 0.0);
      const Eigen::Vector3d side = direction[b].unitOrthogonal();
      const Eigen::Vector3d d = (direction[b] + slid / radius * side).normalized();
      const double gap = 0.1 * ball + amplitude * std::sin(omega * step + b);  // -0.1 to 0.3 of the ball
      centres[b] = (radius + ball + gap) * d;
      clear += gap > 0.05 * ball;
    }
    auto fa = zeros(x.size()), fb = zeros(x.size()), ball_fa = zeros(kBalls), ball_fb = zeros(kBalls),
         moment_a = zeros(kBalls), moment_b = zeros(kBalls);
    remembering.add_forces(x, v, {}, dt, fa, poses);
    searching.add_forces(x, v, {}, dt, fb, poses);
    contacts += add_ball_contacts(remembering.add_ball_forces(x, v, centres, still, still, ball_options, dt, fa), ball_fa, moment_a).contacts;
    add_ball_contacts(searching.add_ball_forces(x, v, centres, still, still, ball_options, dt, fb), ball_fb, moment_b);
    ASSERT_EQ(ball_fa, ball_fb) << "step " << step;
    ASSERT_EQ(moment_a, moment_b) << "step " << step;
    ASSERT_TRUE(same_loads(remembering.rigid_loads(), searching.rigid_loads())) << "step " << step;
  }
  EXPECT_GT(contacts, 5000u);
  EXPECT_GT(clear, 5000u);  // balls clear of the grain, hovering within the search's reach
}

TEST(ContactModel, StableTimeStepIsHalfTheNodeOscillatorLimit) {
  SlidingCube s;
  s.model.materials[0].damping_ratio = 0;
  std::vector<double> mass = unit_masses(s.model);
  ContactModel contact(s.model, mass, {});
  // The largest surface node area on a Kuhn-split 0.25 mm face is a cube corner: 1/3 of its
  // triangles' areas on three faces. Compare with the smallest limit over all nodes brute force.
  double largest = 0;
  for (std::uint32_t n = 0; n < s.model.nodes.size(); ++n) {
    double area = 0;
    for (const auto& t : s.model.triangles)
      if (t[0] == n || t[1] == n || t[2] == n)
        area += 0.5 * (s.model.nodes[t[1]] - s.model.nodes[t[0]]).cross(s.model.nodes[t[2]] - s.model.nodes[t[0]]).norm() / 3;
    largest = std::max(largest, area);
  }
  const double expected = 0.5 * 2 * std::sqrt(1e-6 / (s.model.materials[0].normal_penalty * largest));
  EXPECT_NEAR(contact.stable_time_step(), expected, 1e-12 * expected);
}

TEST(ContactModel, RefusesMassesThatDoNotMatchTheNodes) {
  SlidingCube s;
  EXPECT_THROW(ContactModel(s.model, std::vector<double>(3, 1.0), {}), DataError);
  std::vector<double> mass = unit_masses(s.model);
  mass[s.model.triangles[0][0]] = 0;
  EXPECT_THROW(ContactModel(s.model, mass, {}), DataError);
}

}  // namespace
