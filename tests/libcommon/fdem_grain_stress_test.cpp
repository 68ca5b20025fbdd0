// fdem/ grain stresses: a deformable grain's Love-Weber stress (its contact and boundary forces)
// against the average of its element stresses, which the divergence theorem makes equal at rest in
// equilibrium; the frames of kind=fdem_results that keep both and the element stresses, read back
// by results_file's readers; the VTK frames' stress cell array of a 10-node grain.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/frames_vtk.hpp"
#include "graintwin/fdem/primitives.hpp"
#include "graintwin/fdem/results_file.hpp"
#include "graintwin/fdem/solver.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/schema.hpp"
#include "support/run_tool.hpp"
#include "support/vtk_summary.hpp"

using namespace graintwin;
using namespace graintwin::fdem;

namespace {

constexpr double kEdge = 1e-3;  ///< m, the cube's edge
constexpr double kCut = 1e-6;   ///< m, how far each platen starts inside it

/// A 1 mm cube of `kind` (meshed at `element_size`) between two smooth platens that cut 1 um into
/// its bottom and top faces, and a rigid flat box beside it, out of their reach.
Model squeezed_cube(GrainKind kind, double element_size) {
  Model m;
  add_grain(m, box_mesh(Eigen::Vector3d::Constant(kEdge), element_size), Eigen::Vector3d::Zero(), kind, 0, 1);
  add_grain(m, box_mesh(Eigen::Vector3d(kEdge, kEdge, 0.5 * kEdge), 0.5 * kEdge), Eigen::Vector3d(3 * kEdge, 0, 0), GrainKind::rigid, 0, 2);
  m.platens = {Platen{"bottom", Eigen::Vector3d(0, 0, -0.5 * kEdge + kCut), Eigen::Vector3d::UnitZ(), 0.0},
               Platen{"top", Eigen::Vector3d(0, 0, 0.5 * kEdge - kCut), -Eigen::Vector3d::UnitZ(), 0.0}};
  return m;
}

/// Mass-proportional damping near the critical one of the cube on its contact springs, so it
/// settles in a few thousand steps.
SolverOptions settling() {
  SolverOptions o;
  o.damping = 5e6;
  return o;
}

class GrainStress : public ::testing::TestWithParam<GrainKind> {};

double element_size(GrainKind kind) { return kind == GrainKind::tet4 ? 0.25e-3 : 0.5e-3; }

}  // namespace

// Sum_n x_n (x) f_int,n = sum_q w_q F S F^T over a grain (the discrete divergence theorem), and at
// rest in equilibrium the internal forces are the contact forces: both stresses agree to
// round-off. While the cube still rings, inertia carries part of the platens' load and they differ;
// normalising by the reference volume instead of the current one (off by the volumetric strain)
// would fail the tolerance too.
TEST_P(GrainStress, LoveWeberEqualsTheElementAverageAtRestInEquilibrium) {
  const Model m = squeezed_cube(GetParam(), element_size(GetParam()));
  Solver s(m, settling());
  EXPECT_TRUE(s.love_weber_stresses()[0].array().isNaN().all());  // no step: its forces are unknown
  EXPECT_EQ(s.love_weber_stresses()[1], Eigen::Matrix3d::Zero());   // a rigid grain's: none yet
  const double dt = 0.9 * s.time_step_limits().stable();
  for (int n = 0; n < 20; ++n) s.step(dt);
  const double ringing = relative_stress_difference(s.grain_stress(0), s.love_weber_stresses()[0]);
  EXPECT_GT(ringing, 1e-2);
  for (int n = 0; n < 6000; ++n) s.step(dt);
  const Eigen::Matrix3d elements = s.grain_stress(0), love_weber = s.love_weber_stresses()[0];
  // Uniaxial compression by the platen force over the face (tension positive).
  const double F = s.platen_force(1).z();
  ASSERT_GT(F, 0);
  EXPECT_NEAR(love_weber(2, 2), -F / (kEdge * kEdge), 1e-3 * F / (kEdge * kEdge));
  const double tolerance = 1e-10;
  EXPECT_LT(relative_stress_difference(elements, love_weber), tolerance);
  const double volumetric_strain = -elements.trace() * (1 - 2 * m.materials[0].poisson) / m.materials[0].young;
  EXPECT_GT(relative_stress_difference(elements, love_weber * (1 + volumetric_strain)), 10 * tolerance);
  // The rigid grain touches nothing: its Love-Weber stress is its grain stress, zero.
  EXPECT_EQ(s.love_weber_stresses()[1], s.grain_stress(1));
  EXPECT_EQ(s.grain_stress(1), Eigen::Matrix3d::Zero());
}

// A checkpoint keeps the last step's node forces: the Love-Weber stress right after a restart is
// the uninterrupted run's.
TEST_P(GrainStress, LoveWeberStressSurvivesACheckpoint) {
  const Model m = squeezed_cube(GetParam(), element_size(GetParam()));
  Solver a(m, settling());
  const double dt = 0.9 * a.time_step_limits().stable();
  for (int n = 0; n < 30; ++n) a.step(dt);
  test::TempDir dir;
  {
    io::H5File f = io::H5File::create(dir / "checkpoint.h5");
    a.save(f, "/state");
  }
  Solver b(m, settling());
  b.load(io::H5File::open(dir / "checkpoint.h5"), "/state");
  EXPECT_EQ(a.love_weber_stresses()[0], b.love_weber_stresses()[0]);
}

