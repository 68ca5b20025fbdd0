// mesh/sliver_removal and the element measures it works with: dihedral angles and altitudes of
// known tetrahedra (the altitude as fdemrun measures it); a sliver planted among a gmsh mesh's
// interior nodes, and one whose four corners all lie on the boundary, removed to the thresholds
// with the boundary, the volume and (10-node) the curved boundary kept; a cap and a needle planted
// on the boundary, lifted by sliding boundary nodes along the surface (which stay on it) and left
// without a surface to slide on; thresholds honoured, and one no element can reach leaving a valid
// mesh and the count of what stays below.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>

#include "graintwin/fdem/element.hpp"
#include "graintwin/mesh/gmsh_adapter.hpp"
#include "graintwin/mesh/sliver_removal.hpp"
#include "graintwin/mesh/tet_mesh.hpp"

using namespace graintwin;
using Eigen::Vector3d;

namespace {

/// The boundary as a set of triangles of node positions (rounded to 1e-15 m), whatever the node numbering.
std::set<std::vector<double>> boundary_positions(const mesh::TetMesh& m) {
  std::set<std::vector<double>> out;
  for (const auto& t : mesh::boundary_triangles(m)) {
    std::vector<std::array<double, 3>> corners;
    for (const std::uint32_t v : t)
      corners.push_back({std::round(m.nodes[v].x() * 1e15), std::round(m.nodes[v].y() * 1e15), std::round(m.nodes[v].z() * 1e15)});
    std::rotate(corners.begin(), std::min_element(corners.begin(), corners.end()), corners.end());  // keeps orientation
    std::vector<double> key;
    for (const auto& c : corners) key.insert(key.end(), c.begin(), c.end());
    out.insert(key);
  }
  return out;
}

void expect_positive(const mesh::TetMesh& m) {
  for (std::size_t e = 0; e < m.element_count(); ++e) {
    const std::uint32_t* n = m.element(e);
    ASSERT_GT(mesh::tet_min_altitude(m.nodes[n[0]], m.nodes[n[1]], m.nodes[n[2]], m.nodes[n[3]]), 0.0) << "element " << e;
    ASSERT_GT(mesh::jacobian_ratio(m, e), 0.0) << "element " << e;
  }
}

/// A mesh of a ball of radius 1 mm from gmsh (in this process).
mesh::TetMesh ball(int order) {
  mesh::TetOptions o;
  o.size = 0.35e-3, o.order = order;
  return mesh::mesh_ellipsoid(Vector3d::Zero(), Vector3d::Constant(1e-3), Eigen::Quaterniond::Identity(), o);
}

/// Moves an interior node most of the way to the plane of the face opposite it in one of its
/// elements, where every element around it stays positive: a sliver among interior nodes.
void plant_interior_sliver(mesh::TetMesh& m) {
  std::vector<char> boundary(m.nodes.size(), 0);
  for (const auto& t : mesh::boundary_triangles(m))
    for (const std::uint32_t v : t) boundary[v] = 1;
  const auto all_positive = [&] {
    for (std::size_t e = 0; e < m.element_count(); ++e) {
      const std::uint32_t* n = m.element(e);
      if (!(mesh::tet_min_altitude(m.nodes[n[0]], m.nodes[n[1]], m.nodes[n[2]], m.nodes[n[3]]) > 0.0)) return false;
    }
    return true;
  };
  for (std::size_t e = 0; e < m.element_count(); ++e)
    for (int k = 0; k < 4; ++k) {
      const std::uint32_t* n = m.element(e);
      const std::uint32_t v = n[k];
      if (boundary[v]) continue;
      const Vector3d& a = m.nodes[n[(k + 1) % 4]];
      const Vector3d normal = (m.nodes[n[(k + 2) % 4]] - a).cross(m.nodes[n[(k + 3) % 4]] - a).normalized();
      const Vector3d start = m.nodes[v];
      m.nodes[v] -= 0.93 * normal.dot(start - a) * normal;
      if (all_positive()) return;
      m.nodes[v] = start;
    }
  FAIL() << "no interior node could be moved into a sliver";
}

/// Adds straight mid-edge nodes (gmsh order) to a linear mesh.
mesh::TetMesh quadratic(const mesh::TetMesh& linear) {
  mesh::TetMesh m;
  m.nodes = linear.nodes;
  m.nodes_per_element = 10;
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> mid;
  for (std::size_t e = 0; e < linear.element_count(); ++e) {
    const std::uint32_t* n = linear.element(e);
    m.elements.insert(m.elements.end(), n, n + 4);
    for (const auto& edge : fdem::kTet10Edges) {
      const std::uint32_t a = n[edge[0]], b = n[edge[1]];
      const auto [it, added] = mid.emplace(std::make_pair(std::min(a, b), std::max(a, b)), static_cast<std::uint32_t>(m.nodes.size()));
      if (added) m.nodes.push_back(0.5 * (linear.nodes[a] + linear.nodes[b]));
      m.elements.push_back(it->second);
    }
  }
  return m;
}

/// Five boundary points and three elements: a roof of two triangles over a ridge (a b) slightly
/// above c and d, and a point q below. The element (a b c d) under the roof is a sliver whose four
/// corners, and two of its faces, lie on the boundary: no interior node to move.
mesh::TetMesh roof() {
  mesh::TetMesh m;
  m.nodes = {Vector3d(-1, 0, 0.04), Vector3d(1, 0, 0.04), Vector3d(0, -1, 0), Vector3d(0, 1, 0), Vector3d(0, 0, -1)};
  for (auto& p : m.nodes) p *= 1e-3;
  const auto positive = [&](std::array<std::uint32_t, 4> t) {
    const Vector3d& a = m.nodes[t[0]];
    if ((m.nodes[t[1]] - a).cross(m.nodes[t[2]] - a).dot(m.nodes[t[3]] - a) < 0) std::swap(t[1], t[2]);
    m.elements.insert(m.elements.end(), t.begin(), t.end());
  };
  positive({0, 1, 2, 3});
  positive({0, 2, 3, 4});
  positive({1, 2, 3, 4});
  return m;
}

constexpr double kBallRadius = 1e-3;
Vector3d onto_ball(const Vector3d& p) { return kBallRadius * p.normalized(); }

/// The smallest height of any boundary triangle over the mesh's median element altitude.
double worst_boundary_height(const mesh::TetMesh& m) {
  double worst = std::numeric_limits<double>::infinity();
  for (const auto& t : mesh::boundary_triangles(m)) {
    const Vector3d &a = m.nodes[t[0]], &b = m.nodes[t[1]], &c = m.nodes[t[2]];
    const double longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
    worst = std::min(worst, (b - a).cross(c - a).norm() / longest);
  }
  return worst / mesh::median_altitude(m);
}

/// Slides one boundary node of a gmsh ball along the sphere towards the middle of the opposite
/// edge of one of its boundary triangles (a cap) or towards one of that edge's ends (a needle),
/// until that triangle's height is under 0.12 of the median element altitude with every element
/// still positive: the element on it is then a sliver that no interior operation can lift.
void plant_boundary_sliver(mesh::TetMesh& m, bool needle) {
  const auto all_positive = [&] {
    for (std::size_t e = 0; e < m.element_count(); ++e) {
      const std::uint32_t* n = m.element(e);
      if (!(mesh::tet_min_altitude(m.nodes[n[0]], m.nodes[n[1]], m.nodes[n[2]], m.nodes[n[3]]) > 0.0)) return false;
    }
    return true;
  };
  for (const auto& t : mesh::boundary_triangles(m)) {
    const std::uint32_t c = t[2];
    const Vector3d start = m.nodes[c];
    const Vector3d target = needle ? m.nodes[t[0]] : Vector3d(0.5 * (m.nodes[t[0]] + m.nodes[t[1]]));
    for (double share = 0.5; share < 0.995; share += 0.005) {
      m.nodes[c] = onto_ball(start + share * (target - start));
      if (!all_positive()) break;
      if (worst_boundary_height(m) < 0.12) return;
    }
    m.nodes[c] = start;
  }
  FAIL() << "no boundary node could be slid into a " << (needle ? "needle" : "cap");
}

}  // namespace

