// fdem/ scenes: sphere and ellipsoid primitives meshed by gmsh (volume, mass and principal axes
// against the exact solid, kinds), grains from a kind=fdem_model file merged with primitives
// (materials by name, labels, platens and sample cylinder from the file unless the scene sets
// them), and the errors of bad [model] and shape tables.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <fstream>
#include <numbers>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/element.hpp"
#include "graintwin/mesh/ellipsoid_grain.hpp"
#include "graintwin/fdem/model_file.hpp"
#include "graintwin/fdem/primitives.hpp"
#include "graintwin/fdem/scene.hpp"
#include "support/run_tool.hpp"
#include "support/scene_text.hpp"

using namespace graintwin;
using namespace graintwin::fdem;
using test::write_text;

namespace {

std::string error_of(const std::filesystem::path& scene) {
  try {
    read_scene(scene);
  } catch (const Error& e) {
    return e.message();
  }
  return "no error";
}

}  // namespace

TEST(FdemScene, SpheresAndEllipsoidsHaveTheExactSolidsMassAndAxes) {
  test::TempDir dir;
  const auto path = write_text(dir, "s.toml", R"(
[run]
duration = 1e-6
[[grains]]
shape = "sphere"
radius = 1e-3
element_size = 0.4e-3
kind = "tet10"
position = [0, 0, 1e-3]
[[grains]]
shape = "sphere"
radius = 1e-3
element_size = 0.4e-3
kind = "tet4"
position = [5e-3, 0, 0]
[[grains]]
shape = "ellipsoid"
semi_axes = [2e-3, 1e-3, 0.5e-3]
rotation = [0, 0, 0.5235987755982988]
element_size = 0.3e-3
kind = "rigid"
position = [0, 5e-3, 0]
)");
  const Scene scene = read_scene(path);
  EXPECT_THROW(build_model(scene), UsageError);  // no mesher: refused, not skipped
  const Model m = build_model(scene, mesh::append_ellipsoid_grain);
  ASSERT_EQ(m.grains.size(), 3u);
  EXPECT_EQ(m.grains[0].kind, GrainKind::tet10);
  EXPECT_EQ(m.nodes_of(m.grains[0].element_begin), 10u);
  EXPECT_EQ(m.nodes_of(m.grains[1].element_begin), 4u);
  EXPECT_EQ(m.grains[2].kind, GrainKind::rigid);
  const double sphere = 4.0 / 3.0 * std::numbers::pi * 1e-9;
  const BodyProperties curved = body_properties(m, 0), flat = body_properties(m, 1), ellipsoid = body_properties(m, 2);
  // Curved 10-node elements follow the sphere; flat facets (h = 0.4 R) cut a cap off each, 6 % here.
  EXPECT_NEAR(curved.volume / sphere, 1.0, 2e-3);
  EXPECT_NEAR(flat.volume / sphere, 1.0, 0.08);
  EXPECT_LT(flat.volume, sphere);
  EXPECT_NEAR((curved.centroid - Eigen::Vector3d(0, 0, 1e-3)).norm(), 0, 1e-3 * 1e-3);  // an unstructured mesh: 1e-4 R
  EXPECT_NEAR(curved.mass, 2650 * curved.volume, 1e-12);
  // Principal axes of the rotated ellipsoid: the longest (smallest moment) turned 30 deg about z.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(ellipsoid.inertia);
  const Eigen::Vector3d long_axis = eig.eigenvectors().col(0);
  EXPECT_NEAR(std::abs(long_axis.dot(Eigen::Vector3d(std::cos(std::numbers::pi / 6), std::sin(std::numbers::pi / 6), 0))), 1.0,
              1e-3);
  const double exact_volume = 4.0 / 3.0 * std::numbers::pi * 2e-3 * 1e-3 * 0.5e-3;
  EXPECT_NEAR(ellipsoid.volume / exact_volume, 1.0, 0.08);
}

