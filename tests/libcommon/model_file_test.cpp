// kind=fdem_model files: round trip of a mixed 4/10-node model with materials, platens and sample
// cylinder; refusal of other kinds, of inconsistent models and of values out of their physical
// range (with the file named); shapes2mesh's quality table written and read back; the .vtu and
// .msh views.
#include <gtest/gtest.h>

#include <fstream>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/model_file.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"
#include "support/run_tool.hpp"
#include "support/simulation_results.hpp"
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

TEST(ModelFile, MeshQualityTableIsWrittenAndReadBack) {
  test::TempDir dir;
  const fdem::Model m = two_tet_model();
  // A model without the table (fdemrun's scenes, models made before it existed) reads as none.
  fdem::write_model_file(dir / "none.h5", m, {});
  EXPECT_FALSE(fdem::read_mesh_quality(dir / "none.h5").has_value());
  fdem::MeshQualityTable q;
  q.label = {5, 8};
  q.min_dihedral = {54.7, 12.5};
  q.min_altitude = {0.577e-3, 0.2e-3};
  q.median_altitude = {0.577e-3, 0.5e-3};
  q.worst_element = {0, 1};
  q.step_ratio = {1.0, 0.4};
  q.below_thresholds = {0, 3};
  q.min_dihedral_threshold = 12.0;
  q.min_altitude_ratio_threshold = 0.3;
  fdem::write_model_file(dir / "m.h5", m, {}, [&](io::H5File& f) { fdem::write_mesh_quality(f, q); });
  const auto r = fdem::read_mesh_quality(dir / "m.h5");
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->label, q.label);
  EXPECT_EQ(r->min_dihedral, q.min_dihedral);
  EXPECT_EQ(r->min_altitude, q.min_altitude);
  EXPECT_EQ(r->median_altitude, q.median_altitude);
  EXPECT_EQ(r->worst_element, q.worst_element);
  EXPECT_EQ(r->step_ratio, q.step_ratio);
  EXPECT_EQ(r->below_thresholds, q.below_thresholds);
  EXPECT_EQ(r->min_dihedral_threshold, 12.0);
  EXPECT_EQ(r->min_altitude_ratio_threshold, 0.3);
  EXPECT_EQ(io::H5File::open(dir / "m.h5").attr_string("/mesh/quality/min_altitude", "units").value_or(""), "m");
  // Columns of different lengths are refused before anything is written, and so on reading.
  q.step_ratio.pop_back();
  EXPECT_THROW(fdem::write_model_file(dir / "short.h5", m, {}, [&](io::H5File& f) { fdem::write_mesh_quality(f, q); }), UsageError);
  namespace sq = schema::fdem_model::mesh_quality;
  fdem::write_model_file(dir / "broken.h5", m, {}, [&](io::H5File& f) {  // as a damaged file would hold it
    f.write(sq::label, q.label);
    for (const char* column : {sq::min_dihedral, sq::min_altitude, sq::median_altitude, sq::step_ratio}) f.write(column, q.step_ratio);
    for (const char* column : {sq::worst_element, sq::below_thresholds}) f.write(column, q.worst_element);
    for (const char* threshold : {sq::min_dihedral_threshold, sq::min_altitude_ratio_threshold}) f.set_attr(sq::group, threshold, 0.0);
  });
  EXPECT_THROW(fdem::read_mesh_quality(dir / "broken.h5"), DataError);
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

TEST(ModelFile, ValuesOutOfTheirPhysicalRangeAreRefusedNamingTheFile) {
  // A model file is checked like a scene's [[materials]] (one check for both): a zero Young's
  // modulus, a negative density, a NaN node or a platen without a normal is refused on reading,
  // with the file, the material and the range, before any solver sees it.
  test::TempDir dir;
  const auto good = dir / "good.h5";
  fdem::write_model_file(good, two_tet_model(), {"test"});
  const auto refused = [&](const std::string& name, const std::string& dataset, const std::vector<double>& values,
                           const std::vector<hsize_t>& dims) {
    const auto path = dir / name;
    std::filesystem::copy_file(good, path);
    test::replace_dataset(path, dataset, values, dims);
    try {
      fdem::read_model_file(path);
    } catch (const DataError& e) {
      EXPECT_NE(e.message().find(path.string()), std::string::npos) << e.message();
      return e.message();
    }
    ADD_FAILURE() << name << " was read";
    return std::string();
  };
  const fdem::Material sand, glass = two_tet_model().materials[1];
  std::string message = refused("young.h5", "/materials/young", {sand.young, 0.0}, {2});
  EXPECT_NE(message.find("material 'glass': young must lie in [1000, 1e+13] Pa (got 0 Pa)"), std::string::npos) << message;
  message = refused("density.h5", "/materials/density", {-sand.density, glass.density}, {2});
  EXPECT_NE(message.find("material 'ottawa_sand': density must lie in [1, 1e+10] kg/m^3 (got -2650 kg/m^3)"),
            std::string::npos)
      << message;
  message = refused("poisson.h5", "/materials/poisson", {sand.poisson, std::nan("")}, {2});
  EXPECT_NE(message.find("poisson must lie in (-1, 0.5) (got nan)"), std::string::npos) << message;
  message = refused("penalty.h5", "/materials/normal_penalty", {sand.normal_penalty, 1e300}, {2});
  EXPECT_NE(message.find("normal_penalty must lie in (0, 1e+24] N/m^3"), std::string::npos) << message;
  std::vector<double> nodes;
  for (const Vector3d& p : two_tet_model().nodes) nodes.insert(nodes.end(), {p.x(), p.y(), p.z()});
  nodes[4] = std::numeric_limits<double>::infinity();
  message = refused("node.h5", "/nodes", nodes, {14, 3});
  EXPECT_NE(message.find("node 1 has a coordinate that is not a finite number"), std::string::npos) << message;
  message = refused("platen.h5", "/platens/normal", {0, 0, 1, 0, 0, 0}, {2, 3});
  EXPECT_NE(message.find("platen 'top' needs a finite point, a unit normal"), std::string::npos) << message;
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
