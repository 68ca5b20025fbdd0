// kind=fdem_model files: round trip of a mixed 4/10-node model with materials, platens and sample
// cylinder; refusal of other kinds and of inconsistent models; the .vtu and .msh views.
#include <gtest/gtest.h>

#include <fstream>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/model_file.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/volume_io.hpp"
#include "support/run_tool.hpp"
#include "support/vtk_summary.hpp"

using namespace graintwin;
using Eigen::Vector3d;

namespace {

/// Two grains: one 4-node tetrahedron (label 5) and one 10-node tetrahedron (label 8, rigid).
fdem::Model two_tet_model() {
  fdem::Model m;
  const Vector3d c[4] = {Vector3d(0, 0, 0), Vector3d(1e-3, 0, 0), Vector3d(0, 1e-3, 0), Vector3d(0, 0, 1e-3)};
  for (const Vector3d& p : c) m.nodes.push_back(p);
  const int edges[6][2] = {{0, 1}, {1, 2}, {2, 0}, {3, 0}, {3, 2}, {3, 1}};
  for (const Vector3d& p : c) m.nodes.push_back(p + Vector3d(2e-3, 0, 0));
  for (const auto& e : edges) m.nodes.push_back(0.5 * (m.nodes[4 + static_cast<std::size_t>(e[0])] + m.nodes[4 + static_cast<std::size_t>(e[1])]));
  m.element_nodes = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13};
  m.element_offset = {0, 4, 14};
  m.element_grain = {0, 1};
  m.triangles = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}, {4, 8, 10}};
  m.triangle_grain = {0, 0, 0, 0, 1};
  m.grains = {fdem::Grain{5, fdem::GrainKind::tet4, 0, 0, 4, 0, 1, 0, 4},
              fdem::Grain{8, fdem::GrainKind::rigid, 1, 4, 14, 1, 2, 4, 5}};
  m.materials.push_back(fdem::Material{"glass", 2500, 70e9, 0.22, 0.3, 1e12, 1e12, 0.05});
  m.platens = {fdem::Platen{"bottom", Vector3d(0, 0, -1e-3), Vector3d::UnitZ(), 0.0},
               fdem::Platen{"top", Vector3d(0, 0, 5e-3), -Vector3d::UnitZ(), 0.1}};
  m.sample = fdem::SampleCylinder{{1e-3, 2e-3}, 4e-3, -1e-3, 5e-3, 0.3e-3};
  return m;
}

}  // namespace

TEST(ModelFile, RoundTripKeepsEveryTable) {
  test::TempDir dir;
  const fdem::Model m = two_tet_model();
  fdem::write_model_file(dir / "m.h5", m, {"line one"}, [](io::H5File& f) { f.write("/mesh/extra", std::vector<double>{1, 2}); });
  const fdem::Model r = fdem::read_model_file(dir / "m.h5");
  EXPECT_EQ(r.nodes, m.nodes);
  EXPECT_EQ(r.element_nodes, m.element_nodes);
  EXPECT_EQ(r.element_offset, m.element_offset);
  EXPECT_EQ(r.element_grain, m.element_grain);
  EXPECT_EQ(r.triangles, m.triangles);
  EXPECT_EQ(r.triangle_grain, m.triangle_grain);
  ASSERT_EQ(r.grains.size(), 2u);
  EXPECT_EQ(r.grains[1].label, 8u);
  EXPECT_EQ(r.grains[1].kind, fdem::GrainKind::rigid);
  EXPECT_EQ(r.grains[1].material, 1u);
  EXPECT_EQ(r.grains[1].node_end, 14u);
  ASSERT_EQ(r.materials.size(), 2u);
  EXPECT_EQ(r.materials[1].name, "glass");
  EXPECT_EQ(r.materials[1].damping_ratio, 0.05);
  EXPECT_EQ(r.materials[0].young, fdem::Material{}.young);
  ASSERT_EQ(r.platens.size(), 2u);
  EXPECT_EQ(r.platens[1].normal, -Vector3d::UnitZ());
  EXPECT_EQ(r.platens[1].friction, 0.1);
  ASSERT_TRUE(r.sample.has_value());
  EXPECT_EQ(r.sample->axis_xy, m.sample->axis_xy);
  EXPECT_EQ(r.sample->z_max, 5e-3);
  EXPECT_EQ(r.sample->membrane_thickness, 0.3e-3);
  const io::H5File f = io::H5File::open(dir / "m.h5");
  EXPECT_EQ(f.info("/elements").dims, (std::vector<hsize_t>{2, 10}));
  EXPECT_EQ(f.read<std::uint32_t>("/elements")[4], 4294967295u);  // 4-node row padded
  EXPECT_TRUE(f.exists("/mesh/extra"));
}