TEST(FdemScene, ModelFileGrainsMergeWithPrimitives) {
  test::TempDir dir;
  Model file_model;
  file_model.materials = {Material{}, Material{}};
  file_model.materials[1].name = "glass";
  file_model.materials[1].density = 2500;
  add_grain(file_model, box_mesh({1e-3, 1e-3, 1e-3}, 0.5e-3), Eigen::Vector3d::Zero(), GrainKind::tet4, 1, 7);
  add_grain(file_model, box_mesh({1e-3, 1e-3, 1e-3}, 0.5e-3), Eigen::Vector3d(2e-3, 0, 0), GrainKind::tet10, 0, 8);
  file_model.platens = {Platen{"bottom", Eigen::Vector3d(0, 0, -1e-3), Eigen::Vector3d::UnitZ(), 0.1},
                        Platen{"top", Eigen::Vector3d(0, 0, 2e-3), -Eigen::Vector3d::UnitZ(), 0.0}};
  file_model.sample = SampleCylinder{Eigen::Vector2d(1e-3, 0), 3e-3, -1e-3, 2e-3, 0.3e-3};
  write_model_file(dir / "grains.h5", file_model, {"test"});

  const auto merged = write_text(dir, "merged.toml", R"(
[model]
file = "grains.h5"
[[materials]]
name = "glass"
density = 2400
[[materials]]
name = "steel"
density = 7800
[[grains]]
size = [1e-3, 1e-3, 1e-3]
position = [0, 0, 5e-3]
material = "steel"
label = 9
velocity = [0, 0, -1]
[[stages]]
duration = 1e-6
platens = { top = [0, 0, -0.1] }
)");
  const Scene scene = read_scene(merged);
  ASSERT_EQ(scene.materials.size(), 3u);
  EXPECT_EQ(scene.materials[1].density, 2400);  // the scene's glass replaces the file's
  EXPECT_EQ(scene.materials[2].name, "steel");
  ASSERT_EQ(scene.platens.size(), 2u);  // from the file, and a stage can move them by name
  EXPECT_EQ(scene.stages[0].platen_velocity[1].value(), Eigen::Vector3d(0, 0, -0.1));
  EXPECT_EQ(scene.primitive_grain(0), 2u);
  const Model m = build_model(scene);
  ASSERT_EQ(m.grains.size(), 3u);
  EXPECT_EQ(m.grains[0].label, 7u);
  EXPECT_EQ(m.grains[1].kind, GrainKind::tet10);
  EXPECT_EQ(m.grains[2].label, 9u);
  EXPECT_EQ(m.materials[m.grains[0].material].name, "glass");
  EXPECT_EQ(m.materials[m.grains[2].material].name, "steel");
  EXPECT_NEAR(body_properties(m, 0).mass, 2400 * 1e-9, 1e-18);
  ASSERT_EQ(m.platens.size(), 2u);
  EXPECT_EQ(m.platens[0].friction, 0.1);
  ASSERT_TRUE(m.sample.has_value());
  EXPECT_EQ(m.sample->radius, 3e-3);
  EXPECT_NO_THROW(validate_model(m, "merged"));

  // The scene's own platens, sample and kind override the file's.
  const auto own = write_text(dir, "own.toml", R"(
[run]
duration = 1e-6
[model]
file = "grains.h5"
kind = "rigid"
[sample]
radius = 4e-3
[[platens]]
name = "floor"
point = [0, 0, -2e-3]
)");
  const Model o = build_model(read_scene(own));
  ASSERT_EQ(o.platens.size(), 1u);
  EXPECT_EQ(o.platens[0].name, "floor");
  EXPECT_EQ(o.sample->radius, 4e-3);
  EXPECT_EQ(o.sample->z_max, 2e-3);  // the other keys stay the file's
  for (const Grain& g : o.grains) EXPECT_EQ(g.kind, GrainKind::rigid);

  // kind = "tet4": the 10-node grain split into 4-node elements on its own nodes, the other kept.
  const auto linear = write_text(dir, "linear.toml", "[run]\nduration = 1e-6\n[model]\nfile = \"grains.h5\"\nkind = \"tet4\"\n");
  const Model l = build_model(read_scene(linear));
  ASSERT_EQ(l.grains.size(), 2u);
  for (const Grain& g : l.grains) EXPECT_EQ(g.kind, GrainKind::tet4);
  EXPECT_EQ(l.nodes, file_model.nodes);
  EXPECT_EQ(l.triangles, file_model.triangles);
  EXPECT_EQ(l.grains[0].element_end - l.grains[0].element_begin, file_model.grains[0].element_end - file_model.grains[0].element_begin);
  EXPECT_EQ(l.grains[1].element_end - l.grains[1].element_begin,
            8 * (file_model.grains[1].element_end - file_model.grains[1].element_begin));
  EXPECT_TRUE(read_scene(linear).has_deformable_grains());
}