INSTANTIATE_TEST_SUITE_P(Fdem, GrainStress, ::testing::Values(GrainKind::tet4, GrainKind::tet10),
                         [](const auto& info) { return std::string(enum_name(kGrainKindNames, info.param)); });

TEST(GrainStressDifference, MedianOverTheDeformableGrainsThatCarryStress) {
  const Eigen::Matrix3d unit = Eigen::Matrix3d::Identity();
  EXPECT_DOUBLE_EQ(relative_stress_difference(unit, 0.5 * unit), 0.5);
  EXPECT_TRUE(std::isnan(relative_stress_difference(Eigen::Matrix3d::Zero(), Eigen::Matrix3d::Zero())));
  std::vector<Grain> grains(5);
  grains[0].kind = GrainKind::rigid;  // left out, however far apart
  const std::vector<Eigen::Matrix3d> elements{unit, unit, unit, Eigen::Matrix3d::Zero(), unit};
  const std::vector<Eigen::Matrix3d> love_weber{Eigen::Matrix3d::Zero(), 0.9 * unit, 0.8 * unit, Eigen::Matrix3d::Zero(), 0.7 * unit};
  EXPECT_NEAR(median_stress_difference(elements, love_weber, grains), 0.2, 1e-15);  // of 0.1, 0.2, 0.3; grain 3 carries none
  EXPECT_TRUE(std::isnan(median_stress_difference(elements, love_weber, std::vector<Grain>(5, grains[0]))));
}

// The frames keep every grain's stress and Love-Weber stress and the deformable grains' element
// stresses (float32), read back by results_file's readers as the solver had them; the VTK frame of
// the same state carries the same element stresses as its `stress` cell array, which ParaView
// colours, for a 10-node grain.
TEST(GrainStressFrames, ResultsAndVtkHoldTheElementStressesOfA10NodeGrain) {
  const Model m = squeezed_cube(GrainKind::tet10, 0.5e-3);
  Solver s(m, settling());
  const double dt = 0.9 * s.time_step_limits().stable();
  for (int n = 0; n < 200; ++n) s.step(dt);
  test::TempDir dir;
  {
    ResultsWriter writer(dir / "results.h5", s, "{}");
    writer.add_frame(s);
    writer.finish({"test"});
    ASSERT_EQ(writer.stress_differences().size(), 1u);
    EXPECT_EQ(writer.stress_differences()[0], relative_stress_difference(s.grain_stress(0), s.love_weber_stresses()[0]));
  }
  VtkFrameWriter vtk(dir / "frames");
  vtk.add(s);
  vtk.finish();

  const auto path = dir / "results.h5";
  const ResultsFrame frame = read_results_frame(path, 0);
  const std::vector<Eigen::Matrix3d> love_weber = s.love_weber_stresses();
  ASSERT_EQ(frame.love_weber_stress.size(), 18u);
  for (std::size_t g = 0; g < 2; ++g)
    for (int k = 0; k < 9; ++k) {
      EXPECT_EQ(frame.love_weber_stress[9 * g + k], -love_weber[g](k / 3, k % 3)) << "grain " << g;  // compression positive
      EXPECT_EQ(frame.stress[9 * g + k], -s.grain_stress(g)(k / 3, k % 3)) << "grain " << g;
    }
  const ResultsGrains grains = read_results_grains(path);
  EXPECT_EQ(grains.label, (std::vector<std::uint32_t>{1, 2}));
  EXPECT_EQ(grains.kind, (std::vector<GrainKind>{GrainKind::tet10, GrainKind::rigid}));

  const FrameElementStress elements = read_frame_element_stress(path, 0);
  const std::size_t E = m.grains[0].element_end;  // the cube's elements; the rigid grain's are left out
  ASSERT_EQ(elements.element.size(), E);
  double largest = 0;
  for (std::size_t e = 0; e < E; ++e) {
    EXPECT_EQ(elements.element[e], e);
    EXPECT_EQ(elements.grain[e], 0u);
    const Eigen::Matrix3d sigma = -s.element_stress(e);
    for (int k = 0; k < 9; ++k) EXPECT_EQ(elements.stress[9 * e + k], static_cast<float>(sigma(k / 3, k % 3)));
    largest = std::max(largest, sigma.norm());
  }
  EXPECT_GT(largest, 1e6);  // Pa: the platens press the cube
  EXPECT_EQ(io::H5File::open(path).read<float>(std::string(schema::fdem_results::frames) + "/000000/" +
                                               schema::fdem_results::frame_element_stress).size(), 9 * E);
  EXPECT_THROW(read_frame_element_stress(path, 1), DataError);

  const auto vtu = test::vtk_summary(dir / "frames" / "frame_000000.vtu");
  ASSERT_TRUE(vtu["cell_data"].contains("stress"));
  EXPECT_EQ(vtu["cell_data"]["stress"]["components"].get<int>(), 9);
  EXPECT_EQ(vtu["cell_data"]["stress"]["tuples"].get<std::size_t>(), m.element_count());
  // VTK's range of a 9-component array is that of the tuples' norms: the largest element's.
  EXPECT_NEAR(vtu["cell_data"]["stress"]["range"][1].get<double>(), largest, 1e-6 * largest);
}
