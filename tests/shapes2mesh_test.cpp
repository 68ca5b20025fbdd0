// shapes2mesh: CLI contract; the twin of a phantom scan (labels -> labels2shapes -> shapes2mesh)
// checked against the balls' exact volumes, element validity and watertight grain surfaces; a
// broken SH surface caught and replaced; the .vtu and .msh views; the same model whatever the
// number of gmsh worker processes; Ctrl-C ending the workers, SIGKILL taking them along, -j 1024
// starting no more of them than grains or processors; grains over the time budget falling back and
// counted; every grain's worst element recorded, and thresholds it cannot reach named; bad inputs
// failing cleanly.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <omp.h>
#include <signal.h>
#include <sys/wait.h>

#include <Eigen/Geometry>
#include <chrono>
#include <cmath>
#include <fstream>
#include <thread>

#include "graintwin/fdem/element.hpp"
#include "graintwin/fdem/model_file.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/mesh/surface.hpp"
#include "graintwin/segment/labels.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "graintwin/shape/shapes_file.hpp"
#include "support/cli_contract.hpp"
#include "support/phantoms.hpp"
#include "support/processes.hpp"
#include "support/vtk_summary.hpp"

using namespace graintwin;
using test::run_tool;

namespace {

constexpr double kVoxel = 2e-5;
// Eight spheres of radius 6-8 voxels, apart from each other.
const std::vector<test::Ball> kBalls = test::jittered_lattice(2, 7.0, 18.0, 11.0, 0.5, 0.1, 3);

struct Inputs {
  std::filesystem::path labels, shapes;
};

Inputs write_inputs(const test::TempDir& dir) {
  segment::LabelsFile c;
  c.labels = test::label_balls({40, 40, 40}, kBalls, {kVoxel, kVoxel, kVoxel});
  c.grains = segment::grain_table(c.labels);
  c.parameters_json = "{}";
  segment::write_labels_file(dir / "labels.h5", c, {"phantom labels"});
  const auto r = run_tool("labels2shapes", {(dir / "labels.h5").string(), (dir / "shapes.h5").string(), "-q"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return {dir / "labels.h5", dir / "shapes.h5"};
}

/// Starts shapes2mesh at -j 2 on fine meshes (so that meshing lasts) and returns its pid and its
/// gmsh workers once they are all forked (at the start, one per thread up to the processors).
std::pair<pid_t, std::vector<pid_t>> start_long_run(const test::TempDir& dir, const Inputs& in) {
  const pid_t tool = test::spawn_tool("shapes2mesh", {in.shapes.string(), (dir / "m.h5").string(), "-j", "2", "-q",
                                                      "--elements-per-diameter", "40"});
  std::vector<pid_t> workers;
  const std::size_t expected = std::min<std::size_t>(2, omp_get_num_procs());
  for (int tries = 0; tries < 500 && workers.size() < expected; ++tries) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    workers = test::child_pids(tool);
  }
  return {tool, workers};
}

double ball_volume(std::size_t i) { return 4.0 / 3.0 * M_PI * std::pow(kBalls[i].r * kVoxel, 3); }

/// Grain g's triangles as a stand-alone surface over the model's nodes.
mesh::TriangleSurface grain_surface(const fdem::Model& m, std::size_t g) {
  mesh::TriangleSurface s;
  s.vertices = m.nodes;
  for (std::uint32_t t = m.grains[g].triangle_begin; t < m.grains[g].triangle_end; ++t)
    s.triangles.push_back({int(m.triangles[t][0]), int(m.triangles[t][1]), int(m.triangles[t][2])});
  return s;
}

}  // namespace

TEST(Shapes2mesh, StandardCli) { test::expect_standard_cli("shapes2mesh"); }

TEST(Shapes2mesh, PhantomTwinHasEveryBallAtItsVolumeWithValidElements) {
  test::TempDir dir;
  const Inputs in = write_inputs(dir);
  const auto r = run_tool("shapes2mesh", {in.shapes.string(), in.labels.string(), (dir / "model.h5").string(), "--vtu",
                                          (dir / "model.vtu").string(), "--msh", (dir / "model.msh").string(), "-j", "2"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("8 from SH"), std::string::npos) << r.err;
  const fdem::Model m = fdem::read_model_file(dir / "model.h5");
  ASSERT_EQ(m.grains.size(), kBalls.size());
  const io::H5File f = io::H5File::open(dir / "model.h5");
  const auto volume = f.read<double>("/mesh/volume"), surface_volume = f.read<double>("/mesh/surface_volume");
  const auto surface_nodes = f.read<std::uint64_t>("/mesh/surface_nodes");
  for (std::size_t g = 0; g < m.grains.size(); ++g) {
    SCOPED_TRACE(g);
    EXPECT_EQ(m.grains[g].label, g + 1);
    EXPECT_EQ(m.grains[g].kind, fdem::GrainKind::tet10);
    // The mesh keeps the volume of the SH surface it was given (curved faces on the exact surface);
    // labels2shapes' SH fit of a voxelised ball of radius 6-8 voxels is itself about 4 % small.
    EXPECT_NEAR(volume[g], surface_volume[g], 0.01 * surface_volume[g]);
    EXPECT_NEAR(volume[g], ball_volume(g), 0.06 * ball_volume(g));
    EXPECT_GT(surface_nodes[g], 150u);
    const mesh::SurfaceCheck c = mesh::check_surface(grain_surface(m, g));
    EXPECT_TRUE(c.ok()) << c.problems();
    // Linear triangles through the mid-edge nodes cut the curved faces' caps: about 2.5 % here.
    EXPECT_NEAR(c.volume, volume[g], 0.04 * volume[g]);
  }
  for (std::size_t e = 0; e < m.element_count(); ++e) {
    const auto* n = m.element_nodes.data() + m.element_offset[e];
    const auto& a = m.nodes[n[0]];
    ASSERT_GT((m.nodes[n[1]] - a).cross(m.nodes[n[2]] - a).dot(m.nodes[n[3]] - a), 0.0) << "element " << e;
  }
  for (double j : f.read<double>("/mesh/min_jacobian_ratio")) EXPECT_GT(j, 0.0);
  ASSERT_TRUE(m.sample.has_value());
  EXPECT_EQ(m.platens.size(), 2u);
  EXPECT_NEAR(m.platens[1].point.z() - m.platens[0].point.z(), m.sample->z_max - m.sample->z_min, 1e-12);
  EXPECT_DOUBLE_EQ(m.sample->membrane_thickness, 0.3e-3);
  EXPECT_EQ(m.materials.size(), 1u);
  EXPECT_EQ(m.materials[0].young, 92.1e9);
  const auto history = io::read_history(f);
  ASSERT_GE(history.size(), 3u);
  EXPECT_NE(history.back().find("shapes2mesh"), std::string::npos);
  const auto s = test::vtk_summary(dir / "model.vtu");
  EXPECT_EQ(s["cells"], m.element_count());
  double total = 0;
  for (double v : volume) total += v;
  EXPECT_NEAR(s["volume"].get<double>(), total, 0.03 * total);  // VTK splits curved cells into straight ones
  EXPECT_TRUE(std::filesystem::exists(dir / "model.msh"));
  // One gmsh worker process instead of two: the same model, node for node.
  const auto one = run_tool("shapes2mesh", {in.shapes.string(), in.labels.string(), (dir / "one.h5").string(), "-j", "1", "-q"});
  ASSERT_EQ(one.exit_code, 0) << one.err;
  const fdem::Model m1 = fdem::read_model_file(dir / "one.h5");
  EXPECT_EQ(m1.nodes, m.nodes);
  EXPECT_EQ(m1.element_nodes, m.element_nodes);
  EXPECT_EQ(m1.triangles, m.triangles);
}

TEST(Shapes2mesh, InterruptEndsTheWorkersAndWritesNothing) {
  test::TempDir dir;
  const Inputs in = write_inputs(dir);
  const auto [tool, workers] = start_long_run(dir, in);
  ASSERT_EQ(workers.size(), std::min<std::size_t>(2, omp_get_num_procs())) << "no more workers than processors";
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  ASSERT_EQ(::kill(tool, SIGINT), 0);
  const auto start = std::chrono::steady_clock::now();
  int status = 0;
  ASSERT_EQ(::waitpid(tool, &status, 0), tool);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 5.0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 130);
  for (pid_t w : workers) EXPECT_NE(::kill(w, 0), 0) << "worker " << w << " outlived the tool";
  EXPECT_EQ(test::list_dir(dir.path()), (std::vector<std::string>{"labels.h5", "shapes.h5"}));
}

TEST(Shapes2mesh, KilledToolTakesItsWorkersWithIt) {
  test::TempDir dir;
  const Inputs in = write_inputs(dir);
  const auto [tool, workers] = start_long_run(dir, in);
  ASSERT_FALSE(workers.empty());
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // meshing
  ASSERT_EQ(::kill(tool, SIGKILL), 0);
  int status = 0;
  ASSERT_EQ(::waitpid(tool, &status, 0), tool);
  for (pid_t w : workers) {
    EXPECT_TRUE(test::process_ends_within(w, std::chrono::seconds(1))) << "worker " << w << " outlived the killed tool";
    ::kill(w, SIGKILL);
  }
}

TEST(Shapes2mesh, ThousandsOfThreadsStartNoMoreWorkersThanGrainsOrProcessors) {
  test::TempDir dir;
  const Inputs in = write_inputs(dir);
  const auto start = std::chrono::steady_clock::now();
  const auto r = run_tool("shapes2mesh", {in.shapes.string(), (dir / "m.h5").string(), "-j", "1024", "-q", "--order", "1",
                                          "--elements-per-diameter", "4"});
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::H5File f = io::H5File::open(dir / "m.h5");
  const auto p = nlohmann::json::parse(f.read_strings("/mesh/parameters").at(0));
  EXPECT_EQ(p["gmsh_processes"].get<int>(), std::min<int>(kBalls.size(), omp_get_num_procs()));
  EXPECT_LT(seconds, 60.0) << "1024 threads on 8 grains must not crawl";
}

TEST(Shapes2mesh, BrokenShSurfaceFallsBackToVoxelsOrEllipsoidWithANote) {
  test::TempDir dir;
  const Inputs in = write_inputs(dir);
  shape::ShapesFile s = shape::read_shapes_file(in.shapes);
  s.grains[0].coeffs.setZero();
  s.grains[0].coeffs[0] = 1e-4 * std::sqrt(4.0 * M_PI);
  s.grains[0].coeffs[6] = 5e-4;  // r(direction) < 0 around the equator: the surface folds through the centroid
  shape::write_shapes_file(dir / "broken.h5", s, {"broken"});
  const auto with_labels = run_tool("shapes2mesh", {(dir / "broken.h5").string(), in.labels.string(), (dir / "a.h5").string(),
                                                    "--order", "1", "-v", "-v"});
  ASSERT_EQ(with_labels.exit_code, 0) << with_labels.err;
  EXPECT_NE(with_labels.err.find("SH surface has"), std::string::npos) << with_labels.err;
  const io::H5File a = io::H5File::open(dir / "a.h5");
  EXPECT_EQ(a.read<std::uint8_t>("/mesh/surface_origin")[0], 1);  // smoothed voxels
  EXPECT_NEAR(a.read<double>("/mesh/volume")[0], ball_volume(0), 0.06 * ball_volume(0));
  const auto alone = run_tool("shapes2mesh", {(dir / "broken.h5").string(), (dir / "b.h5").string(), "--order", "1"});
  ASSERT_EQ(alone.exit_code, 0) << alone.err;
  const io::H5File b = io::H5File::open(dir / "b.h5");
  EXPECT_EQ(b.read<std::uint8_t>("/mesh/surface_origin")[0], 2);  // inertia ellipsoid
  EXPECT_NE(b.read_strings("/mesh/note")[0].find("pairs of triangles that cross each other"), std::string::npos);
  EXPECT_NE(alone.err.find("1 as ellipsoids"), std::string::npos) << alone.err;
}

TEST(Shapes2mesh, GrainsOverTheBudgetFallBackToTheKeptSurfaceAndAreCounted) {
  test::TempDir dir;
  const Inputs in = write_inputs(dir);
  // gmsh's remeshing of the SH surfaces under a budget no gmsh run meets: every grain overruns,
  // its worker is stopped, and it is meshed from its SH surface kept as the boundary.
  const auto r = run_tool("shapes2mesh", {in.shapes.string(), in.labels.string(), (dir / "m.h5").string(), "--sh-meshing", "gmsh",
                                          "--grain-budget", "1e-9", "-j", "2"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("gmsh overran --grain-budget 1e-09 s; meshed by the kept surface path from its sh instead"), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("8 overran --grain-budget"), std::string::npos) << r.err;
  const io::H5File f = io::H5File::open(dir / "m.h5");
  const auto path = f.read<std::uint8_t>("/mesh/path");
  const auto overran = f.read<std::uint8_t>("/mesh/overran_budget");
  const auto volume = f.read<double>("/mesh/volume");
  const auto notes = f.read_strings("/mesh/note");
  ASSERT_EQ(path.size(), kBalls.size());
  for (std::size_t g = 0; g < path.size(); ++g) {
    EXPECT_EQ(path[g], 1) << g;
    EXPECT_EQ(overran[g], 1) << g;
    EXPECT_NE(notes[g].find("overran"), std::string::npos) << notes[g];
    EXPECT_NEAR(volume[g], ball_volume(g), 0.05 * ball_volume(g)) << g;
  }
  // The default: kept surfaces straight away, nothing over the budget.
  const auto d = run_tool("shapes2mesh", {in.shapes.string(), in.labels.string(), (dir / "d.h5").string()});
  ASSERT_EQ(d.exit_code, 0) << d.err;
  EXPECT_NE(d.err.find("0 gmsh remeshed the surface, 8 surface remeshed and kept as the boundary, 0 ellipsoid; 0 overran"),
            std::string::npos)
      << d.err;
}

TEST(Shapes2mesh, EveryGrainsWorstElementIsRecordedAndUnreachableThresholdsNamed) {
  test::TempDir dir;
  const Inputs in = write_inputs(dir);
  const auto r = run_tool("shapes2mesh", {in.shapes.string(), in.labels.string(), (dir / "m.h5").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("slivers (--min-dihedral"), std::string::npos) << r.err;
  const fdem::Model m = fdem::read_model_file(dir / "m.h5");
  const auto q = fdem::read_mesh_quality(dir / "m.h5");
  ASSERT_TRUE(q.has_value());
  ASSERT_EQ(q->label.size(), m.grains.size());
  EXPECT_GT(q->min_dihedral_threshold, 0.0);
  EXPECT_GT(q->min_altitude_ratio_threshold, 0.0);
  for (std::size_t g = 0; g < m.grains.size(); ++g) {
    SCOPED_TRACE(g);
    EXPECT_EQ(q->label[g], m.grains[g].label);
    // The worst element is the grain's own, at its model index, with the altitude fdemrun's step uses.
    const std::uint64_t worst = q->worst_element[g];
    ASSERT_GE(worst, m.grains[g].element_begin);
    ASSERT_LT(worst, m.grains[g].element_end);
    EXPECT_NEAR(q->min_altitude[g], fdem::element_min_altitude(m, worst), 1e-15);
    for (std::size_t e = m.grains[g].element_begin; e < m.grains[g].element_end; ++e)
      EXPECT_GE(fdem::element_min_altitude(m, e), q->min_altitude[g]);
    EXPECT_DOUBLE_EQ(q->step_ratio[g], q->min_altitude[g] / q->median_altitude[g]);
    // The balls' meshes reach the default thresholds.
    EXPECT_EQ(q->below_thresholds[g], 0u);
    EXPECT_GE(q->step_ratio[g], q->min_altitude_ratio_threshold);
    EXPECT_GE(q->min_dihedral[g], q->min_dihedral_threshold);
  }
  // 60 degrees cannot be had (space is not filled by near-regular tetrahedra): the run still writes
  // its model, but names the grains that stay below and counts their elements.
  const auto hard = run_tool("shapes2mesh", {in.shapes.string(), in.labels.string(), (dir / "hard.h5").string(), "--min-dihedral", "60"});
  ASSERT_EQ(hard.exit_code, 0) << hard.err;
  EXPECT_NE(hard.err.find("grain 1: "), std::string::npos) << hard.err;
  EXPECT_NE(hard.err.find("stay below --min-dihedral 60"), std::string::npos) << hard.err;
  const auto hq = fdem::read_mesh_quality(dir / "hard.h5");
  ASSERT_TRUE(hq.has_value());
  EXPECT_EQ(hq->min_dihedral_threshold, 60.0);
  for (std::size_t g = 0; g < hq->label.size(); ++g) EXPECT_GT(hq->below_thresholds[g], 0u);
  const auto notes = io::H5File::open(dir / "hard.h5").read_strings("/mesh/note");
  EXPECT_NE(notes[0].find("below the sliver thresholds"), std::string::npos) << notes[0];
}

TEST(Shapes2mesh, OverridesAndRigidSmallGrains) {
  test::TempDir dir;
  const Inputs in = write_inputs(dir);
  const auto r = run_tool("shapes2mesh", {in.shapes.string(), (dir / "m.h5").string(), "--order", "1",
                                          "--elements-per-diameter", "4", "--rigid-below", "1.0"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const fdem::Model m = fdem::read_model_file(dir / "m.h5");
  std::size_t rigid = 0;
  for (const auto& g : m.grains) rigid += g.kind == fdem::GrainKind::rigid;
  EXPECT_GT(rigid, 0u);  // the balls below d50
  EXPECT_LT(rigid, m.grains.size());
  for (std::size_t e = 0; e < m.element_count(); ++e) EXPECT_EQ(m.nodes_of(e), 4u);
  const io::H5File f = io::H5File::open(dir / "m.h5");
  const auto d = shape::read_shapes_file(in.shapes).grains;
  const auto h = f.read<double>("/mesh/element_size");
  const auto kind = f.read<std::uint8_t>("/mesh/kind");
  for (std::size_t g = 0; g < h.size(); ++g)
    if (kind[g] != 0) {
      EXPECT_NEAR(h[g], d[g].equivalent_diameter / 4, 1e-12);
    }
}

TEST(Shapes2mesh, EquivalentPackingDrawsTheLibraryIntoACylinderAtTheSolidFraction) {
  test::TempDir dir;
  const Inputs in = write_inputs(dir);
  const auto r = run_tool("shapes2mesh", {in.shapes.string(), (dir / "s.h5").string(), "--packing", "equivalent",
                                          "--solid-fraction", "0.3", "--aspect", "1.2", "--grains", "10", "--order", "1"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("equivalent sample: 10 grains drawn from 8"), std::string::npos) << r.err;
  const fdem::Model m = fdem::read_model_file(dir / "s.h5");
  ASSERT_EQ(m.grains.size(), 10u);
  ASSERT_TRUE(m.sample.has_value());
  const fdem::SampleCylinder& c = *m.sample;
  EXPECT_NEAR(c.z_max - c.z_min, 1.2 * 2 * c.radius, 1e-12);
  const io::H5File f = io::H5File::open(dir / "s.h5");
  const auto label = f.read<std::uint32_t>("/mesh/label"), source = f.read<std::uint32_t>("/mesh/source_label");
  const auto volume = f.read<double>("/mesh/volume"), surface_volume = f.read<double>("/mesh/surface_volume");
  double total = 0, drawn = 0;
  for (std::size_t g = 0; g < 10; ++g) {
    EXPECT_EQ(label[g], g + 1);
    EXPECT_GE(source[g], 1u);
    EXPECT_LE(source[g], 8u);
    total += volume[g], drawn += surface_volume[g];
  }
  // The drawn grains' SH volume over the cylinder is the solid fraction asked for (the packer's
  // tables and the level-4 surfaces agree to a fraction of a percent); the linear meshes lose ~2 %.
  const double cylinder = M_PI * c.radius * c.radius * (c.z_max - c.z_min);
  EXPECT_NEAR(drawn / cylinder, 0.3, 0.01);
  EXPECT_NEAR(total / cylinder, 0.3, 0.015);
  // Every node inside the cylinder, within a hundredth of the smallest grain.
  for (const auto& p : m.nodes) {
    EXPECT_LE((p.head<2>() - c.axis_xy).norm(), c.radius * 1.01);
    EXPECT_GE(p.z(), c.z_min - 0.01 * c.radius);
    EXPECT_LE(p.z(), c.z_max + 0.01 * c.radius);
  }
  // Without LABELS the scan's solid fraction is unknown.
  test::expect_clean_failure("shapes2mesh", dir, {in.shapes.string(), (dir / "t.h5").string(), "--packing", "equivalent"}, 2,
                             "--solid-fraction");
}

TEST(Shapes2mesh, BadInputsFailCleanly) {
  test::TempDir dir;
  const Inputs in = write_inputs(dir);
  const std::string out = (dir / "m.h5").string();
  test::expect_clean_failure("shapes2mesh", dir, {in.labels.string(), out}, 2, "pass the output of labels2shapes");
  test::expect_clean_failure("shapes2mesh", dir, {in.shapes.string(), in.shapes.string(), out}, 2, "pass the output of ct2labels");
  test::expect_clean_failure("shapes2mesh", dir, {in.shapes.string(), out, "--order", "3"}, 2, "--order");
  test::expect_clean_failure("shapes2mesh", dir, {in.shapes.string(), (dir / "m.vtk").string()}, 2, "must end in .h5");
  test::expect_clean_failure("shapes2mesh", dir, {in.shapes.string(), out, "--sample-cylinder", "inscribed"}, 2,
                             "--sample-cylinder inscribed needs LABELS and the scan's packing; pass the labels file, or leave it at auto");
  test::expect_clean_failure("shapes2mesh", dir, {in.shapes.string(), out, "--sample-cylinder", "round"}, 2, "--sample-cylinder");
  shape::ShapesFile empty = shape::read_shapes_file(in.shapes);
  empty.grains.clear();
  shape::write_shapes_file(dir / "empty.h5", empty, {"empty"});
  test::expect_clean_failure("shapes2mesh", dir, {(dir / "empty.h5").string(), out}, 1, "holds no grain");
  // Labels of another scan: a grain of the shapes file missing from them.
  segment::LabelsFile other;
  other.labels = test::label_balls({40, 40, 40}, {kBalls[0]}, {kVoxel, kVoxel, kVoxel});
  other.grains = segment::grain_table(other.labels);
  other.parameters_json = "{}";
  segment::write_labels_file(dir / "other.h5", other, {"other"});
  test::expect_clean_failure("shapes2mesh", dir, {in.shapes.string(), (dir / "other.h5").string(), out}, 2,
                             "pass the labels file the shapes were measured from");
}

// NaN passed CLI11's ranges (--gamma-floor nan); every numeric option is now refused outside its
// stated range while the command line is read, before any input is opened.
TEST(Shapes2mesh, OptionsOutsideTheirRangeAreRefused) {
  test::TempDir dir;
  const std::vector<std::string> in{(dir / "shapes.h5").string(), (dir / "m.h5").string()};
  const auto refused = [&](const std::vector<std::string>& options, const std::string& says) {
    test::expect_option_refused("shapes2mesh", dir, in, options, says);
  };
  refused({"--gamma-floor", "nan"}, "--gamma-floor: must be a finite number in [0, 0.9], not nan");
  refused({"--volume-tol", "inf"}, "[0.0001, 0.5]");
  refused({"--smooth", "nan"}, "[0, 5] voxels");
  refused({"--grain-budget=-1"}, "--grain-budget: must be a finite number in [0, 3600] s");
  refused({"--sh-meshing", "fast"}, "--sh-meshing");
  refused({"--grains", "1e19"}, "--grains: must be a whole number in [0, 50000]");
  // -1 wrapped round to 2^64 - 1 grains and ended in a bare "cannot create std::vector larger than max_size()".
  refused({"--grains=-1"}, "--grains: must be a whole number in [0, 50000], not -1");
  refused({"--membrane-thickness", "nan"}, "--membrane-thickness: the length 'nan' must be a finite length");
  refused({"--membrane-thickness", "2m"}, "[1 um, 10 mm]");
  // Thresholds no mesh can meet are refused before any work: no tetrahedron has all dihedral
  // angles above 70.5 degrees, and half the elements lie below the median altitude.
  refused({"--min-dihedral", "61"}, "--min-dihedral: must be a finite number in [0, 60] degrees");
  refused({"--min-altitude", "0.95"}, "--min-altitude: must be a finite number in [0, 0.9]");
}

TEST(Shapes2mesh, MeshesBeyondTheMemoryAreRefusedWithTheNumbersBeforeMeshing) {
  test::TempDir dir;
  const Inputs in = write_inputs(dir);
  // 100 elements per diameter: about 3e6 elements per grain (3 (d / h)^3), far beyond 2 GB.
  const auto before = test::list_dir(dir.path());
  const auto r = test::run_tool_with_memory_limit("shapes2mesh", 2000000000,
                                                  {in.shapes.string(), (dir / "m.h5").string(), "--elements-per-diameter", "100"});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("shapes2mesh needs about"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("grains of about 3e+06 elements, 100 per diameter"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("give a smaller --elements-per-diameter"), std::string::npos) << r.err;
  EXPECT_EQ(test::list_dir(dir.path()), before);
}