// The shapes' names are one table for the scene reader and its messages: each names one shape.
TEST(FdemScene, PrimitiveShapeNamesReadBackAsTheirShapes) {
  for (const auto& [shape, name] : kPrimitiveShapeNames) {
    EXPECT_EQ(find_enum(kPrimitiveShapeNames, name), shape) << name;
    EXPECT_STREQ(enum_name(kPrimitiveShapeNames, shape), name);
  }
  EXPECT_FALSE(find_enum(kPrimitiveShapeNames, "cone"));
}

TEST(FdemScene, BadModelAndShapeTablesFailWithTheFix) {
  test::TempDir dir;
  Model file_model;
  add_grain(file_model, box_mesh({1e-3, 1e-3, 1e-3}, 1e-3), Eigen::Vector3d::Zero(), GrainKind::tet4, 0, 3);
  write_model_file(dir / "grains.h5", file_model, {"test"});
  const auto scene = [&](const std::string& body) { return write_text(dir, "bad.toml", "[run]\nduration = 1e-6\n" + body); };
  EXPECT_NE(error_of(scene("[model]\nfile = \"nope.h5\"\n")).find("does not exist"), std::string::npos);
  EXPECT_NE(error_of(scene("[model]\nfile = \"grains.h5\"\nkind = \"tet10\"\n")).find("kind may be \"rigid\" or \"tet4\""), std::string::npos);
  EXPECT_NE(error_of(scene("[model]\nfile = \"grains.h5\"\n[[grains]]\nsize = [1e-3, 1e-3, 1e-3]\nlabel = 3\n"))
                .find("label 3 is used twice"),
            std::string::npos);
  write_text(dir, "not_a_model.h5", "plain text");
  EXPECT_NE(error_of(scene("[model]\nfile = \"not_a_model.h5\"\n")).find("not_a_model.h5"), std::string::npos);
  EXPECT_NE(error_of(scene("[[grains]]\nshape = \"sphere\"\nsize = [1e-3, 1e-3, 1e-3]\n")).find("size does not apply to a sphere"),
            std::string::npos);
  EXPECT_NE(error_of(scene("[[grains]]\nshape = \"ellipsoid\"\nradius = 1e-3\n")).find("radius does not apply"), std::string::npos);
  EXPECT_NE(error_of(scene("[[grains]]\nshape = \"ellipsoid\"\n")).find("semi_axes is missing"), std::string::npos);
  EXPECT_NE(error_of(scene("[[grains]]\nshape = \"cone\"\n")).find("use box, sphere or ellipsoid"), std::string::npos);
  EXPECT_NE(error_of(scene("[[grains]]\nshape = \"sphere\"\nradius = -1\n")).find("radius must be positive"), std::string::npos);
  // Graded meshes: only on curved grains, with a fine size below the coarse one.
  EXPECT_NE(error_of(scene("[[grains]]\nsize = [1e-3, 1e-3, 1e-3]\nrefine_at = [[0, 0, 5e-4]]\nfine_element_size = 1e-4\n"))
                .find("refine_at applies to spheres"),
            std::string::npos);
  EXPECT_NE(error_of(scene("[[grains]]\nshape = \"sphere\"\nradius = 1e-3\nrefine_at = [[0, 0, 1e-3]]\n"))
                .find("fine_element_size is missing"),
            std::string::npos);
  EXPECT_NE(error_of(scene("[[grains]]\nshape = \"sphere\"\nradius = 1e-3\nelement_size = 2e-4\nrefine_at = [[0, 0, 1e-3]]\n"
                           "fine_element_size = 3e-4\n"))
                .find("coarse size is element_size"),
            std::string::npos);
  EXPECT_NE(error_of(scene("[[grains]]\nshape = \"sphere\"\nradius = 1e-3\nsize_growth = 0.2\n")).find("need refine_at"),
            std::string::npos);
  EXPECT_NE(error_of(scene("[[grains]]\nshape = \"sphere\"\nradius = 1e-3\nrefine_at = [0, 0, 1]\nfine_element_size = 1e-4\n"))
                .find("array of points"),
            std::string::npos);
}

