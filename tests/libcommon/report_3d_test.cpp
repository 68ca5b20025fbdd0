// The report's 3D pictures: the force-chain network (report/force_network: a frame's contacts
// that push their grains apart become segments between the grains' centroids, with their normal
// forces; the strong network keeps those at or above the mean force), the camera box of the
// D2min clusters and the front quarter cut from eps_q's (report/clusters_3d), the grains' posed
// and simplified surfaces (report/surfaces_3d) and the run's ParaView state (report/paraview_state).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <limits>
#include <map>
#include <numbers>

#include "graintwin/fdem/element.hpp"
#include "graintwin/report/clusters_3d.hpp"
#include "graintwin/report/force_network.hpp"
#include "graintwin/report/paraview_state.hpp"
#include "graintwin/report/surfaces_3d.hpp"
#include "support/simulation_results.hpp"

using namespace graintwin;
using namespace graintwin::report;

TEST(ReportForceNetwork, CompressiveContactsRunFromCentroidToCentroid) {
  const std::vector<Eigen::Vector3d> centroid{{0, 0, 0}, {1, 0, 0}, {0, 0, 2}};
  micro::FrameContacts contacts;
  contacts.pair = {{0, 1}, {0, 2}, {1, 2}};
  contacts.normal = {Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitX()};
  contacts.normal_force = {3.0, 0.0, -1.0};  // pushing, touching without force, pulling
  const ForceNetwork n = force_network(centroid, contacts);
  ASSERT_EQ(n.force.size(), 1u) << "only contacts pushing their grains apart carry a chain";
  EXPECT_EQ(n.force[0], 3.0);
  EXPECT_EQ(n.from[0], centroid[0]);
  EXPECT_EQ(n.to[0], centroid[1]);
}

TEST(ReportForceNetwork, TheStrongNetworkKeepsTheContactsAtOrAboveTheMeanForce) {
  ForceNetwork n;
  for (double f : {1.0, 2.0, 3.0, 6.0}) n.from.emplace_back(f, 0, 0), n.to.emplace_back(f, 1, 0), n.force.push_back(f);
  const ForceNetwork strong = strong_network(n);  // mean 3
  ASSERT_EQ(strong.force, (std::vector<double>{3.0, 6.0}));
  EXPECT_EQ(strong.from[1], Eigen::Vector3d(6, 0, 0));
  EXPECT_TRUE(strong_network(ForceNetwork{}).force.empty());
}

TEST(ReportClusters3d, TheCameraBoxHoldsEverySphereWhole) {
  const double inf = std::numeric_limits<double>::infinity();
  const auto b = sphere_bounds({0, 0, 0, 4, 1, -2}, {1.0, 0.5}, {inf, -inf, inf, -inf, inf, -inf});
  EXPECT_EQ(b, (std::array<double, 6>{-1.0, 4.5, -1.0, 1.5, -2.5, 1.0}));
  EXPECT_EQ(sphere_bounds({}, {}, b), b);
}

namespace {

/// A closed UV sphere of radius r: `rings` bands of `sectors` quads (split in two), poles as fans.
TriangleSurface uv_sphere(double r, int rings, int sectors) {
  TriangleSurface s;
  s.vertices.emplace_back(0, 0, r);
  for (int i = 1; i < rings; ++i)
    for (int j = 0; j < sectors; ++j) {
      const double theta = std::numbers::pi * i / rings, phi = 2 * std::numbers::pi * j / sectors;
      s.vertices.emplace_back(r * std::sin(theta) * std::cos(phi), r * std::sin(theta) * std::sin(phi), r * std::cos(theta));
    }
  s.vertices.emplace_back(0, 0, -r);
  const auto at = [&](int ring, int j) { return std::uint32_t(1 + (ring - 1) * sectors + (j % sectors)); };
  const std::uint32_t south = std::uint32_t(s.vertices.size() - 1);
  for (int j = 0; j < sectors; ++j) {
    s.triangles.push_back({0, at(1, j), at(1, j + 1)});
    for (int i = 1; i + 1 < rings; ++i) {
      s.triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
      s.triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
    }
    s.triangles.push_back({at(rings - 1, j), south, at(rings - 1, j + 1)});
  }
  return s;
}

/// How many triangles use each undirected edge.
std::map<std::pair<std::uint32_t, std::uint32_t>, int> edge_uses(const TriangleSurface& s) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> uses;
  for (const auto& t : s.triangles)
    for (int e = 0; e < 3; ++e) ++uses[std::minmax(t[e], t[(e + 1) % 3])];
  return uses;
}

}  // namespace

