// fdem/ mixed twins: a scene's [model.deformable] picks the deformable grains of a model file by
// labels, a box, a scan's D2min or the grain stress of an earlier run (the rest become rigid, the
// picked ones keep their mesh's order); bad rules are refused with the file and the fix before any
// work; a mixed scene runs with its energy books closing, and a deformable grain pressed by rigid
// ones carries their load.
#include <gtest/gtest.h>

#include <cmath>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/grain_selection.hpp"
#include "graintwin/fdem/model_file.hpp"
#include "graintwin/fdem/primitives.hpp"
#include "graintwin/fdem/results_file.hpp"
#include "graintwin/fdem/scene.hpp"
#include "graintwin/fdem/solver.hpp"
#include "graintwin/io/schema.hpp"
#include "support/run_tool.hpp"
#include "support/scene_text.hpp"
#include "support/simulation_results.hpp"

using namespace graintwin;
using namespace graintwin::fdem;
using test::write_text;

namespace {

/// Six 1 mm cubes in a row along x, 2 mm apart, labels 10-15: tet4 and tet10 in turn, the last rigid
/// (a 4-node mesh).
Model row_of_cubes() {
  Model m;
  for (int k = 0; k < 6; ++k) {
    const GrainKind kind = k == 5 ? GrainKind::rigid : k % 2 ? GrainKind::tet10 : GrainKind::tet4;
    add_grain(m, box_mesh(Eigen::Vector3d::Constant(1e-3), 0.5e-3), Eigen::Vector3d(2e-3 * k, 0, 0), kind, 0,
              static_cast<std::uint32_t>(10 + k));
  }
  return m;
}

class MixedTwin : public ::testing::Test {
 protected:
  void SetUp() override { write_model_file(dir_ / "grains.h5", row_of_cubes(), {"test"}); }
  /// A scene of the row's model file with `deformable` as its [model.deformable] table.
  std::filesystem::path scene(const std::string& deformable) const {
    return write_text(dir_, "scene.toml", "[run]\nduration = 1e-6\n[model]\nfile = \"grains.h5\"\n[model.deformable]\n" + deformable);
  }
  /// The kinds of the model the scene builds.
  static std::vector<GrainKind> kinds(const Scene& s) {
    std::vector<GrainKind> out;
    for (const Grain& g : build_model(s).grains) out.push_back(g.kind);
    return out;
  }
  std::string error_of(const std::string& deformable, const D2minByLabel& d2min = {}) const {
    try {
      read_scene(scene(deformable), std::filesystem::path(), d2min);
    } catch (const Error& e) {
      return e.message();
    }
    return "no error";
  }
  /// A results file of the row (all rigid) whose one frame holds mean stresses `p` (Pa) by grain.
  std::filesystem::path results_with_mean_stress(const std::vector<double>& p) const {
    Model m = row_of_cubes();
    for (Grain& g : m.grains) g.kind = GrainKind::rigid;
    SolverOptions o;
    o.contact.enabled = false;
    const Solver solver(m, o);
    const auto path = dir_ / "rigid.h5";
    {
      ResultsWriter writer(path, solver, "{}");
      writer.add_frame(solver);
      writer.finish({"test"});
    }
    std::vector<double> stress;
    for (double v : p)
      for (int k = 0; k < 9; ++k) stress.push_back(k % 4 == 0 ? v : 0.0);
    test::replace_dataset(path, std::string(schema::fdem_results::frames) + "/000000/" + schema::fdem_results::frame_stress, stress,
                          {p.size(), 3, 3});
    return path;
  }

  test::TempDir dir_;
};

constexpr GrainKind R = GrainKind::rigid, T4 = GrainKind::tet4, T10 = GrainKind::tet10;

}  // namespace

TEST_F(MixedTwin, LabelsPickTheirGrainsWhichKeepTheirMeshOrder) {
  const Scene s = read_scene(scene("rule = \"labels\"\nlabels = [11, 15, 11]\n"));
  ASSERT_TRUE(s.model->deformable);
  EXPECT_EQ(s.model->deformable->grains, (std::vector<std::uint32_t>{1, 5}));
  EXPECT_EQ(s.model->deformable->rule, "labels (3 given)");
  // Label 15 is rigid in the file: picked, it deforms as its 4-node mesh.
  EXPECT_EQ(kinds(s), (std::vector<GrainKind>{R, T10, R, R, R, T4}));
  const Model built = build_model(s);
  EXPECT_EQ(grain_kind_counts(built), (std::array<std::size_t, 3>{4, 1, 1}));
}

TEST_F(MixedTwin, ABoxPicksTheGrainsWhoseCentroidsLieInIt) {
  const Scene s = read_scene(scene("rule = \"box\"\nmin = [1e-3, -1e-3, -1e-3]\nmax = [5e-3, 1e-3, 1e-3]\n"));
  EXPECT_EQ(kinds(s), (std::vector<GrainKind>{R, T10, T4, R, R, R}));
  EXPECT_NEAR(mesh_centroid(row_of_cubes(), 3).x(), 6e-3, 1e-15);
}