TEST(FdemScene, MaterialsAndRunKeysOutOfTheirRangeAreRefusedWithTheRange) {
  // Material values take the model files' ranges (one check for both), printed readably.
  test::TempDir dir;
  const auto scene = [&](const std::string& body) { return write_text(dir, "bad.toml", "[run]\nduration = 1e-6\n" + body); };
  const std::string box = "[[grains]]\nsize = [1e-3, 1e-3, 1e-3]\n";
  const auto says = [&](const std::string& body, const std::string& words) {
    const std::string message = error_of(scene(body));
    EXPECT_NE(message.find(words), std::string::npos) << message;
  };
  says("[[materials]]\nyoung = 0\n", "bad.toml: [[materials]] 1: young must lie in [1000, 1e+13] Pa (got 0 Pa)");
  says("[[materials]]\ndensity = -2650\n", "density must lie in [1, 1e+10] kg/m^3 (got -2650 kg/m^3)");
  says("[[materials]]\npoisson = 0.5\n", "poisson must lie in (-1, 0.5) (got 0.5)");
  says("[[materials]]\ndamping_ratio = 1\n", "damping_ratio must lie in [0, 1) (got 1)");
  says("[[materials]]\nnormal_penalty = 1e30\n", "normal_penalty must lie in (0, 1e+24] N/m^3 (got 1e+30 N/m^3)");
  says("[[materials]]\nfriction = nan\n", "friction must be a number");
  says(box + "[[platens]]\nfriction = 20\n", "bad.toml: [[platens]] 1: friction must lie in [0, 10] (got 20)");
  const auto run = [&](const std::string& keys) { return write_text(dir, "run.toml", "[run]\nduration = 1e-6\n" + keys + box); };
  EXPECT_NE(error_of(run("overlap_tolerance = 0.9\n")).find("overlap_tolerance must lie in [0.001, 0.5]"), std::string::npos);
  EXPECT_NE(error_of(run("relax_overlaps = 1\n")).find("relax_overlaps must be true or false"), std::string::npos);
  EXPECT_NE(error_of(run("max_steps = 1e16\n")).find("max_steps must lie in [1, 1e+15] (got 1e+16)"), std::string::npos);
  EXPECT_NE(error_of(run("keep_initial_overlaps = 1\n")).find("keep_initial_overlaps must be true or false"), std::string::npos);
  EXPECT_NE(error_of(run("mass_scaled_share = 0.5\n")).find("mass_scaled_share must lie in [0, 0.2]"), std::string::npos);
  EXPECT_NE(error_of(run("mass_scaled_share = nan\n")).find("mass_scaled_share must"), std::string::npos);
  EXPECT_NE(error_of(run("time_step_fraction = 1.5\n")).find("time_step_fraction must be at most 1"), std::string::npos);
  EXPECT_NE(error_of(run("time_step_fraction = 0\n")).find("time_step_fraction must be"), std::string::npos);
  EXPECT_NE(error_of(run("time_step = 1e-9\ntime_step_fraction = 0.5\n")).find("give time_step or time_step_fraction, not both"),
            std::string::npos);
  const Scene defaults = read_scene(run(""));
  EXPECT_EQ(defaults.time_step_fraction, 1.0);
  EXPECT_EQ(defaults.overlaps.tolerance, 0.1);
  EXPECT_FALSE(defaults.overlaps.relax);
  EXPECT_EQ(defaults.max_steps, 1e7);
  EXPECT_FALSE(defaults.overlaps.keep);
  EXPECT_EQ(defaults.mass_scaled_share, 0.0);
  const Scene set = read_scene(run("overlap_tolerance = 0.1\nrelax_overlaps = true\nmax_steps = 5e8\n"));
  EXPECT_EQ(set.overlaps.tolerance, 0.1);
  EXPECT_TRUE(set.overlaps.relax);
  EXPECT_EQ(set.max_steps, 5e8);
  // A penalty set per element size is checked once resolved on the mesh.
  const Scene tiny = read_scene(scene("[[materials]]\npenalty_per_size = 1000\npenalty_element_size = 1e-12\n" + box));
  try {
    build_model(tiny);
    ADD_FAILURE() << "a penalty of 9e25 N/m^3 was accepted";
  } catch (const UsageError& e) {
    EXPECT_NE(e.message().find("gives a penalty out of range: normal_penalty must lie in (0, 1e+24] N/m^3"), std::string::npos)
        << e.message();
  }
}