TEST(ReportSurfaces3d, VertexClusteringKeepsASphereClosedAndRoundWithTheTriangleCountAsked) {
  const double r = 1e-3;
  const TriangleSurface fine = uv_sphere(r, 60, 120);  // 14 160 triangles
  const double area = surface_area(fine.vertices, fine.triangles);
  EXPECT_NEAR(area, 4 * std::numbers::pi * r * r, 0.01 * area);
  const TriangleSurface coarse = cluster_vertices(fine.vertices, fine.triangles, clustering_cell(area, 400));
  EXPECT_GT(coarse.triangles.size(), 200u);
  EXPECT_LT(coarse.triangles.size(), 800u) << "about the 400 asked";
  for (const auto& [edge, uses] : edge_uses(coarse)) EXPECT_EQ(uses % 2, 0) << "an open edge: the surface has a hole";
  for (const Eigen::Vector3d& v : coarse.vertices) EXPECT_NEAR(v.norm(), r, 0.08 * r) << "a cluster's mean lies near the sphere";
  EXPECT_NEAR(surface_area(coarse.vertices, coarse.triangles), area, 0.1 * area);
}

TEST(ReportSurfaces3d, TheEnclosedCentroidIsTheSolidsNotTheSurfaces) {
  // A sphere moved off the origin: its centre (the UV sphere is symmetric), whatever its triangles' sizes.
  TriangleSurface s = uv_sphere(2.0, 12, 7);
  for (Eigen::Vector3d& v : s.vertices) v += Eigen::Vector3d(5, -3, 1);
  EXPECT_NEAR((enclosed_centroid(s.vertices, s.triangles) - Eigen::Vector3d(5, -3, 1)).norm(), 0.0, 1e-12);
  // A cube with one face split finely: the solid's centre, where the surface's area centroid moves.
  const std::vector<Eigen::Vector3d> v{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}, {0.5, 0.5, 1}};
  const std::vector<std::array<std::uint32_t, 3>> t{{0, 2, 1}, {0, 3, 2}, {0, 1, 5}, {0, 5, 4}, {1, 2, 6}, {1, 6, 5},
                                                    {2, 3, 7}, {2, 7, 6}, {3, 0, 4}, {3, 4, 7}, {4, 5, 8}, {5, 6, 8}, {6, 7, 8}, {7, 4, 8}};
  EXPECT_NEAR((enclosed_centroid(v, t) - Eigen::Vector3d(0.5, 0.5, 0.5)).norm(), 0.0, 1e-15);
}