TEST(ModelFile, AllLinearModelsStoreFourColumnsAndNoSampleIsAllowed) {
  test::TempDir dir;
  fdem::Model m = two_tet_model();
  m.element_nodes.resize(8);
  m.element_offset = {0, 4, 8};
  m.nodes.resize(8);
  m.grains[1].node_end = 8;
  m.grains[1].kind = fdem::GrainKind::tet4;
  m.triangles.back() = {4, 6, 5};
  m.sample.reset();
  fdem::write_model_file(dir / "m.h5", m, {});
  EXPECT_EQ(io::H5File::open(dir / "m.h5").info("/elements").dims, (std::vector<hsize_t>{2, 4}));
  const fdem::Model r = fdem::read_model_file(dir / "m.h5");
  EXPECT_FALSE(r.sample.has_value());
  EXPECT_EQ(r.element_nodes, m.element_nodes);
}

TEST(ModelFile, RefusesOtherKindsAndBrokenModels) {
  test::TempDir dir;
  {
    io::H5File f = io::H5File::create(dir / "shapes.h5");
    io::write_root_attrs(f, "shapes");
  }
  try {
    fdem::read_model_file(dir / "shapes.h5");
    FAIL() << "a shapes file was read as a model";
  } catch (const UsageError& e) {
    EXPECT_NE(e.message().find("shapes2mesh"), std::string::npos) << e.message();
  }
  fdem::Model m = two_tet_model();
  m.element_nodes[2] = 9;  // grain 0 using a node of grain 1
  EXPECT_THROW(fdem::write_model_file(dir / "bad.h5", m, {}), DataError);
  m = two_tet_model();
  m.grains[1].node_begin = 5;  // a gap in the node ranges
  EXPECT_THROW(fdem::validate_model(m, "m"), DataError);
  m = two_tet_model();
  m.grains[0].material = 4;
  EXPECT_THROW(fdem::validate_model(m, "m"), DataError);
}

TEST(ModelFile, VtuAndMshViews) {
  test::TempDir dir;
  const fdem::Model m = two_tet_model();
  io::write_vtu(dir / "m.vtu", fdem::model_grid(m));
  const auto s = test::vtk_summary(dir / "m.vtu");
  EXPECT_EQ(s["points"], 14);
  EXPECT_EQ(s["cells"], 2);
  EXPECT_EQ(s["cell_data"]["label"]["range"][1], 8.0);
  EXPECT_EQ(s["point_data"]["grain"]["tuples"], 14);
  // gmsh's node order mapped to VTK's: VTK measures both straight tetrahedra at their true volume.
  EXPECT_NEAR(s["volume"].get<double>(), 2.0 * 1e-9 / 6.0, 1e-21);
  // Displaced positions (a frame): the grid follows them.
  std::vector<Vector3d> moved = m.nodes;
  for (auto& p : moved) p.z() += 1.0;
  io::write_vtu(dir / "f.vtu", fdem::model_grid(m, moved));
  EXPECT_DOUBLE_EQ(test::vtk_summary(dir / "f.vtu")["bounds"][4].get<double>(), 1.0);

  fdem::write_model_msh(dir / "m.msh", m);
  std::ifstream in(dir / "m.msh");
  std::string line;
  std::vector<std::string> lines;
  while (std::getline(in, line)) lines.push_back(line);
  ASSERT_GT(lines.size(), 10u);
  EXPECT_EQ(lines[1], "2.2 0 8");
  EXPECT_EQ(lines[4], "14");
  EXPECT_EQ(lines[21], "7");  // 2 tetrahedra + 5 triangles
  EXPECT_EQ(lines[22], "1 4 2 5 1 1 2 3 4");
  EXPECT_EQ(lines[23].substr(0, 10), "2 11 2 8 2");
}