TEST(FdemScene, DeformableIntegrationIsExplicitOrImplicitWithWhatImplicitTakes) {
  test::TempDir dir;
  const std::string box = "[[grains]]\nsize = [1e-3, 1e-3, 1e-3]\n";
  const auto run = [&](const std::string& keys, const std::string& rest = "") {
    return write_text(dir, "run.toml", "[run]\nduration = 1e-6\n" + keys + box + rest);
  };
  EXPECT_FALSE(read_scene(run("")).implicit_grains);
  EXPECT_TRUE(read_scene(run("deformable_integration = \"implicit\"\n")).implicit_grains);
  EXPECT_NE(error_of(run("deformable_integration = \"newmark\"\n"))
                .find("run.toml: [run]: deformable_integration must be \"explicit\" (central differences at the element step) "
                      "or \"implicit\""),
            std::string::npos);
  const std::string implicit = "deformable_integration = \"implicit\"\n";
  EXPECT_NE(error_of(run(implicit + "local_damping = 0.7\n"))
                .find("run.toml: [run] deformable_integration = \"implicit\" takes mass-proportional damping only so far, and "
                      "[run] sets stiffness_damping or local_damping"),
            std::string::npos);
  EXPECT_NE(error_of(run(implicit + "stiffness_damping = 1e-9\n")).find("takes mass-proportional damping only"), std::string::npos);
  EXPECT_NE(error_of(run(implicit + "element_step_target = 1e-7\ndamping = 100\n"))
                .find("[run] element_step_target (selective mass scaling) lifts the element step, which implicit grains do not have"),
            std::string::npos);
  // A stage's own damping is checked too.
  const std::string stages = "[[stages]]\nname = \"press\"\nduration = 1e-6\nlocal_damping = 0.5\n";
  EXPECT_NE(error_of(write_text(dir, "stages.toml", "[run]\n" + implicit + box + stages)).find("stage 'press' sets stiffness_damping or local_damping"),
            std::string::npos);
}

