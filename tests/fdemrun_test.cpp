// fdemrun: CLI contract; a scene of a spinning elastic box and a falling rigid box against their
// exact motion; the results file (frames, series, platen schedule); grains from a kind=fdem_model
// file with a gmsh sphere beside them and VTK frames read back by VTK; a run split by --stop-step,
// --checkpoint and --restart reproducing the uninterrupted run bit for bit; a triaxial test of 27
// rigid cubes in the servo wall and in the membrane (stages, triaxial columns, frames at the asked
// strains, membrane positions), and the membrane test split over five processes, stopped in each of
// its four phases, matching the whole run bit for bit; bad scenes and options failing cleanly;
// grains started in each other or behind a platen refused, or relaxed apart; a run above the step
// ceiling and a model file's material out of range refused with the numbers.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <numbers>
#include <regex>

#include "graintwin/fdem/element.hpp"
#include "graintwin/fdem/model_file.hpp"
#include "graintwin/fdem/primitives.hpp"
#include "graintwin/fdem/results_file.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/io/schema.hpp"
#include "support/cli_contract.hpp"
#include "support/cube_sample.hpp"
#include "support/scene_text.hpp"
#include "support/simulation_results.hpp"
#include "support/vtk_summary.hpp"

using namespace graintwin;
using test::kTwoBoxScene;
using test::replaced;
using test::run_tool;
using test::write_text;

TEST(Fdemrun, StandardCli) { test::expect_standard_cli("fdemrun"); }

