// VTK XML PolyData writer: checked by VTK's own reader (the one ParaView uses), and bad input.
#include <gtest/gtest.h>

#include "graintwin/core/error.hpp"
#include "graintwin/io/vtk.hpp"
#include "support/run_tool.hpp"
#include "support/vtk_summary.hpp"

using namespace graintwin;

using test::vtk_summary;

TEST(Vtk, PolyDataWithVertsLinesTrianglesAndArraysReadsBackInVtk) {
  test::TempDir dir;
  io::VtkPolyData d;
  d.points = {0, 0, 0, 1e-3, 0, 0, 0, 1e-3, 0, 0, 0, 2e-3};
  d.add_vertices(0, 2);
  d.add_line(0, 3);
  d.add_triangle(0, 1, 2);
  d.point_data.push_back({"normal", 3, {0, 0, 1, 0, 0, 1, 0, 0, 1, 1, 0, 0}});
  d.cell_data.push_back({"label", 1, {7, 8, 9, 10}});
  io::write_vtp(dir / "a.vtp", d);
  const auto s = vtk_summary(dir / "a.vtp");
  EXPECT_EQ(s["points"], 4);
  EXPECT_EQ(s["verts"], 2);
  EXPECT_EQ(s["lines"], 1);
  EXPECT_EQ(s["polys"], 1);
  EXPECT_EQ(s["point_data"]["normal"]["components"], 3);
  EXPECT_EQ(s["cell_data"]["label"]["tuples"], 4);
  EXPECT_DOUBLE_EQ(s["cell_data"]["label"]["range"][1].get<double>(), 10.0);
  EXPECT_DOUBLE_EQ(s["bounds"][5].get<double>(), 2e-3);
}

TEST(Vtk, RefusesInconsistentArrays) {
  test::TempDir dir;
  io::VtkPolyData d;
  d.points = {0, 0, 0, 1, 1, 1};
  d.add_line(0, 2);
  EXPECT_THROW(io::write_vtp(dir / "b.vtp", d), UsageError);
  d.line_connectivity = {0, 1};
  d.cell_data.push_back({"x", 1, {1, 2}});
  EXPECT_THROW(io::write_vtp(dir / "b.vtp", d), UsageError);
}

TEST(Vtk, UnstructuredGridOfLinearAndQuadraticTetsReadsBackInVtk) {
  test::TempDir dir;
  io::VtkUnstructuredGrid g;
  // A unit corner tetrahedron as a 4-node cell and as a 10-node cell (VTK order) over the same points.
  g.points = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, .5, 0, 0, .5, .5, 0, 0, .5, 0, 0, 0, .5, .5, 0, .5, 0, .5, .5};
  g.add_cell(io::kVtkTetra, {0, 1, 2, 3});
  g.add_cell(io::kVtkQuadraticTetra, {0, 1, 2, 3, 4, 5, 6, 7, 8, 9});
  g.point_data.push_back({"u", 3, std::vector<double>(30, 1.0)});
  g.cell_data.push_back({"grain", 1, {3, 4}});
  io::write_vtu(dir / "g.vtu", g);
  const auto s = vtk_summary(dir / "g.vtu");
  EXPECT_EQ(s["points"], 10);
  EXPECT_EQ(s["cells"], 2);
  EXPECT_EQ(s["point_data"]["u"]["components"], 3);
  EXPECT_DOUBLE_EQ(s["cell_data"]["grain"]["range"][1].get<double>(), 4.0);
  EXPECT_DOUBLE_EQ(s["bounds"][5].get<double>(), 1.0);
  // VTK's own volumes: both cells are the corner tetrahedron (a wrong mid-node order gives 1/24).
  EXPECT_NEAR(s["volume"].get<double>(), 2.0 / 6.0, 1e-12);
}

TEST(Vtk, UnstructuredGridRefusesWrongNodeCountsAndTypes) {
  test::TempDir dir;
  io::VtkUnstructuredGrid g;
  g.points = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  g.add_cell(io::kVtkQuadraticTetra, {0, 1, 2, 3});
  EXPECT_THROW(io::write_vtu(dir / "g.vtu", g), UsageError);
  g = {};
  g.points = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  g.add_cell(42, {0, 1, 2, 3});
  EXPECT_THROW(io::write_vtu(dir / "g.vtu", g), UsageError);
  EXPECT_FALSE(std::filesystem::exists(dir / "g.vtu"));
}