TEST(FdemScene, PenaltyPerSizeIsResolvedOnTheBuiltMeshes) {
  // Boxes meshed at h = 0.5 mm: two of a surface triangle's three edges are h, so the median edge
  // is h, for 4-node grains and (doubled quarter faces) for 10-node ones.
  test::TempDir dir;
  const std::string materials =
      "[[materials]]\nname = \"a\"\nyoung = 1e9\npenalty_per_size = 10\n"
      "[[materials]]\nname = \"b\"\nyoung = 2e9\npenalty_per_size = 5\npenalty_element_size = 1e-4\n"
      "[[materials]]\nname = \"c\"\nnormal_penalty = 7e12\n";
  const std::string box = "[[grains]]\nsize = [2e-3, 1e-3, 1e-3]\nelement_size = 5e-4\n";
  for (const char* kind : {"tet4", "tet10"}) {
    const auto path = write_text(dir, "penalty.toml",
                                 "[run]\nduration = 1e-6\n" + materials + box + "material = \"a\"\nkind = \"" + kind +
                                     "\"\n" + box + "material = \"c\"\nposition = [0, 0, 5e-3]\n");
    const Model m = build_model(read_scene(path));
    EXPECT_NEAR(contact_element_size(m, 0), 5e-4, 1e-12) << kind;
    EXPECT_NEAR(m.materials[0].normal_penalty, 10 * 1e9 / 5e-4, 1e3) << kind;
    EXPECT_EQ(m.materials[0].tangential_penalty, m.materials[0].normal_penalty) << kind;
    EXPECT_NEAR(m.materials[1].normal_penalty, 5 * 2e9 / 1e-4, 1e3) << kind;  // given size: no grain needed
    EXPECT_EQ(m.materials[2].normal_penalty, 7e12) << kind;
    EXPECT_EQ(m.materials[2].tangential_penalty, Material{}.tangential_penalty) << kind;
  }
  // A scene table replacing the model file's material of the same name keeps its index.
  Model file_model;
  file_model.materials = {Material{}, Material{}};
  file_model.materials[0].name = "file_first";
  file_model.materials[1].name = "file_second";
  add_grain(file_model, box_mesh({1e-3, 1e-3, 1e-3}, 2.5e-4), Eigen::Vector3d::Zero(), GrainKind::rigid, 1, 1);
  write_model_file(dir / "grains.h5", file_model, {"test"});
  const auto merged = write_text(dir, "merged.toml",
                                 "[run]\nduration = 1e-6\n[model]\nfile = \"grains.h5\"\n[[materials]]\nname = \"extra\"\n"
                                 "penalty_per_size = 3\npenalty_element_size = 1e-3\n[[materials]]\nname = \"file_second\"\n"
                                 "young = 4e9\npenalty_per_size = 2\n");
  const Model with_file = build_model(read_scene(merged));
  ASSERT_EQ(with_file.materials.size(), 3u);
  EXPECT_EQ(with_file.materials[0].normal_penalty, Material{}.normal_penalty);
  EXPECT_NEAR(with_file.materials[1].normal_penalty, 2 * 4e9 / 2.5e-4, 1e3);
  EXPECT_NEAR(with_file.materials[2].normal_penalty, 3 * Material{}.young / 1e-3, 1e3);
  // A measured size needs a grain of that material (refused before any meshing); both ways of
  // setting p_n at once are refused.
  const auto unused = write_text(dir, "unused.toml", "[run]\nduration = 1e-6\n" + materials + box + "material = \"c\"\n");
  EXPECT_NE(error_of(unused).find("material 'a' sets penalty_per_size but no grain uses it"), std::string::npos)
      << error_of(unused);
  const auto scene = [&](const std::string& body) { return write_text(dir, "bad.toml", "[run]\nduration = 1e-6\n" + body); };
  EXPECT_NE(error_of(scene("[[materials]]\npenalty_per_size = 10\nnormal_penalty = 1e12\n")).find("give one or the others"),
            std::string::npos);
  EXPECT_NE(error_of(scene("[[materials]]\npenalty_element_size = 1e-4\n")).find("needs penalty_per_size"), std::string::npos);
  EXPECT_NE(error_of(scene("[[materials]]\npenalty_per_size = -1\n")).find("penalty_per_size must be positive"),
            std::string::npos);
}

