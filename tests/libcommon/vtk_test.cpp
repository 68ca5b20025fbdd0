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
