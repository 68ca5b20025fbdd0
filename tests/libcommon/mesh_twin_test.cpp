// mesh/twin (shapes2mesh's stage): the scan cylinder's height within the image and the solid
// fraction, the equivalent packing's options completed from the scan (and refused without a
// cylinder or above what packs), model and source labels of grains in place and of a sample,
// grains meshed in parallel into their own rows and placed at their poses, the model assembled
// with its counts, the sample cylinder's precedence, and the /mesh table written and read back.
#include <gtest/gtest.h>

#include <cmath>

#include "graintwin/core/error.hpp"
#include "graintwin/mesh/twin.hpp"
#include "graintwin/synth/packing.hpp"
#include "support/run_tool.hpp"
#include "support/sh_grain.hpp"

using namespace graintwin;
using namespace graintwin::mesh;
using Eigen::Vector3d;

namespace {

/// A scan of 10 x 4 x 4 voxels of 1 mm whose first voxel is centred at z = 1 mm: its voxel faces
/// span z from 0.5 mm to 10.5 mm.
Volume<std::uint32_t> scan_image() { return Volume<std::uint32_t>({10, 4, 4}, {1e-3, 1e-3, 1e-3}, {1e-3, 0.0, 0.0}); }

std::vector<shape::GrainShape> grains_of_volumes(const std::vector<double>& volumes) {
  std::vector<shape::GrainShape> grains(volumes.size());
  for (std::size_t i = 0; i < volumes.size(); ++i) {
    grains[i].label = static_cast<std::uint32_t>(10 + i);
    grains[i].volume = volumes[i];
  }
  return grains;
}

EquivalentPackingOptions packing(double solid_fraction, double aspect) {
  EquivalentPackingOptions o;
  o.solid_fraction = solid_fraction;
  o.aspect = aspect;
  return o;
}

synth::PackedGrain pose_at(const Vector3d& position) {
  synth::PackedGrain pose;
  pose.position = position;
  return pose;
}

/// One linear tetrahedron with its right-angle corner at `corner` and legs of `edge`.
TetMesh one_tet(const Vector3d& corner, double edge) {
  TetMesh m;
  m.nodes = {corner, corner + Vector3d(edge, 0, 0), corner + Vector3d(0, edge, 0), corner + Vector3d(0, 0, edge)};
  m.elements = {0, 1, 2, 3};
  return m;
}

}  // namespace

TEST(MeshTwin, ScanCylinderHeightIsClippedToTheImageAndSolidFractionIsGrainsOverCylinder) {
  const Volume<std::uint32_t> image = scan_image();
  ScanCylinder region;
  EXPECT_FALSE(region.bounded());
  region.radius = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(region.bounded());
  region.radius = 2e-3;
  EXPECT_TRUE(region.bounded());
  EXPECT_NEAR(height_in_scan(region, image), 10e-3, 1e-15);  // unbounded in z: the whole scan
  region.z_min = 2e-3, region.z_max = 20e-3;
  EXPECT_NEAR(height_in_scan(region, image), 8.5e-3, 1e-15);
  const auto grains = grains_of_volumes({1e-9, 3e-9});
  EXPECT_NEAR(solid_fraction(grains, 1e-3, 2e-3), 4e-9 / (M_PI * 1e-6 * 2e-3), 1e-12);
}

TEST(MeshTwin, PackingOptionsTakeTheScansSolidFractionAndAspectUnlessGiven) {
  const Volume<std::uint32_t> image = scan_image();
  ScanLabels scan;
  scan.image = &image;
  scan.region.radius = 2.5e-3;
  const auto grains = grains_of_volumes({40e-9, 60e-9});
  const EquivalentPackingOptions taken = scan_packing_options(packing(0.0, 0.0), grains, &scan, "l.h5");
  EXPECT_NEAR(taken.solid_fraction, solid_fraction(grains, 2.5e-3, 10e-3), 1e-12);
  EXPECT_NEAR(taken.aspect, 10e-3 / 5e-3, 1e-12);
  const EquivalentPackingOptions given = scan_packing_options(packing(0.5, 3.0), grains, &scan, "l.h5");
  EXPECT_EQ(given.solid_fraction, 0.5);
  EXPECT_EQ(given.aspect, 3.0);
  // No cylinder: a solid fraction must be given, and the aspect is 1.
  EXPECT_EQ(scan_packing_options(packing(0.5, 0.0), grains, nullptr, "").aspect, 1.0);
  scan.region.radius = 0.0;
  try {
    scan_packing_options(packing(0.0, 0.0), grains, &scan, "l.h5");
    ADD_FAILURE() << "no cylinder accepted";
  } catch (const UsageError& e) {
    EXPECT_NE(e.message().find("l.h5 has no bounded sample cylinder"), std::string::npos) << e.message();
  }
  // Grains of more volume than the cylinder holds cannot be packed.
  scan.region.radius = 1e-3;
  EXPECT_THROW(scan_packing_options(packing(0.0, 0.0), grains_of_volumes({1e-6}), &scan, "l.h5"), DataError);
}