TEST(SliverMeasures, DihedralAndAltitudeOfKnownTetrahedra) {
  const Vector3d o(0, 0, 0), x(1, 0, 0), y(0, 1, 0), z(0, 0, 1);
  // The corner tetrahedron: right angles at the axes, acos(1/sqrt(3)) where the slanted face meets them.
  EXPECT_NEAR(mesh::tet_min_dihedral_degrees(o, x, y, z), std::acos(1 / std::sqrt(3.0)) * 180 / M_PI, 1e-9);
  EXPECT_NEAR(mesh::tet_min_altitude(o, x, y, z), 1 / std::sqrt(3.0), 1e-12);  // to the slanted face
  const Vector3d a(1, 1, 1), b(1, -1, -1), c(-1, 1, -1), d(-1, -1, 1);  // regular
  EXPECT_NEAR(mesh::tet_min_dihedral_degrees(a, b, c, d), std::acos(1.0 / 3.0) * 180 / M_PI, 1e-9);
  EXPECT_NEAR(mesh::tet_min_altitude(a, c, b, d), 2 * std::sqrt(2.0) * std::sqrt(2.0 / 3.0), 1e-12);  // edge 2 sqrt(2)
  EXPECT_LT(mesh::tet_min_altitude(a, b, c, d), 0.0);  // the same corners inverted
  // A flat one: four corners in a plane.
  EXPECT_NEAR(mesh::tet_min_dihedral_degrees(o, x, y, Vector3d(1, 1, 0)), 0.0, 1e-6);
  // The altitude fdemrun's element step uses, element by element of a gmsh ball.
  const mesh::TetMesh m = ball(2);
  fdem::Model model;
  mesh::append_grain(model, m, 1, fdem::GrainKind::tet10);
  for (std::size_t e = 0; e < m.element_count(); ++e) {
    const std::uint32_t* n = m.element(e);
    EXPECT_NEAR(mesh::tet_min_altitude(m.nodes[n[0]], m.nodes[n[1]], m.nodes[n[2]], m.nodes[n[3]]), fdem::element_min_altitude(model, e),
                1e-15);
  }
}