TEST(FdemScene, AGradedSphereIsFineOnlyNearItsRefinePoint) {
  test::TempDir dir;
  const auto path = write_text(dir, "graded.toml",
                               "[run]\nduration = 1e-6\n[[grains]]\nshape = \"sphere\"\nradius = 1e-3\nelement_size = 4e-4\n"
                               "refine_at = [[0, 0, -1e-3]]\nfine_element_size = 4e-5\nsize_growth = 0.3\n");
  const Scene scene = read_scene(path);
  ASSERT_TRUE(scene.grains[0].grading.has_value());
  const Model m = build_model(scene, mesh::append_ellipsoid_grain);
  // Mean edge of the surface triangles near the pole against those at the equator.
  double near = 0, far = 0;
  int n_near = 0, n_far = 0;
  for (const auto& t : m.triangles) {
    const Eigen::Vector3d c = (m.nodes[t[0]] + m.nodes[t[1]] + m.nodes[t[2]]) / 3;
    const double edge = (m.nodes[t[1]] - m.nodes[t[0]]).norm();
    if ((c - Eigen::Vector3d(0, 0, -1e-3)).norm() < 1e-4) near += edge, ++n_near;
    if (std::abs(c.z()) < 1e-4) far += edge, ++n_far;
  }
  ASSERT_GT(n_near, 0);
  ASSERT_GT(n_far, 0);
  EXPECT_LT(near / n_near, 0.3 * far / n_far);
}

// A [triaxial] table: defaults of docs/methods.md (reference experiment, membrane), the membrane thickness from the model
// file's sample cylinder unless the table sets it, the model file replaced by read_scene's argument
// (fdemrun --model), and the rate as a strain rate or an inertial number, not both.
TEST(FdemScene, TriaxialTableTakesTheModelsMembraneThicknessAndItsDefaults) {
  test::TempDir dir;
  Model file_model;
  add_grain(file_model, box_mesh({1e-3, 1e-3, 1e-3}, 0.5e-3), Eigen::Vector3d::Zero(), GrainKind::rigid, 0, 1);
  file_model.sample = SampleCylinder{Eigen::Vector2d::Zero(), 1e-3, -0.5e-3, 0.5e-3, 0.6e-3};
  write_model_file(dir / "thick.h5", file_model, {"test"});
  const auto path = write_text(dir, "triaxial.toml", "[model]\n[triaxial]\nframe_strains = [0.01, 0.05]\n");
  EXPECT_THROW(read_scene(path), UsageError);  // [model] without a file and without the override
  const Scene s = read_scene(path, dir / "thick.h5");
  ASSERT_TRUE(s.triaxial.has_value());
  const TriaxialSpec& t = *s.triaxial;
  EXPECT_TRUE(t.membrane);
  EXPECT_DOUBLE_EQ(t.options.membrane.thickness, 0.6e-3);
  EXPECT_DOUBLE_EQ(t.options.confining_pressure, 300e3);
  EXPECT_DOUBLE_EQ(t.options.membrane.young, 1.25e6);
  EXPECT_DOUBLE_EQ(t.options.membrane.poisson, 0.2);
  EXPECT_DOUBLE_EQ(t.target_axial_strain, 0.1);
  EXPECT_DOUBLE_EQ(t.shear_ramp_strain, 5e-3);
  EXPECT_EQ(t.frame_strains, (std::vector<double>{0.01, 0.05}));
  EXPECT_TRUE(s.stages.empty());
  const auto thin = write_text(dir, "thin.toml", "[model]\n[triaxial]\nmembrane_thickness = 0.3e-3\nstrain_rate = 10\n");
  const Scene t2 = read_scene(thin, dir / "thick.h5");
  EXPECT_DOUBLE_EQ(t2.triaxial->options.membrane.thickness, 0.3e-3);
  EXPECT_DOUBLE_EQ(t2.triaxial->strain_rate, 10.0);
  // Without a sample cylinder there is no wall to start from.
  file_model.sample.reset();
  write_model_file(dir / "bare.h5", file_model, {"test"});
  EXPECT_THROW(read_scene(path, dir / "bare.h5"), UsageError);
}