TEST(MeshTwin, GrainsInPlaceKeepTheirLabelsAndASamplesAreNumberedWithTheirSource) {
  const auto library = grains_of_volumes({1e-9, 2e-9, 3e-9});
  const std::vector<const shape::GrainShape*> pointers = {&library[0], &library[1], &library[2]};
  const TwinGrains in_place = grains_in_place(pointers);
  EXPECT_EQ(in_place.label, (std::vector<std::uint32_t>{10, 11, 12}));
  EXPECT_EQ(in_place.source_label, in_place.label);
  EXPECT_TRUE(in_place.poses.empty());
  EquivalentTwin twin;
  twin.sample.source = {2, 0, 2};
  twin.sample.poses.resize(3);
  for (std::size_t s : twin.sample.source) twin.grains.push_back(library[s]);
  const TwinGrains drawn = grains_of_sample(twin, pointers);
  EXPECT_EQ(drawn.label, (std::vector<std::uint32_t>{1, 2, 3}));
  EXPECT_EQ(drawn.source_label, (std::vector<std::uint32_t>{12, 10, 12}));
  EXPECT_EQ(drawn.shapes[1], &twin.grains[1]);
  EXPECT_EQ(drawn.poses.size(), 3u);
}

TEST(MeshTwin, GrainsAreMeshedIntoTheirOwnRowsAndPlacedAtTheirPoses) {
  const ShSurfaceBasis basis(3, 4);
  const shape::GrainShape small = test::sh_grain(0.2e-3, 0.0, Vector3d::Zero()), large = test::sh_grain(0.4e-3, 0.0, Vector3d::Zero());
  TwinGrains grains = grains_in_place({&small, &large});
  grains.poses = {pose_at(Vector3d(1e-3, 0, 0)), pose_at(Vector3d(0, 2e-3, 0))};
  GrainMeshOptions o;
  o.order = 1;
  o.size.elements_per_diameter = 4;
  std::size_t done = 0;
  const auto results = mesh_twin_grains(grains, basis, nullptr, o, [&] { ++done; });
  EXPECT_EQ(done, 2u);
  ASSERT_EQ(results.size(), 2u);
  EXPECT_LT(results[0].quality.volume, results[1].quality.volume);  // largest meshed first, rows kept
  for (std::size_t i = 0; i < 2; ++i) {
    Vector3d mean = Vector3d::Zero();
    for (const Vector3d& x : results[i].mesh.nodes) mean += x;
    mean /= static_cast<double>(results[i].mesh.nodes.size());
    EXPECT_LT((mean - grains.poses[i].position).norm(), 0.05e-3) << "grain " << i;
  }
}

TEST(MeshTwin, AssemblyJoinsTheMeshesAndCountsTheirOriginsPathsAndKinds) {
  const auto library = grains_of_volumes({1e-9, 2e-9});
  const TwinGrains grains = grains_in_place({&library[0], &library[1]});
  std::vector<GrainMeshResult> results(2);
  results[0].mesh = one_tet(Vector3d::Zero(), 1e-3);
  results[0].kind = fdem::GrainKind::rigid;
  results[0].origin = SurfaceOrigin::voxels;
  results[0].path = MeshPath::kept_surface;
  results[0].surface_volume = 1e-9 / 6;
  results[0].quality = mesh_quality(results[0].mesh, 0.1);
  results[0].seconds = 2.0;
  results[1].mesh = one_tet(Vector3d(5e-3, 0, 0), 2e-3);
  results[1].origin = SurfaceOrigin::ellipsoid;
  results[1].path = MeshPath::ellipsoid;
  results[1].overran = true;
  results[1].surface_volume = 8e-9 / 6;
  results[1].quality = mesh_quality(results[1].mesh, 0.1);
  results[1].gmsh.seconds = 1.5;
  results[1].seconds = 3.0;
  const TwinModel twin = assemble_twin(grains, results);
  ASSERT_EQ(twin.model.grains.size(), 2u);
  EXPECT_EQ(twin.model.grains[0].label, 10u);
  EXPECT_EQ(twin.model.grains[1].label, 11u);
  EXPECT_EQ(twin.model.nodes.size(), 8u);
  EXPECT_EQ(twin.table.label, (std::vector<std::uint32_t>{10, 11}));
  EXPECT_EQ(twin.table.origin, (std::vector<std::uint8_t>{1, 2}));
  EXPECT_EQ(twin.table.overran, (std::vector<std::uint8_t>{0, 1}));
  EXPECT_NEAR(twin.table.volume_error[1], 0.0, 1e-12);
  const TwinCounts& c = twin.counts;
  EXPECT_EQ(c.origin, (std::array<std::size_t, 3>{0, 1, 1}));
  EXPECT_EQ(c.path, (std::array<std::size_t, 3>{0, 1, 1}));
  EXPECT_EQ(c.overran, 1u);
  EXPECT_EQ(c.rigid, 1u);
  EXPECT_DOUBLE_EQ(c.gmsh_seconds, 1.5);
  EXPECT_DOUBLE_EQ(c.seconds, 5.0);
}