TEST(SliverRemoval, PlantedInteriorSliverIsRemovedKeepingTheBoundaryAndTheVolume) {
  for (const int order : {1, 2}) {
    mesh::TetMesh m = ball(1);
    plant_interior_sliver(m);
    if (order == 2) m = quadratic(m);
    const mesh::SliverThresholds t{12.0, 0.25};
    const mesh::MeshQuality before = mesh::mesh_quality(m, 0.1, t);
    ASSERT_GE(before.below_thresholds, 1u);
    const auto surface = boundary_positions(m);
    const double volume = mesh::mesh_volume(m);
    const mesh::SliverReport r = mesh::remove_slivers(m, t);
    EXPECT_EQ(r.before, before.below_thresholds);
    EXPECT_EQ(r.after, 0u) << "order " << order;
    EXPECT_GE(r.moved + r.flips + r.splits, 1u);
    const mesh::MeshQuality after = mesh::mesh_quality(m, 0.1, t);
    EXPECT_EQ(after.below_thresholds, 0u);
    EXPECT_GE(after.min_dihedral, 12.0);
    EXPECT_GT(after.min_altitude / after.median_altitude, 0.25 * 0.9);  // the pass measures against the median it started from
    EXPECT_GT(after.min_altitude, 3 * before.min_altitude);
    expect_positive(m);
    EXPECT_EQ(boundary_positions(m), surface);
    EXPECT_NEAR(mesh::mesh_volume(m), volume, 1e-9 * volume);
  }
}

TEST(SliverRemoval, SliverWithEveryCornerOnTheBoundaryIsFlippedAway) {
  for (const int order : {1, 2}) {
    mesh::TetMesh m = order == 1 ? roof() : quadratic(roof());
    if (order == 2) m.nodes[m.elements[4]] += Vector3d(0, 0, 0.01e-3);  // a boundary edge of the sliver, curved: it must stay so
    const mesh::SliverThresholds t{0.0, 0.25};
    ASSERT_EQ(mesh::mesh_quality(m, 0.1, t).below_thresholds, 1u);
    const auto surface = boundary_positions(m);
    const mesh::SliverReport r = mesh::remove_slivers(m, t);
    EXPECT_EQ(r.after, 0u);
    EXPECT_EQ(r.flips, 1u);
    EXPECT_EQ(m.element_count(), 2u);  // three elements around the interior edge (c d) become two
    expect_positive(m);
    EXPECT_EQ(boundary_positions(m), surface);
  }
}