TEST(Fdemrun, SceneRunsToItsExactMotion) {
  test::TempDir dir;
  const auto scene = write_text(dir, "scene.toml", kTwoBoxScene);
  const auto out = dir / "results.h5";
  const auto r = run_tool("fdemrun", {scene.string(), out.string(), "-q"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::H5File f = io::H5File::open(out);
  EXPECT_EQ(f.attr_string("/", "kind").value_or(""), "fdem_results");
  EXPECT_EQ(f.read<std::uint32_t>("/grains/label"), (std::vector<std::uint32_t>{1, 42}));
  EXPECT_NE(io::read_history(f).back().find("fdemrun"), std::string::npos);
  const auto run = nlohmann::json::parse(f.read_strings("/run/parameters").at(0));
  const double dt = run["time_step"];
  const std::uint64_t steps = run["steps"], every = std::uint64_t(std::llround(1e-5 / dt));
  EXPECT_EQ(steps, 2 * std::uint64_t(std::llround(2e-5 / dt)));  // whole steps per stage
  const std::size_t frames = fdem::results_frame_count(out);
  EXPECT_EQ(frames, (steps - 1) / every + 2);  // every 10 us from 0, and the end
  const fdem::ResultsFrame last = fdem::read_results_frame(out, frames - 1);
  EXPECT_NEAR(last.time, 4e-5, dt);
  EXPECT_EQ(last.step, steps);
  // The rigid box flies exactly: z = v t - g t^2 / 2.
  const double t = last.time;
  EXPECT_NEAR(last.centroid[5], 1.5 * t - 0.5 * 9.81 * t * t, 1e-15);
  // The spinning box turned by omega t about z, and stays unstressed within the centrifugal level.
  const double angle = 2 * std::acos(std::min(1.0, std::abs(last.rotation[0])));
  EXPECT_NEAR(angle, 2000 * t, 1e-3 * 2000 * t);
  for (int k = 0; k < 9; ++k) EXPECT_LT(std::abs(last.stress[k]), 2e3);  // rho omega^2 r^2 ~ 1e3 Pa
  EXPECT_TRUE(last.pair.empty());
  // Series: rows every 2 us of the 40 us; the platen stood still, then moved at 0.5 m/s.
  const fdem::ResultsSeries s = fdem::read_results_series(out);
  ASSERT_EQ(s.time.size(), 20u);
  EXPECT_EQ(s.platen_position.size(), 20u * 3);
  EXPECT_NEAR(s.platen_position[3 * 5 + 2], 5e-3, 1e-15);  // row 5 (10 us), after the step of the still stage
  // The last row's platen has moved for (t - 20 us) plus the row's own step (~1e-8 s, 5e-9 m).
  EXPECT_NEAR(s.platen_position.back(), 5e-3 - 0.5 * (s.time.back() - 2e-5), 1e-8);
  for (std::size_t k = 0; k < s.time.size(); ++k) EXPECT_GT(s.kinetic[k], 0);
}

TEST(Fdemrun, ModelFileAndSphereFallWithVtkFrames) {
  test::TempDir dir;
  fdem::Model grains;
  fdem::add_grain(grains, fdem::box_mesh({1e-3, 1e-3, 1e-3}, 0.5e-3), Eigen::Vector3d::Zero(), fdem::GrainKind::tet4, 0, 5);
  grains.platens = {fdem::Platen{"bottom", Eigen::Vector3d(0, 0, -1), Eigen::Vector3d::UnitZ(), 0}};
  fdem::write_model_file(dir / "grains.h5", grains, {"test"});
  const auto scene = write_text(dir, "scene.toml", R"(
[run]
duration = 2e-5
gravity = [0, 0, -9.81]
contact = false
frame_interval = 1e-5
[model]
file = "grains.h5"
[[grains]]
shape = "sphere"
radius = 0.5e-3
position = [3e-3, 0, 0]
element_size = 0.25e-3
kind = "tet10"
velocity = [0, 0, -2]
)");
  const auto out = dir / "results.h5", frames = dir / "frames";
  const auto r = run_tool("fdemrun", {scene.string(), out.string(), "-q", "--vtk", frames.string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::H5File f = io::H5File::open(out);
  EXPECT_EQ(f.read<std::uint32_t>("/grains/label"), (std::vector<std::uint32_t>{5, 6}));  // file first, then primitives
  const std::size_t count = fdem::results_frame_count(out);
  ASSERT_GE(count, 3u);
  // The .pvd lists every frame with the results' times.
  std::stringstream pvd;
  pvd << std::ifstream(frames / "frames.pvd").rdbuf();
  const std::string text = pvd.str();
  const std::regex entry(R"re(timestep="([^"]+)"[^>]*file="(frame_\d{6}\.vtu)")re");
  std::vector<std::pair<double, std::string>> listed;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), entry); it != std::sregex_iterator(); ++it)
    listed.emplace_back(std::stod((*it)[1]), (*it)[2]);
  ASSERT_EQ(listed.size(), count);
  const fdem::ResultsFrame last = fdem::read_results_frame(out, count - 1);
  EXPECT_EQ(listed.back().first, last.time);
  // VTK reads the last frame: every node and element, displacements of free fall, no stress.
  const auto vtu = test::vtk_summary(frames / listed.back().second);
  EXPECT_EQ(vtu["point_data"]["displacement"]["tuples"].get<std::uint64_t>(), vtu["points"].get<std::uint64_t>());
  ASSERT_TRUE(vtu["point_data"].contains("displacement"));
  ASSERT_TRUE(vtu["point_data"].contains("velocity"));
  ASSERT_TRUE(vtu["cell_data"].contains("stress"));
  ASSERT_TRUE(vtu["cell_data"].contains("label"));
  EXPECT_EQ(vtu["cell_data"]["stress"]["components"].get<int>(), 9);
  const double t = last.time, fall = 0.5 * 9.81 * t * t;
  const auto range = vtu["point_data"]["displacement"]["range"];
  EXPECT_NEAR(range[0].get<double>(), fall, 1e-12);              // the box, dropped from rest
  EXPECT_NEAR(range[1].get<double>(), 2 * t + fall, 1e-12);      // the sphere, thrown down at 2 m/s
  EXPECT_LT(vtu["cell_data"]["stress"]["range"][1].get<double>(), 1.0);  // Pa: free fall strains nothing
  // VTK's cell volumes (quadratic cells split at their mid-edge nodes) add up to the grains' exact
  // ones: its node order agrees with ours; and the curved sphere is a sphere.
  const auto volumes = f.read<double>("/grains/volume");
  EXPECT_NEAR(vtu["volume"].get<double>() / (volumes[0] + volumes[1]), 1.0, 0.01);
  EXPECT_NEAR(volumes[1] / (4.0 / 3.0 * std::numbers::pi * 0.125e-9), 1.0, 0.01);
}

namespace {

/// Three 1 mm tet10 cubes stacked along z (labels 7, 8, 9), written to dir/stack.h5.
fdem::Model write_cube_stack(const std::filesystem::path& dir) {
  fdem::Model stack;
  for (int k = 0; k < 3; ++k)
    fdem::add_grain(stack, fdem::box_mesh(Eigen::Vector3d::Constant(1e-3), 0.5e-3), Eigen::Vector3d(0, 0, 1e-3 * (k - 1)),
                    fdem::GrainKind::tet10, 0, static_cast<std::uint32_t>(7 + k));
  fdem::write_model_file(dir / "stack.h5", stack, {"test"});
  return stack;
}

/// Scene text: the platens that hold the stack 1 um into its end faces.
constexpr const char* kStackPlatens = R"([[platens]]
name = "bottom"
point = [0, 0, -1.499e-3]
normal = [0, 0, 1]
[[platens]]
name = "top"
point = [0, 0, 1.499e-3]
normal = [0, 0, -1]
)";

}  // namespace

// A mixed twin: three cubes of a model file stacked between the platens, the middle one (tet10 in
// the file) picked deformable by label, the others rigid; the log and the run's parameters say how
// many of each kind and which rule picked them, the frames hold the middle cube's element stresses,
// the closing lines compare its two stresses, which agree once the stack has settled, and the
// energy books close over the run.
TEST(Fdemrun, AMixedTwinRecordsItsKindsAndComparesItsStresses) {
  test::TempDir dir;
  const fdem::Model stack = write_cube_stack(dir.path());
  const std::string stack_scene = R"(
[run]
duration = 2e-5
damping = 5e6
frame_interval = 5e-6
[model]
file = "stack.h5"
[model.deformable]
rule = "labels"
labels = [8]
)" + std::string(kStackPlatens);
  const auto scene = write_text(dir, "scene.toml", stack_scene);
  const auto out = dir / "results.h5";
  const auto r = run_tool("fdemrun", {scene.string(), out.string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("grains: 2 rigid, 0 tet4, 1 tet10; the model file's deformable ones (1) picked by labels (1 given)"),
            std::string::npos) << r.err;
  EXPECT_NE(r.err.find("stress of the deformable grains (1), Love-Weber"), std::string::npos) << r.err;
  const io::H5File f = io::H5File::open(out);
  const auto kinds = nlohmann::json::parse(f.read_strings(schema::fdem_results::parameters).at(0))["grain_kinds"];
  EXPECT_EQ(kinds, nlohmann::json({{"rigid", 2}, {"tet4", 0}, {"tet10", 1}, {"deformable_rule", "labels (1 given)"}}));
  const std::size_t frames = fdem::results_frame_count(out);
  const auto elements = fdem::read_frame_element_stress(out, frames - 1);
  EXPECT_EQ(elements.grain, std::vector<std::uint32_t>(stack.grains[1].element_end - stack.grains[1].element_begin, 1));
  const double last = f.attr_double(fmt::format("/frames/{:06d}", frames - 1), schema::fdem_results::frame_stress_difference);
  EXPECT_LT(last, 1e-6);
  // The energy books close: mechanical energy + dissipated - external work stays what it started as.
  const auto s = fdem::read_results_series(out);
  const auto booked = [&](std::size_t k) { return s.kinetic[k] + s.strain[k] + s.contact_elastic[k] + s.dissipated[k] - s.external_work[k]; };
  ASSERT_GT(s.time.size(), 100u);
  EXPECT_NEAR(booked(s.time.size() - 1), booked(0), 1e-3 * booked(0));

  // The same stack with the rigid cubes' elastostatic stresses: every element of the three cubes
  // has a row, and the rigid cubes' elements carry the load the deformable one does (on average:
  // the coarse cubes' element stresses range over 0.4-1.0 of it, from the face the tet10 cube's
  // nodes press on to the platen's).
  const auto elastostatic = write_text(dir, "elastostatic.toml", replaced(stack_scene, "[run]\n", "[run]\nrigid_stress = \"elastostatic\"\n"));
  const auto both = dir / "both.h5";
  const auto e = run_tool("fdemrun", {elastostatic.string(), both.string(), "--vtk", (dir / "frames").string()});
  ASSERT_EQ(e.exit_code, 0) << e.err;
  const auto rows = fdem::read_frame_element_stress(both, fdem::results_frame_count(both) - 1);
  ASSERT_EQ(rows.grain.size(), stack.element_count());
  const auto frame = fdem::read_results_frame(both, fdem::results_frame_count(both) - 1);
  EXPECT_EQ(frame.centroid, fdem::read_results_frame(out, frames - 1).centroid);  // the run is the same run
  EXPECT_EQ(frame.stress, fdem::read_results_frame(out, frames - 1).stress);
  const double load = frame.stress[9 * 1 + 8];  // the deformable cube's sigma_zz, compression positive
  ASSERT_GT(load, 0);
  // Each rigid cube's element stresses, volume-averaged, are its Love-Weber stress: the load.
  for (const std::uint32_t g : {0u, 2u}) {
    double average = 0, volume = 0;
    for (std::size_t k = 0; k < rows.grain.size(); ++k)
      if (rows.grain[k] == g) {
        const double v = fdem::element_volume(stack, rows.element[k]);
        average += v * rows.stress[9 * k + 8], volume += v;
      }
    EXPECT_NEAR(average / volume, frame.stress[9 * g + 8], 1e-5 * load) << "grain " << g;
    EXPECT_NEAR(average / volume, load, 1e-3 * load) << "grain " << g;
  }
}


// The elastostatic stress of rigid grains against what it stands for: the same stack of three
// cubes, once all tet10 and settled under damping, once all rigid with rigid_stress =
// "elastostatic". Element by element, over each run's load, the rigid cubes' stresses are the
// settled deformable ones'.
TEST(Fdemrun, ElastostaticStressesOfRigidCubesAreTheSettledTet10Ones) {
  test::TempDir dir;
  const fdem::Model stack = write_cube_stack(dir.path());
  const std::string deformable = R"(
[run]
duration = 4e-5
damping = 5e6
[model]
file = "stack.h5"
)" + std::string(kStackPlatens);
  const auto settled = dir / "settled.h5", rigid = dir / "rigid.h5";
  ASSERT_EQ(run_tool("fdemrun", {write_text(dir, "settled.toml", deformable).string(), settled.string()}).exit_code, 0);
  const std::string elastostatic =
      replaced(replaced(deformable, "[run]\n", "[run]\nrigid_stress = \"elastostatic\"\n"), "file = \"stack.h5\"\n", "file = \"stack.h5\"\nkind = \"rigid\"\n");
  const auto r = run_tool("fdemrun", {write_text(dir, "rigid.toml", elastostatic).string(), rigid.string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto a = fdem::read_frame_element_stress(settled, fdem::results_frame_count(settled) - 1);
  const auto b = fdem::read_frame_element_stress(rigid, fdem::results_frame_count(rigid) - 1);
  ASSERT_EQ(a.element, b.element);
  ASSERT_EQ(a.element.size(), stack.element_count());
  // Each run's stresses over its own load (the platen force over the face: the two stacks' springs
  // in series differ by the tet10 cubes' own compliance).
  const auto load_of = [](const std::filesystem::path& results) {
    const auto frame = fdem::read_results_frame(results, fdem::results_frame_count(results) - 1);
    return frame.stress[9 * 1 + 8];
  };
  const double la = load_of(settled), lb = load_of(rigid);
  double worst = 0, mean = 0;
  for (std::size_t k = 0; k < a.stress.size(); ++k) {
    const double d = std::abs(a.stress[k] / la - b.stress[k] / lb);
    worst = std::max(worst, d), mean += d / static_cast<double>(a.stress.size());
  }
  // 1.3 % at worst and 0.18 % on average, the same after 1e-4 s: settled; what remains is how the
  // deformable cubes' own compliance spreads the node forces at their contacts.
  EXPECT_LT(worst, 2e-2);
  EXPECT_LT(mean, 3e-3);
}

namespace {

/// The last frames of two results files agree bit for bit.
void expect_same_last_frame(const std::filesystem::path& a, const std::filesystem::path& b) {
  const auto x = fdem::read_results_frame(a, fdem::results_frame_count(a) - 1);
  const auto y = fdem::read_results_frame(b, fdem::results_frame_count(b) - 1);
  EXPECT_EQ(x.step, y.step);
  EXPECT_EQ(x.time, y.time);
  EXPECT_EQ(x.centroid, y.centroid);
  EXPECT_EQ(x.rotation, y.rotation);
  EXPECT_EQ(x.stress, y.stress);
  EXPECT_EQ(x.velocity, y.velocity);
}

}  // namespace

TEST(Fdemrun, RestartFromCheckpointReproducesTheRunBitForBit) {
  test::TempDir dir;
  const auto scene = write_text(dir, "scene.toml", kTwoBoxScene);
  const auto whole = dir / "whole.h5", first = dir / "first.h5", second = dir / "second.h5", ckpt = dir / "ckpt.h5";
  ASSERT_EQ(run_tool("fdemrun", {scene.string(), whole.string(), "-q"}).exit_code, 0);
  const auto a = run_tool("fdemrun", {scene.string(), first.string(), "-q", "--stop-step", "37", "--checkpoint", ckpt.string()});
  ASSERT_EQ(a.exit_code, 0) << a.err;
  const auto b = run_tool("fdemrun", {scene.string(), second.string(), "-q", "--restart", ckpt.string()});
  ASSERT_EQ(b.exit_code, 0) << b.err;
  expect_same_last_frame(whole, second);
  const auto sw = fdem::read_results_series(whole), sr = fdem::read_results_series(second);
  ASSERT_FALSE(sr.step.empty());
  const std::size_t offset = sw.step.size() - sr.step.size();
  EXPECT_EQ(sw.step[offset], sr.step[0]);
  for (std::size_t k = 0; k < sr.step.size(); ++k) EXPECT_EQ(sw.kinetic[offset + k], sr.kinetic[k]) << "row " << k;
}

TEST(Fdemrun, BadInputsFailCleanly) {
  test::TempDir dir;
  const auto good = write_text(dir, "good.toml", kTwoBoxScene);
  const auto out = (dir / "out.h5").string();
  test::expect_clean_failure("fdemrun", dir, {(dir / "missing.toml").string(), out}, 2, "missing.toml");
  const auto typo = write_text(dir, "typo.toml", replaced(kTwoBoxScene, "element_size = 1e-3", "element_sise = 1e-3"));
  test::expect_clean_failure("fdemrun", dir, {typo.string(), out}, 2, "key 'element_sise' is unknown; did you mean 'element_size'?");
  const auto sphere = write_text(dir, "sphere.toml", replaced(kTwoBoxScene, "kind = \"rigid\"", "kind = \"rigid\"\nshape = \"sphere\""));
  test::expect_clean_failure("fdemrun", dir, {sphere.string(), out}, 2, "size does not apply to a sphere");
  const auto no_model = write_text(dir, "no_model.toml", replaced(kTwoBoxScene, "[run]", "[model]\nfile = \"gone.h5\"\n[run]"));
  test::expect_clean_failure("fdemrun", dir, {no_model.string(), out}, 2, "gone.h5 does not exist");
  const auto fast = write_text(dir, "fast.toml", replaced(kTwoBoxScene, "contact = false", "contact = false\ntime_step = 1e-6"));
  test::expect_clean_failure("fdemrun", dir, {fast.string(), out}, 2, "above the stable limit");
  const auto syntax = write_text(dir, "syntax.toml", "[run\nduration = 1");
  test::expect_clean_failure("fdemrun", dir, {syntax.string(), out}, 2, "syntax.toml line 1");
  const auto material = write_text(dir, "material.toml", replaced(kTwoBoxScene, "material = \"glass\"", "material = \"steel\""));
  test::expect_clean_failure("fdemrun", dir, {material.string(), out}, 2, "material 'steel' is not among the [[materials]]");
  const auto rigid_stress = write_text(dir, "rigid_stress.toml", replaced(kTwoBoxScene, "[run]\n", "[run]\nrigid_stress = \"exact\"\n"));
  test::expect_clean_failure("fdemrun", dir, {rigid_stress.string(), out}, 2, "rigid_stress must be \"love_weber\"");
  test::expect_clean_failure("fdemrun", dir, {good.string(), (dir / "out.txt").string()}, 2, "must end in .h5");
  // A checkpoint of another scene is refused before anything is written.
  const auto ckpt = dir / "ckpt.h5";
  ASSERT_EQ(run_tool("fdemrun", {good.string(), out, "-q", "--stop-step", "3", "--checkpoint", ckpt.string()}).exit_code, 0);
  const auto other = write_text(dir, "other.toml", replaced(kTwoBoxScene, "angular_velocity = [0, 0, 2000]", "angular_velocity = [0, 0, 1000]"));
  test::expect_clean_failure("fdemrun", dir, {other.string(), (dir / "o.h5").string(), "--restart", ckpt.string()}, 2,
                             "written for another scene");
  // A --stop-step at or before the checkpoint's step is refused rather than run one step too far.
  test::expect_clean_failure("fdemrun", dir,
                             {good.string(), (dir / "s.h5").string(), "--restart", ckpt.string(), "--stop-step", "3"}, 2,
                             "--stop-step 3 is not beyond step 3");
  // An existing output (results or VTK folder) is refused without --force.
  test::expect_clean_failure("fdemrun", dir, {good.string(), out}, 2, "out.h5");
  std::filesystem::create_directory(dir / "old_frames");
  test::expect_clean_failure("fdemrun", dir, {good.string(), (dir / "new.h5").string(), "--vtk", (dir / "old_frames").string()},
                             2, "old_frames");
  // An existing checkpoint is a user's file like any output: refused without --force, byte for byte
  // as it was; with --force the run replaces it.
  const auto bytes_of = [](const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  };
  const std::string ckpt_before = bytes_of(ckpt);
  test::expect_clean_failure("fdemrun", dir,
                             {good.string(), (dir / "c.h5").string(), "--stop-step", "5", "--checkpoint", ckpt.string()}, 2,
                             "ckpt.h5");
  EXPECT_EQ(bytes_of(ckpt), ckpt_before);
  const auto forced = run_tool("fdemrun", {good.string(), (dir / "c.h5").string(), "-q", "--stop-step", "5", "--checkpoint",
                                           ckpt.string(), "--force"});
  ASSERT_EQ(forced.exit_code, 0) << forced.err;
  EXPECT_NE(bytes_of(ckpt), ckpt_before);
}

namespace {

/// A rigid box whose bottom starts 0.3 mm behind the bottom platen, and two elastic boxes started
/// half through each other (their corners on each other's faces), under gravity.
const char* kOverlapScene = R"(
[run]
duration = 2e-5
gravity = [0, 0, -9.81]
frame_interval = 1e-5

[[grains]]
size = [1e-3, 1e-3, 1e-3]
position = [0, 0, 0.2e-3]
element_size = 0.5e-3
kind = "rigid"

[[grains]]
size = [1e-3, 1e-3, 1e-3]
position = [3e-3, 0, 0.6e-3]
element_size = 0.25e-3
kind = "tet4"

[[grains]]
size = [1e-3, 1e-3, 1e-3]
position = [3.5e-3, 0, 0.6e-3]
element_size = 0.25e-3
kind = "tet4"

[[platens]]
name = "bottom"
point = [0, 0, 0]
normal = [0, 0, 1]
)";

}  // namespace

TEST(Fdemrun, GrainsStartedInsideEachOtherOrAPlatenAreRefused) {
  // Run as they were, the box in the platen flew off at 549 m/s and the two boxes never parted.
  test::TempDir dir;
  const auto out = (dir / "out.h5").string();
  const auto both = write_text(dir, "both.toml", kOverlapScene);
  test::expect_clean_failure("fdemrun", dir, {both.string(), out}, 2,
                             "both.toml: grains label 2 and label 3 overlap by 0.5 mm at the start, beyond the tolerance "
                             "of 0.124 mm ([run] overlap_tolerance = 0.1 x the smaller grain's equivalent diameter, "
                             "1.24 mm) (2 overlaps in all are beyond theirs); move them apart, or set [run] "
                             "relax_overlaps = true to push overlapping grains apart before the run");
  const auto platen = write_text(dir, "platen.toml", replaced(kOverlapScene, "position = [3.5e-3, 0, 0.6e-3]", "position = [5e-3, 0, 0.6e-3]"));
  test::expect_clean_failure("fdemrun", dir, {platen.string(), out}, 2,
                             "platen.toml: grain label 1 reaches 0.3 mm behind platen 'bottom' at the start, beyond the "
                             "tolerance of 0.124 mm ([run] overlap_tolerance = 0.1 x the grain's equivalent diameter, "
                             "1.24 mm); move them apart");
  // A wider tolerance accepts the pair (half a box: 0.5 mm), as contact off does.
  const auto wide = write_text(dir, "wide.toml", replaced(replaced(kOverlapScene, "position = [0, 0, 0.2e-3]", "position = [0, 0, 0.5e-3]"),
                                                          "frame_interval", "overlap_tolerance = 0.45\nframe_interval"));
  EXPECT_EQ(run_tool("fdemrun", {wide.string(), out, "-q"}).exit_code, 0);
  const auto off = write_text(dir, "off.toml", replaced(kOverlapScene, "frame_interval", "contact = false\nframe_interval"));
  EXPECT_EQ(run_tool("fdemrun", {off.string(), out, "-q", "--force"}).exit_code, 0);
}

TEST(Fdemrun, RelaxedOverlapsPartTheBoxesAndLiftTheGrainOutOfThePlatenAtSaneSpeeds) {
  test::TempDir dir;
  const auto scene = write_text(dir, "relax.toml", replaced(kOverlapScene, "frame_interval", "relax_overlaps = true\nframe_interval"));
  const auto out = dir / "out.h5";
  const auto r = run_tool("fdemrun", {scene.string(), out.string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("relaxed the initial overlaps ([run] relax_overlaps)"), std::string::npos) << r.err;
  const fdem::ResultsFrame first = fdem::read_results_frame(out, 0);
  const fdem::ResultsFrame last = fdem::read_results_frame(out, fdem::results_frame_count(out) - 1);
  // The grain in the platen starts on it, the boxes side by side; they stay so, at the speeds of
  // gravity and of the few hundred nanometres of overlap left (a hundredth of the tolerance).
  const double tolerance = 0.1 * std::cbrt(6 / std::numbers::pi) * 1e-3;
  EXPECT_NEAR(first.centroid[2], 0.5e-3, 0.011 * tolerance);
  EXPECT_NEAR(first.centroid[6] - first.centroid[3], 1e-3, 0.011 * tolerance);
  EXPECT_NEAR(last.centroid[6] - last.centroid[3], 1e-3, 0.011 * tolerance);
  for (std::size_t k = 0; k < last.velocity.size(); ++k) EXPECT_LT(std::abs(last.velocity[k]), 0.05) << k;
  for (const double overlap : last.overlap) EXPECT_LT(overlap, 0.011 * tolerance);
  const auto run = nlohmann::json::parse(io::H5File::open(out).read_strings("/run/parameters").at(0));
  EXPECT_NEAR(run["initial_overlaps"]["deepest"].get<double>(), 0.5e-3, 1e-12);
  EXPECT_EQ(run["initial_overlaps"]["moved_grains"].get<int>(), 3);
}

TEST(Fdemrun, KeptInitialOverlapsStartTheBoxesAtRestWhereThePenaltyFiresThemApart) {
  // The two 4-node boxes start 0.08 mm into each other (within the 0.1 mm a step's search looks,
  // so the penalty sees them; deeper kept overlaps: fdem_contact_test); the rigid box rests on the
  // platen. (Half a box deep, as in kOverlapScene, a kept node sits near the middle of the other
  // box and flips between its faces: docs/fdemrun.md.)
  test::TempDir dir;
  const std::string wide =
      replaced(replaced(replaced(kOverlapScene, "position = [0, 0, 0.2e-3]", "position = [0, 0, 0.5e-3]"), "position = [3.5e-3, 0, 0.6e-3]",
                        "position = [3.92e-3, 0, 0.6e-3]"),
               "frame_interval", "overlap_tolerance = 0.45\nframe_interval");
  const auto fired = write_text(dir, "fired.toml", wide);
  const auto kept = write_text(dir, "kept.toml", replaced(wide, "frame_interval", "keep_initial_overlaps = true\nframe_interval"));
  const auto fastest = [&](const std::filesystem::path& scene, const std::string& name) {
    const auto out = dir / name;
    const auto r = run_tool("fdemrun", {scene.string(), out.string()});
    EXPECT_EQ(r.exit_code, 0) << r.err;
    const fdem::ResultsFrame last = fdem::read_results_frame(out, fdem::results_frame_count(out) - 1);
    double v = 0;
    for (const double c : last.velocity) v = std::max(v, std::abs(c));
    return std::make_pair(v, r.err);
  };
  const auto [fired_speed, fired_log] = fastest(fired, "fired.h5");
  const auto [kept_speed, kept_log] = fastest(kept, "kept.h5");
  EXPECT_GT(fired_speed, 1.0) << fired_log;
  // At rest but for gravity over the run (20 us: 0.2 mm/s).
  EXPECT_LT(kept_speed, 0.01) << kept_log;
  EXPECT_NE(kept_log.find("initial overlaps kept force-free ([run] keep_initial_overlaps), the deepest 0.08 mm"), std::string::npos)
      << kept_log;
}

TEST(Fdemrun, ARunBeyondTheStepCeilingIsRefusedWithTheNumbers) {
  test::TempDir dir;
  const auto out = (dir / "out.h5").string();
  // A penalty far too stiff shrinks the contact's time step until the 40 us of the scene take
  // hundreds of millions of steps: refused before the first, with what sets the step.
  const auto stiff = write_text(dir, "stiff.toml", replaced(replaced(kTwoBoxScene, "contact = false\n", ""), "poisson = 0.2",
                                                             "poisson = 0.2\nnormal_penalty = 1e22\ntangential_penalty = 1e22"));
  const auto r = run_tool("fdemrun", {stiff.string(), out});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  for (const char* words : {"stiff.toml: the run would take", "s of stages at", "above the ceiling of 1e+07 steps",
                            "is the contact limit", "soften the penalty", "raise [run] max_steps"})
    EXPECT_NE(r.err.find(words), std::string::npos) << words << "\n" << r.err;
  EXPECT_FALSE(std::filesystem::exists(out));
  // The ceiling is the scene's: a low one refuses the plain scene, set by its elements' limit.
  const auto low = write_text(dir, "low.toml", replaced(kTwoBoxScene, "contact = false", "contact = false\nmax_steps = 100"));
  test::expect_clean_failure("fdemrun", dir, {low.string(), out}, 2, "above the ceiling of 100 steps; the time step");
  test::expect_clean_failure("fdemrun", dir, {low.string(), out}, 2, "is the element limit");
  const auto none = write_text(dir, "none.toml", replaced(kTwoBoxScene, "contact = false", "contact = false\nmax_steps = 0"));
  test::expect_clean_failure("fdemrun", dir, {none.string(), out}, 2, "max_steps must lie in [1, 1e+15] (got 0)");
}

TEST(Fdemrun, AModelFileMaterialOutOfRangeIsRefusedNamingTheFile) {
  // The same Young's modulus of 0 that a scene's [[materials]] refuses, and a negative density
  // (whose message named no file), in a model file.
  test::TempDir dir;
  fdem::Model grains;
  fdem::add_grain(grains, fdem::box_mesh({1e-3, 1e-3, 1e-3}, 0.5e-3), Eigen::Vector3d::Zero(), fdem::GrainKind::tet4, 0, 5);
  const auto model = dir / "grains.h5";
  fdem::write_model_file(model, grains, {"test"});
  const auto scene = write_text(dir, "scene.toml", "[run]\nduration = 1e-6\n[model]\nfile = \"grains.h5\"\n");
  const auto out = (dir / "out.h5").string();
  test::replace_dataset(model, "/materials/young", std::vector<double>{0.0}, {1});
  test::expect_clean_failure("fdemrun", dir, {scene.string(), out}, 1,
                             model.string() + ": material 'ottawa_sand': young must lie in [1000, 1e+13] Pa (got 0 Pa)");
  test::replace_dataset(model, "/materials/young", std::vector<double>{92.1e9}, {1});
  test::replace_dataset(model, "/materials/density", std::vector<double>{-2650.0}, {1});
  test::expect_clean_failure("fdemrun", dir, {scene.string(), out}, 1, model.string() + ": material 'ottawa_sand': density");
  const auto in_scene = write_text(dir, "young.toml", "[run]\nduration = 1e-6\n[[materials]]\nyoung = 0\n[[grains]]\nsize = [1e-3, 1e-3, 1e-3]\n");
  test::expect_clean_failure("fdemrun", dir, {in_scene.string(), out}, 2,
                             "young.toml: [[materials]] 1: young must lie in [1000, 1e+13] Pa (got 0 Pa)");
}

namespace {

/// A triaxial scene over a model file of 27 rigid cubes (support/cube_sample.hpp); `boundary` is
/// the [triaxial] boundary key.
std::filesystem::path triaxial_scene(const test::TempDir& dir, const std::string& boundary) {
  const fdem::Model cubes = test::cube_sample(1e-3);
  fdem::write_model_file(dir / "cubes.h5", cubes, {"test"});
  return write_text(dir, boundary + ".toml", R"(
[run]
damping = 2000
[model]
file = "cubes.h5"
[triaxial]
boundary = ")" + boundary + R"("
ball_radius = 1.4e-4
strain_rate = 5
target_axial_strain = 2e-3
shear_ramp_strain = 1e-3
frame_strains = [5e-4, 1e-3]
pressure_ramp_steps = 500
)");
}

/// The checks of a finished triaxial run of triaxial_scene(boundary) to 2e-3 strain: its stages,
/// series columns, platen ramp, end state and frames at the asked strains.
void expect_triaxial_results(const std::filesystem::path& out, const std::string& boundary) {
  SCOPED_TRACE(boundary);
  namespace sr = schema::fdem_results;
  const io::H5File f = io::H5File::open(out);
  const auto stages = f.read_strings(sr::stage_name);
  const std::vector<std::string> expected_stages =
      boundary == "wall" ? std::vector<std::string>{"consolidation", "shearing"}
                         : std::vector<std::string>{"consolidation", "membrane", "shearing"};
  EXPECT_EQ(stages, expected_stages);
  const auto stage = f.read<std::uint32_t>(sr::series_stage);
  const auto eps1 = f.read<double>(sr::series_axial_strain), epsv = f.read<double>(sr::series_volumetric_strain);
  const auto ratio = f.read<double>(sr::series_stress_ratio), lateral = f.read<double>(sr::series_lateral_stress);
  const auto volume = f.read<double>(sr::series_volume), radial = f.read<double>(sr::series_volume_radial);
  const auto inertial = f.read<double>(sr::series_inertial_number), kinetic = f.read<double>(sr::series_kinetic_ratio);
  ASSERT_EQ(eps1.size(), stage.size());
  ASSERT_EQ(kinetic.size(), stage.size());
  // The cubes start apart: no stored energy, so no kinetic ratio (NaN), never an infinity.
  EXPECT_TRUE(std::isnan(kinetic.front()));
  EXPECT_TRUE(std::none_of(kinetic.begin(), kinetic.end(), [](double k) { return std::isinf(k); }));
  const std::uint32_t shearing = static_cast<std::uint32_t>(stages.size() - 1);
  double before = -1;
  for (std::size_t i = 0; i < stage.size(); ++i) {
    // Strains and the inertial number exist from the start of shearing on, the volumes agree.
    EXPECT_EQ(std::isnan(eps1[i]), stage[i] != shearing) << "row " << i;
    EXPECT_EQ(std::isnan(inertial[i]), stage[i] != shearing) << "row " << i;
    EXPECT_NEAR(radial[i], volume[i], 1e-9 * volume[i]) << "row " << i;
    // sigma_1 / sigma_3 is NaN exactly while the lateral boundary carries nothing (the wall not
    // yet reached, the membrane held without pressure), never an infinity.
    EXPECT_EQ(std::isnan(ratio[i]), !(lateral[i] > 0)) << "row " << i;
    EXPECT_FALSE(std::isinf(ratio[i])) << "row " << i;
    if (stage[i] == shearing) {
      EXPECT_GE(eps1[i], before);
      before = eps1[i];
    }
  }
  EXPECT_NEAR(eps1.back(), 2e-3, 1e-5);
  // The platens start from rest and reach full speed over the scene's ramp of 1e-3 strain: the
  // gap closes by 2, 3, 4 ... parts in successive steps, then by strain_rate x H0 x dt.
  const auto height = f.read<double>(sr::series_height);
  const auto first = static_cast<std::size_t>(std::find(stage.begin(), stage.end(), shearing) - stage.begin());
  const double d1 = height[first] - height[first + 1], d2 = height[first + 1] - height[first + 2];
  EXPECT_NEAR(d2 / d1, 1.5, 1e-3);
  const double full = height[height.size() - 2] - height.back();
  EXPECT_GT(full, 10 * d1);
  EXPECT_TRUE(std::isfinite(epsv.back()));
  EXPECT_NEAR(lateral.back(), 300e3, 0.02 * 300e3);  // the wall servo or the membrane pressure
  EXPECT_GT(ratio.back(), 1.5);                      // columns of rigid cubes carry the platens
  // Frames: the start of shearing, the two asked strains, the end.
  ASSERT_EQ(fdem::results_frame_count(out), 4u);
  const std::vector<double> asked{0.0, 5e-4, 1e-3, 2e-3};
  for (std::size_t k = 0; k < 4; ++k) {
    const std::string g = fmt::format("{}/{:06d}", sr::frames, k);
    EXPECT_NEAR(f.attr_doubles(g, "axial_strain").at(0), asked[k], 2e-5) << "frame " << k;
    EXPECT_EQ(f.exists(g + "/" + sr::frame_membrane_position), boundary == "membrane");
  }
  const auto parameters = nlohmann::json::parse(f.read_strings(sr::parameters).at(0));
  EXPECT_GT(parameters["triaxial"]["shear_steps"].get<int>(), 0);
  EXPECT_EQ(parameters["triaxial"]["membrane_balls"].get<int>() > 0, boundary == "membrane");
}

}  // namespace

// The wall here; the membrane's whole run is checked the same way in the split run's test below
// (one membrane run less in the suite).
TEST(Fdemrun, TriaxialTestWritesItsSeriesStagesAndFramesAtTheAskedStrains) {
  test::TempDir dir;
  const auto out = dir / "wall.h5";
  const auto r = run_tool("fdemrun", {triaxial_scene(dir, "wall").string(), out.string(), "-q", "-j", "1", "--model",
                                      (dir / "cubes.h5").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  expect_triaxial_results(out, "wall");
}

TEST(Fdemrun, BadTriaxialScenesFailBeforeAnyStep) {
  test::TempDir dir;
  const auto scene = triaxial_scene(dir, "wall");
  std::stringstream text;
  text << std::ifstream(scene).rdbuf();
  const auto out = (dir / "out.h5").string();
  const auto bad = [&](const std::string& name, const std::string& from, const std::string& to, const std::string& says) {
    const auto path = write_text(dir, name, replaced(text.str(), from, to));
    test::expect_clean_failure("fdemrun", dir, {path.string(), out}, 2, says);
  };
  bad("latex.toml", "ball_radius", "membrane_poisson = 0.45\nball_radius", "above 1/3");
  bad("stages.toml", "[triaxial]", "[[stages]]\nduration = 1e-5\n[triaxial]", "runs its own stages");
  bad("order.toml", "[5e-4, 1e-3]", "[1e-3, 5e-4]", "ascending");
  bad("beyond.toml", "[5e-4, 1e-3]", "[5e-4, 0.1]", "ascending");
  bad("kind.toml", "boundary = \"wall\"", "boundary = \"latex\"", "use membrane or wall");
  bad("both.toml", "strain_rate = 5", "strain_rate = 5\nshear_inertial_number = 1e-3", "keep one");
  bad("ramp.toml", "shear_ramp_strain = 1e-3", "shear_ramp_strain = 0.01", "below target_axial_strain");
  // A triaxial run restarts only from a triaxial checkpoint of the same scene.
  const auto plain = write_text(dir, "plain.toml", kTwoBoxScene), plain_ckpt = dir / "plain_ckpt.h5";
  ASSERT_EQ(run_tool("fdemrun", {plain.string(), (dir / "plain.h5").string(), "-q", "--stop-step", "3", "--checkpoint",
                                 plain_ckpt.string()})
                .exit_code,
            0);
  test::expect_clean_failure("fdemrun", dir, {scene.string(), out, "--restart", plain_ckpt.string()}, 2,
                             "written for another scene");
}

TEST(Fdemrun, TriaxialRunSplitInEveryPhaseIsTheWholeRunBitForBit) {
  test::TempDir dir;
  const auto scene = triaxial_scene(dir, "membrane");
  const auto whole = dir / "whole.h5";
  const std::vector<std::string> common{"-q", "-j", "1"};
  const auto run = [&](std::vector<std::string> args) {
    args.insert(args.end(), common.begin(), common.end());
    const auto r = run_tool("fdemrun", args);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return r.exit_code == 0;
  };
  ASSERT_TRUE(run({scene.string(), whole.string(), "--model", (dir / "cubes.h5").string()}));
  expect_triaxial_results(whole, "membrane");
  const auto parameters = [](const std::filesystem::path& results) {
    return nlohmann::json::parse(io::H5File::open(results).read_strings(schema::fdem_results::parameters).at(0));
  };
  const auto summary = parameters(whole)["triaxial"];
  const auto wall = summary["consolidation_steps"].get<std::uint64_t>();
  const auto membrane = summary["membrane_steps"].get<std::uint64_t>();
  const auto shearing = summary["shear_steps"].get<std::uint64_t>();
  const auto whole_series = fdem::read_results_series(whole);
  const auto stages_of = [](const std::filesystem::path& results) {
    return io::H5File::open(results).read<std::uint32_t>(schema::fdem_results::series_stage);
  };
  const auto whole_stage = stages_of(whole);
  // One run in five processes, each restarting from the previous one's checkpoint: stops in the
  // wall's consolidation, while the membrane is held (it is for at least 100 steps), while its
  // pressure ramps up (the first row past 30 % of sigma_3), and while shearing.
  const auto lateral = io::H5File::open(whole).read<double>(schema::fdem_results::series_lateral_stress);
  std::size_t ramping = 0;
  while (ramping < lateral.size() && !(whole_stage[ramping] == 1 && lateral[ramping] > 0.3 * 300e3)) ++ramping;
  ASSERT_LT(ramping, lateral.size());
  std::filesystem::path restart_from;
  std::size_t rows = 0;
  const std::vector<std::uint64_t> stops{wall / 2, wall + 50, whole_series.step[ramping], wall + membrane + shearing / 2, 0};
  for (std::size_t part = 0; part < stops.size(); ++part) {
    SCOPED_TRACE("part " + std::to_string(part));
    const auto results = dir / fmt::format("part{}.h5", part), ckpt = dir / fmt::format("ckpt{}.h5", part);
    std::vector<std::string> args{scene.string(), results.string()};
    if (stops[part] > 0) args.insert(args.end(), {"--stop-step", std::to_string(stops[part]), "--checkpoint", ckpt.string()});
    if (!restart_from.empty()) args.insert(args.end(), {"--restart", restart_from.string()});
    ASSERT_TRUE(run(args));
    restart_from = ckpt;
    // Each part's rows are the whole run's rows of its steps, bit for bit.
    const auto series = fdem::read_results_series(results);
    const auto stage = stages_of(results);
    ASSERT_FALSE(series.step.empty());
    for (std::size_t k = 0; k < series.step.size(); ++k) {
      ASSERT_EQ(whole_series.step[rows + k], series.step[k]) << "row " << k;
      EXPECT_EQ(whole_series.kinetic[rows + k], series.kinetic[k]) << "row " << k;
      EXPECT_EQ(whole_stage[rows + k], stage[k]) << "row " << k;
    }
    rows += series.step.size();
    if (stops[part] > 0) {
      EXPECT_EQ(parameters(results)["stopped_at_step"].get<std::uint64_t>(), stops[part]);
      continue;
    }
    expect_same_last_frame(whole, results);
    // The summary counts the steps before the restarts too.
    const auto resumed_summary = parameters(results)["triaxial"];
    for (const char* key : {"consolidation_steps", "membrane_steps", "shear_steps", "max_kinetic_ratio"})
      EXPECT_EQ(resumed_summary[key], summary[key]) << key;
  }
  EXPECT_EQ(rows, whole_series.step.size());
}

// The run's own numeric option: a whole number of steps in a stated range (CLI11 alone read -1 as
// 2^64 - 1 steps).
TEST(Fdemrun, StopStepOutsideItsRangeIsRefused) {
  test::TempDir dir;
  const auto good = write_text(dir, "good.toml", kTwoBoxScene);
  const auto out = (dir / "out.h5").string();
  test::expect_clean_failure("fdemrun", dir, {good.string(), out, "--stop-step", "-1"}, 2,
                             "--stop-step: must be a whole number in [0, 1e+15] steps, not -1");
  test::expect_clean_failure("fdemrun", dir, {good.string(), out, "--stop-step", "nan"}, 2, "[0, 1e+15] steps");
}