TEST(ReportSurfaces3d, CellsSmallerThanEveryEdgeLeaveTheSurfaceAsItIs) {
  const TriangleSurface s = uv_sphere(1.0, 6, 8);
  const TriangleSurface same = cluster_vertices(s.vertices, s.triangles, 1e-3);
  ASSERT_EQ(same.triangles.size(), s.triangles.size());
  for (std::size_t t = 0; t < s.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(same.vertices[same.triangles[t][k]], s.vertices[s.triangles[t][k]]);
}

TEST(ReportSurfaces3d, GrainsArePosedAtTheirFrameAndTheFrontQuarterIsCutAway) {
  test::LatticeRun run;  // 64 rigid 1 mm cubes on a 1.5 mm lattice, sites 0 to 4.5 mm
  const fdem::Model model = test::lattice_model(run);
  const std::vector<Eigen::Vector3d> reference = grain_surface_centroids(model);
  FramePose pose;
  for (std::size_t g = 0; g < model.grains.size(); ++g) {
    // Straight-sided grains: the enclosed solid's centroid is the solver's, to rounding.
    EXPECT_NEAR((reference[g] - fdem::body_properties(model, g).centroid).norm(), 0.0, 1e-15) << g;
    pose.centroid.push_back(reference[g]), pose.rotation.emplace_back(1.0, 0.0, 0.0, 0.0);
  }
  // Grain 5 (site (1.5, 1.5, 0) mm) turned 90 degrees about z and moved up by 0.1 mm.
  const Eigen::Quaterniond turn(Eigen::AngleAxisd(std::numbers::pi / 2, Eigen::Vector3d::UnitZ()));
  pose.rotation[5] = {turn.w(), turn.x(), turn.y(), turn.z()};
  pose.centroid[5] += Eigen::Vector3d(0, 0, 1e-4);
  const FrontQuarter cut{2.25e-3, 2.25e-3};  // x above, y below the lattice's middle: sites x, y in {3, 4.5} x {0, 1.5} mm
  EXPECT_TRUE(cut.holds(3e-3, 0.0));
  EXPECT_FALSE(cut.holds(1.5e-3, 0.0));
  EXPECT_FALSE(cut.holds(3e-3, 3e-3));
  const SurfacesView v = posed_surfaces(model, reference, pose, cut, kSurfaceTriangleBudget);
  EXPECT_EQ(v.grains_cut, 16u) << "4 columns of 4 cubes in front of the axis";
  EXPECT_EQ(v.grains, 48u);
  const std::size_t per_cube = model.grains[0].triangle_end - model.grains[0].triangle_begin;
  EXPECT_EQ(v.triangles.size(), 3 * 48 * per_cube) << "cubes are far below their share of the budget: drawn whole";
  EXPECT_EQ(v.source_triangles, 48 * per_cube);
  ASSERT_EQ(v.label.size(), v.triangles.size() / 3);
  std::map<std::uint32_t, int> triangles_of;
  for (std::uint32_t l : v.label) ++triangles_of[l];
  EXPECT_EQ(triangles_of.count(test::lattice_label(3)), 0u) << "grain 3 sits at (4.5, 0, 0) mm, in the cut";
  EXPECT_EQ(triangles_of[test::lattice_label(5)], int(per_cube));
  // Every vertex of grain 5 is its reference vertex turned about the cube's centre and lifted.
  const Eigen::Vector3d centre = test::lattice_site(run, 5);
  for (std::size_t t = 0; t < v.label.size(); ++t) {
    if (v.label[t] != test::lattice_label(5)) continue;
    for (int k = 0; k < 3; ++k) {
      const float* p = &v.vertices[3 * v.triangles[3 * t + k]];
      const Eigen::Vector3d local = Eigen::Vector3d(p[0], p[1], p[2]) - centre - Eigen::Vector3d(0, 0, 1e-4);
      EXPECT_NEAR(std::abs(local.x()), 0.5e-3, 1e-9);  // still a cube of its size about its new centre
      EXPECT_NEAR(std::abs(local.y()), 0.5e-3, 1e-9);
      EXPECT_NEAR(std::abs(local.z()), 0.5e-3, 1e-9);
    }
  }
  EXPECT_NEAR(v.bounds[5], 4.5e-3 + 0.5e-3, 1e-9);
}

TEST(ReportClusters3d, TheFrontQuarterCutRemovesItsGrainsAndMembraneBalls) {
  GrainsView v;
  v.centre = {1, -1, 0, -1, -1, 0, 1, 1, 0, 2, -3, 5};
  v.radius = {0.1, 0.2, 0.3, 0.4}, v.value = {1, 2, 3, 4}, v.highlighted = {1, 1, 0, 1};
  v.membrane = {3, -3, 0, -3, -3, 0};
  cut_front_quarter(v, {0.0, 0.0});
  EXPECT_EQ(v.centre, (std::vector<double>{-1, -1, 0, 1, 1, 0}));
  EXPECT_EQ(v.radius, (std::vector<double>{0.2, 0.3}));
  EXPECT_EQ(v.value, (std::vector<double>{2, 3}));
  EXPECT_EQ(v.highlighted, (std::vector<std::uint8_t>{1, 0}));
  EXPECT_EQ(v.membrane, (std::vector<double>{-3, -3, 0}));
}

TEST(ReportParaviewState, EverySourceHasItsReaderRepresentationAndViewAndTheSeriesFollowTime) {
  std::vector<StateSource> sources(3);
  sources[0] = {"scan_000 grains", "scan_000/grains.vtp", "XMLPolyDataReader"};
  sources[1] = {"twin frames", "simulation_frames/frames.pvd", "PVDReader"};
  sources[1].view = 1;
  sources[2] = {"force chains", "force_chains/chains.pvd", "PVDReader"};
  sources[2].view = 1, sources[2].colour_by = "normalised_force", sources[2].colour_range = {1.0, 4.0};
  const std::string xml = paraview_state_xml(sources, {0, 1e-3, 0, 1e-3, 0, 2e-3});
  const auto count = [&](const std::string& what) {
    std::size_t n = 0;
    for (std::size_t at = xml.find(what); at != std::string::npos; at = xml.find(what, at + 1)) ++n;
    return n;
  };
  EXPECT_EQ(count("<Proxy group=\"sources\""), 3u);
  EXPECT_EQ(count("<Proxy group=\"representations\" type=\"GeometryRepresentation\""), 3u);
  EXPECT_EQ(count("value=\"scan_000/grains.vtp\""), 1u) << "relative paths, as given";
  EXPECT_EQ(count("<Proxy group=\"lookup_tables\""), 1u) << "only the chains are painted by a value";
  // The scans' view shows the grains, the twin's the frames and chains; the time keeper follows both series.
  EXPECT_NE(xml.find("<Property name=\"Representations\" id=\"400.Representations\" number_of_elements=\"1\">\n        <Proxy value=\"200\"/>"),
            std::string::npos);
  EXPECT_NE(xml.find("<Property name=\"Representations\" id=\"401.Representations\" number_of_elements=\"2\">\n        <Proxy value=\"201\"/>\n        <Proxy value=\"202\"/>"),
            std::string::npos);
  EXPECT_NE(xml.find("<Property name=\"TimeSources\" id=\"500.TimeSources\" number_of_elements=\"2\">\n        <Proxy value=\"101\"/>\n        <Proxy value=\"102\"/>"),
            std::string::npos);
  EXPECT_EQ(count("<Item direction=\"0\""), 2u) << "two views side by side";
  EXPECT_EQ(xml.rfind("</ParaView>\n"), xml.size() - 12);
}