TEST(SliverRemoval, ThresholdsAreHonouredAndAnUnreachableOneLeavesAValidMesh) {
  mesh::TetMesh m = ball(1);
  plant_interior_sliver(m);
  const mesh::TetMesh planted = m;
  // Nothing asked: nothing changes.
  EXPECT_EQ(mesh::remove_slivers(m, {}).before, 0u);
  EXPECT_EQ(m.nodes, planted.nodes);
  EXPECT_EQ(m.elements, planted.elements);
  // The dihedral threshold alone.
  const mesh::SliverReport r = mesh::remove_slivers(m, {15.0, 0.0});
  EXPECT_GE(r.before, 1u);
  EXPECT_EQ(r.after, 0u);
  EXPECT_GE(mesh::mesh_quality(m, 0.1).min_dihedral, 15.0);
  // 60 degrees everywhere cannot be had (the regular tetrahedron's 70.5 degrees do not fill space):
  // what stays below is counted, and the mesh stays valid with its boundary.
  m = planted;
  const auto surface = boundary_positions(m);
  const double volume = mesh::mesh_volume(m);
  const mesh::SliverReport impossible = mesh::remove_slivers(m, {60.0, 0.0});
  EXPECT_GT(impossible.after, 0u);
  EXPECT_EQ(impossible.after, mesh::mesh_quality(m, 0.1, {60.0, 0.0}).below_thresholds);
  expect_positive(m);
  EXPECT_EQ(boundary_positions(m), surface);
  EXPECT_NEAR(mesh::mesh_volume(m), volume, 1e-9 * volume);
}

TEST(SliverRemoval, CapAndNeedleOnTheBoundaryAreLiftedBySlidingAlongTheSurface) {
  for (const bool needle : {false, true})
    for (const int order : {1, 2}) {
      SCOPED_TRACE(fmt::format("{}, {}-node", needle ? "needle" : "cap", order == 1 ? 4 : 10));
      mesh::TetMesh planted = ball(1);
      plant_boundary_sliver(planted, needle);
      if (order == 2) {
        planted = quadratic(planted);
        for (const auto& t : mesh::boundary_triangles(planted))  // a curved boundary, as snapping leaves it
          for (const std::uint32_t v : t) planted.nodes[v] = onto_ball(planted.nodes[v]);
      }
      const mesh::SliverThresholds t{0.0, 0.3};
      ASSERT_GE(mesh::mesh_quality(planted, 0.1, t).below_thresholds, 1u);
      // Without a surface the boundary stays, and so does the sliver on it.
      mesh::TetMesh kept = planted;
      const mesh::SliverReport stuck = mesh::remove_slivers(kept, t);
      EXPECT_GE(stuck.after, 1u);
      EXPECT_EQ(stuck.slid, 0u);
      EXPECT_EQ(boundary_positions(kept), boundary_positions(planted));
      // With the sphere: lifted, its nodes still on it, the volume changed by what is reported.
      mesh::TetMesh m = planted;
      const double volume = mesh::mesh_volume(m);
      const mesh::SliverReport r = mesh::remove_slivers(m, t, onto_ball);
      EXPECT_EQ(r.after, 0u);
      EXPECT_GE(r.slid, 1u);
      EXPECT_EQ(r.peeled, 0u);
      EXPECT_GE(mesh::mesh_quality(m, 0.1).min_altitude / mesh::median_altitude(planted), 0.3 * 0.999);
      expect_positive(m);
      for (const auto& tri : mesh::boundary_triangles(m))
        for (const std::uint32_t v : tri) EXPECT_NEAR(m.nodes[v].norm(), kBallRadius, 1e-12 * kBallRadius) << "node " << v;
      if (order == 1) EXPECT_NEAR(mesh::mesh_volume(m) - volume, r.slid_volume, 1e-9 * volume);
      EXPECT_LT(std::abs(mesh::mesh_volume(m) - volume), 2e-3 * volume);
    }
}