TEST(MeshTwin, TheSampleIsThePackingsThenTheInscribedThenTheScansThenTheGrains) {
  fdem::Model model;
  append_grain(model, one_tet(Vector3d::Zero(), 1e-3), 1, fdem::GrainKind::tet4);
  const double thickness = 0.2e-3;
  const TwinSample around = twin_sample(model, thickness, nullptr, nullptr, nullptr);
  EXPECT_EQ(around.source, "grains");
  EXPECT_EQ(around.cylinder.membrane_thickness, thickness);
  EXPECT_NEAR(around.cylinder.z_max, 1e-3, 1e-15);

  ScanCylinder region;  // unbounded in z: the grains' z range
  region.axis_xy = Eigen::Vector2d(1e-3, 2e-3);
  region.radius = 3e-3;
  const TwinSample scan = twin_sample(model, thickness, nullptr, nullptr, &region);
  EXPECT_EQ(scan.source, "labels");
  EXPECT_EQ(scan.cylinder.axis_xy, region.axis_xy);
  EXPECT_EQ(scan.cylinder.radius, 3e-3);
  EXPECT_NEAR(scan.cylinder.z_max, 1e-3, 1e-15);
  region.z_min = -1e-3, region.z_max = 4e-3;
  EXPECT_EQ(twin_sample(model, thickness, nullptr, nullptr, &region).cylinder.z_max, 4e-3);

  fdem::SampleCylinder inscribed;
  inscribed.radius = 5e-3;
  EXPECT_EQ(twin_sample(model, thickness, nullptr, &inscribed, &region).source, "inscribed in the scan");
  synth::Container container;
  container.radius = 6e-3, container.height = 7e-3;
  const TwinSample packed = twin_sample(model, thickness, &container, &inscribed, &region);
  EXPECT_EQ(packed.source, "equivalent packing");
  EXPECT_EQ(packed.cylinder.axis_xy, Eigen::Vector2d::Zero());
  EXPECT_EQ(packed.cylinder.radius, 6e-3);
  EXPECT_EQ(packed.cylinder.z_min, 0.0);
  EXPECT_EQ(packed.cylinder.z_max, 7e-3);
  EXPECT_EQ(packed.cylinder.membrane_thickness, thickness);
}

TEST(MeshTwin, TheMeshTableIsWrittenWithItsUnitsAndCodes) {
  test::TempDir dir;
  const auto library = grains_of_volumes({1e-9});
  GrainMeshResult r;
  r.mesh = one_tet(Vector3d::Zero(), 1e-3);
  r.surface_volume = 1e-9 / 6;
  r.quality = mesh_quality(r.mesh, 0.1);
  r.note = "a note";
  const TwinModel twin = assemble_twin(grains_in_place({&library[0]}), {r});
  {
    io::H5File f = io::H5File::create(dir / "m.h5");
    write_mesh_table(f, twin, R"({"order": 1})");
  }
  const io::H5File f = io::H5File::open(dir / "m.h5");
  EXPECT_EQ(f.read<std::uint32_t>("/mesh/label"), (std::vector<std::uint32_t>{10}));
  EXPECT_EQ(f.read<std::uint64_t>("/mesh/elements"), (std::vector<std::uint64_t>{1}));
  EXPECT_NEAR(f.read<double>("/mesh/volume")[0], 1e-9 / 6, 1e-20);
  EXPECT_EQ(f.attr_string("/mesh/volume", "units").value_or(""), "m^3");
  EXPECT_NE(f.attr_string("/mesh/surface_origin", "codes").value_or("").find("1 smoothed voxels"), std::string::npos);
  EXPECT_EQ(f.read_strings("/mesh/note"), (std::vector<std::string>{"a note"}));
  EXPECT_EQ(f.read_strings("/mesh/parameters"), (std::vector<std::string>{R"({"order": 1})"}));
}