TEST_F(MixedTwin, D2minAboveAThresholdPicksTheScansShearBand) {
  write_text(dir_, "micro.h5", "");  // read by the reader given below
  std::filesystem::path asked;
  std::size_t asked_state = 9, asked_increment = 9;
  const D2minByLabel d2min = [&](const std::filesystem::path& micro, std::size_t state, std::size_t increment) {
    asked = micro, asked_state = state, asked_increment = increment;
    return std::map<std::uint32_t, double>{{10, 0.02}, {12, 0.005}, {13, 0.5}, {14, std::nextafter(0.01, 0.0)}, {99, 1.0}};
  };
  const Scene s = read_scene(scene("rule = \"d2min\"\nfile = \"micro.h5\"\nincrement = 2\nabove = 0.01\n"), std::filesystem::path(), d2min);
  EXPECT_EQ(asked, dir_ / "micro.h5");
  EXPECT_EQ(asked_state, 0u);
  EXPECT_EQ(asked_increment, 2u);
  EXPECT_EQ(kinds(s), (std::vector<GrainKind>{T4, R, R, T10, R, R}));
  EXPECT_EQ(s.model->deformable->rule, "D2min / d50^2 above 0.01 over increment 2 of micro.h5 (labels of its state 0)");
}

TEST_F(MixedTwin, TheMostLoadedGrainsOfAnEarlierRunsFrameArePicked) {
  results_with_mean_stress({5e6, 1e6, 9e6, 3e6, 9e6, 0});
  const Scene two = read_scene(scene("rule = \"most_loaded\"\nfile = \"rigid.h5\"\ncount = 2\n"));
  EXPECT_EQ(kinds(two), (std::vector<GrainKind>{R, R, T4, R, T4, R}));
  EXPECT_EQ(two.model->deformable->rule, "the 2 grains of highest mean stress in frame 0 of rigid.h5");
  const Scene half = read_scene(scene("rule = \"most_loaded\"\nfile = \"rigid.h5\"\nframe = 0\nshare = 0.5\n"));
  EXPECT_EQ(kinds(half), (std::vector<GrainKind>{T4, R, T4, R, T4, R}));
}

TEST_F(MixedTwin, BadRulesAreRefusedWithTheFileAndTheFix) {
  EXPECT_EQ(error_of("rule = \"labels\"\nlabels = [11, 99, 98]\n"),
            dir_.path().string() + "/scene.toml: [model.deformable]: label 99 is not a grain of grains.h5 (nor are 1 more); "
                                   "give labels of its grains");
  EXPECT_NE(error_of("rule = \"box\"\nmin = [1, 1, 1]\nmax = [2, 2, 2]\n").find("the rule picks no grain of grains.h5; widen it"),
            std::string::npos);
  EXPECT_NE(error_of("rule = \"d2min\"\nfile = \"gone.h5\"\nincrement = 0\nabove = 0.01\n").find("gone.h5 does not exist"),
            std::string::npos);
  EXPECT_NE(error_of("rule = \"most_loaded\"\nfile = \"gone.h5\"\ncount = 1\n").find("gone.h5 does not exist"), std::string::npos);
  EXPECT_NE(error_of("rule = \"shear_band\"\n").find("rule 'shear_band' is unknown; use labels, box, d2min or most_loaded"),
            std::string::npos);
  EXPECT_NE(error_of("labels = [11]\n").find("rule is missing"), std::string::npos);
  EXPECT_NE(error_of("rule = \"labels\"\nlabels = [11]\ncount = 2\n").find("key 'count' is unknown"), std::string::npos);
  EXPECT_NE(error_of("rule = \"labels\"\nlabels = []\n").find("labels must be a non-empty array"), std::string::npos);
  EXPECT_NE(error_of("rule = \"box\"\nmin = [0, 0, 0]\nmax = [1, -1, 1]\n").find("min must lie below max"), std::string::npos);
  write_text(dir_, "micro.h5", "");
  EXPECT_NE(error_of("rule = \"d2min\"\nfile = \"micro.h5\"\nincrement = 0\nabove = 0.01\n").find("cannot read kind=micro files"),
            std::string::npos);
  EXPECT_NE(error_of("rule = \"d2min\"\nfile = \"micro.h5\"\nabove = 0.01\n").find("increment is missing"), std::string::npos);
  const D2minByLabel short_file = [](const std::filesystem::path&, std::size_t, std::size_t) -> std::map<std::uint32_t, double> {
    throw UsageError("micro.h5 has no increment 4 (it holds 2); give an increment below 2");
  };
  EXPECT_NE(error_of("rule = \"d2min\"\nfile = \"micro.h5\"\nincrement = 4\nabove = 0.01\n", short_file)
                .find("[model.deformable]: micro.h5 has no increment 4"),
            std::string::npos);
  results_with_mean_stress({1, 2, 3, 4, 5, 6});
  EXPECT_NE(error_of("rule = \"most_loaded\"\nfile = \"rigid.h5\"\ncount = 7\n").find("count must lie in [1, 6]"), std::string::npos);
  EXPECT_NE(error_of("rule = \"most_loaded\"\nfile = \"rigid.h5\"\ncount = 1\nshare = 0.5\n").find("give count"), std::string::npos);
  EXPECT_NE(error_of("rule = \"most_loaded\"\nfile = \"rigid.h5\"\ncount = 1\nframe = 3\n").find("frame 3 is not in"), std::string::npos);
  EXPECT_NE(error_of("rule = \"most_loaded\"\nfile = \"grains.h5\"\ncount = 1\n").find("grains.h5"), std::string::npos);  // not results
  // A results file of another model lacks the row's labels.
  {
    Model other;
    add_grain(other, box_mesh(Eigen::Vector3d::Constant(1e-3), 1e-3), Eigen::Vector3d::Zero(), GrainKind::rigid, 0, 10);
    SolverOptions o;
    o.contact.enabled = false;
    const Solver solver(other, o);
    ResultsWriter writer(dir_ / "other.h5", solver, "{}");
    writer.add_frame(solver);
    writer.finish({"test"});
  }
  EXPECT_NE(error_of("rule = \"most_loaded\"\nfile = \"other.h5\"\ncount = 1\n").find("lacks 5 of the 6 grains of grains.h5"),
            std::string::npos);
  const auto both = write_text(dir_, "both.toml",
                               "[run]\nduration = 1e-6\n[model]\nfile = \"grains.h5\"\nkind = \"rigid\"\n[model.deformable]\n"
                               "rule = \"labels\"\nlabels = [11]\n");
  try {
    read_scene(both);
    ADD_FAILURE() << "accepted";
  } catch (const UsageError& e) {
    EXPECT_NE(e.message().find("contradict"), std::string::npos) << e.message();
  }
}

// A tet10 cube between two rigid cubes, stacked between platens that cut 1 um into the outer ones,
// settles: the rigid cubes pass the platens' load through their contacts with the deformable one,
// whose element stress is -F / A and equals its Love-Weber stress; the rigid cubes carry the same.
// Undamped beforehand, the energy books close over a few hundred steps.
TEST(MixedTwinRun, ADeformableGrainPressedByRigidOnesCarriesTheirLoad) {
  const double a = 1e-3, cut = 1e-6;
  Model m;
  add_grain(m, box_mesh(Eigen::Vector3d::Constant(a), a), Eigen::Vector3d(0, 0, -a), GrainKind::rigid, 0, 1);
  add_grain(m, box_mesh(Eigen::Vector3d::Constant(a), 0.5e-3), Eigen::Vector3d::Zero(), GrainKind::tet10, 0, 2);
  add_grain(m, box_mesh(Eigen::Vector3d::Constant(a), a), Eigen::Vector3d(0, 0, a), GrainKind::rigid, 0, 3);
  m.platens = {Platen{"bottom", Eigen::Vector3d(0, 0, -1.5 * a + cut), Eigen::Vector3d::UnitZ(), 0.0},
               Platen{"top", Eigen::Vector3d(0, 0, 1.5 * a - cut), -Eigen::Vector3d::UnitZ(), 0.0}};
  SolverOptions o;
  Solver s(m, o);
  const double dt = 0.9 * s.time_step_limits().stable();
  StepReport first = s.step(dt), last;
  for (int n = 0; n < 400; ++n) last = s.step(dt);
  // Books: mechanical energy + dissipated = what was put in + external work.
  const Energies& e = last.energies;
  const double stored = e.mechanical() + e.dissipated - e.external_work;
  EXPECT_NEAR(stored, first.energies.mechanical(), 1e-3 * std::max(e.mechanical(), 1e-30)) << "mechanical " << e.mechanical();
  EXPECT_GT(e.mechanical(), 0);
  s.set_damping(5e6);
  for (int n = 0; n < 6000; ++n) s.step(dt);
  const double F = s.platen_force(1).z();
  ASSERT_GT(F, 0);
  const Eigen::Matrix3d middle = s.grain_stress(1);
  EXPECT_NEAR(middle(2, 2), -F / (a * a), 2e-3 * F / (a * a));
  EXPECT_LT(relative_stress_difference(middle, s.love_weber_stresses()[1]), 1e-6);
  for (std::size_t g : {0, 2}) EXPECT_NEAR(s.grain_stress(g)(2, 2), -F / (a * a), 2e-3 * F / (a * a)) << "grain " << g;
}
