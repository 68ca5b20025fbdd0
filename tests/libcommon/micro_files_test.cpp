// The readers of kind=micro and kind=forces files beside their writers: what write_forces_file
// writes is read back, damaged tables are refused, D2min of a micro file's increment is found by
// label; and the frame range and windows of the force statistics (forces_analysis).
#include <gtest/gtest.h>

#include <cmath>

#include "graintwin/core/error.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/micro/forces_analysis.hpp"
#include "graintwin/micro/forces_file.hpp"
#include "graintwin/micro/micro_file.hpp"
#include "support/run_tool.hpp"
#include "support/simulation_results.hpp"

using namespace graintwin;
using namespace graintwin::micro;
namespace fs = std::filesystem;

namespace {

/// Two grains (labels 7 and 9), two frames, one window, every number distinct.
ForcesFile two_frame_forces() {
  ForcesFile c;
  c.label = {7, 9};
  c.q = {1e5, 2e5, 3e5, 4e5};  // grain-major: (7, frame 0), (7, frame 1), (9, frame 0), (9, frame 1)
  c.chain_threshold = 1.5;
  c.d2min_source = "centroids";
  c.parameters_json = "{\"from\":0}";
  for (std::size_t k = 0; k < 2; ++k) {
    FrameForces f;
    f.frame = 3 + k, f.time = 0.5 * double(k + 1), f.contacts = 10 + k, f.platen_contacts = 2, f.strong = 4;
    f.distribution.mean = 2.0;
    f.distribution.pdf.edges = {0.1, 1.0, 10.0};
    f.distribution.pdf.count = {3 + k, 5};
    f.distribution.pdf.density = {0.25, 0.05 * double(k + 1)};
    f.distribution.pdf.used = 8 + k, f.distribution.pdf.outside = 1;
    f.distribution.strong.valid = true, f.distribution.strong.scale = 0.7 + double(k);
    f.distribution.weak.valid = k == 0, f.distribution.weak.theta = -0.3;
    f.rose.theta_edges = {0.0, 0.5, 1.0};
    f.rose.phi_edges = {0.0, 3.0, 6.0};
    f.rose.counts = {1, 2, 3, 4 + k};
    f.rose.mean_force = {1.5, 2.5, std::nan(""), 4.5};
    c.frames.push_back(std::move(f));
  }
  VolatilityWindow w;
  w.from = 3, w.to = 4;
  w.volatility = {0.1, std::nan("")};
  w.d2min = {0.02, 0.03};
  w.correlation.r = 0.25, w.correlation.p_value = 0.5, w.correlation.count = 1;
  c.windows.push_back(std::move(w));
  return c;
}

bool same(double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

void expect_same(const std::vector<double>& a, const std::vector<double>& b, const std::string& what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  for (std::size_t k = 0; k < a.size(); ++k) EXPECT_TRUE(same(a[k], b[k])) << what << "[" << k << "]";
}

/// A micro file's tables as tracks2micro writes them from simulation frames: 3 grains in 3 states
/// (grain 2 absent from state 2), increments 0 -> 1 and 1 -> 2.
MicroTables three_grain_micro() {
  MicroTables m;
  m.source = "fdem_results";
  m.states.resize(3);
  m.increments.resize(2);
  m.increments[0].from = 0, m.increments[0].to = 1;
  m.increments[1].from = 1, m.increments[1].to = 2;
  m.grains = 3;
  m.grain_label = {5, 5, 5, 6, 6, 6, 8, 8, 0};
  m.grain_d2min = {0.1, 0.2, 0.3, 0.4, 0.5, std::nan("")};
  return m;
}

SimulationGrains grains_labelled(std::vector<std::uint32_t> labels) {
  SimulationGrains g;
  g.label = std::move(labels);
  for (std::size_t i = 0; i < g.label.size(); ++i) g.row[g.label[i]] = i;
  return g;
}

}  // namespace

TEST(ForcesFile, WhatIsWrittenIsReadBack) {
  test::TempDir dir;
  const ForcesFile c = two_frame_forces();
  write_forces_file(dir / "f.h5", c, {});
  const ForcesTables r = read_forces_tables(dir / "f.h5");
  ASSERT_EQ(r.frames.size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    const ForcesFrameTables& f = r.frames[k];
    const FrameForces& w = c.frames[k];
    EXPECT_EQ(f.index, w.frame);
    EXPECT_EQ(f.time, w.time);
    EXPECT_EQ(f.contacts, w.contacts);
    EXPECT_EQ(f.strong_scale, w.distribution.strong.scale);
    EXPECT_EQ(f.pdf.edges, w.distribution.pdf.edges);
    EXPECT_EQ(f.pdf.count, w.distribution.pdf.count);
    EXPECT_EQ(f.pdf.density, w.distribution.pdf.density);
    EXPECT_EQ(f.pdf.used, w.distribution.pdf.used);
    EXPECT_EQ(f.pdf.outside, 1u);
    EXPECT_EQ(f.rose.theta_edges, w.rose.theta_edges);
    EXPECT_EQ(f.rose.phi_edges, w.rose.phi_edges);
    EXPECT_EQ(f.rose.counts, w.rose.counts);
    expect_same(f.rose.mean_force, w.rose.mean_force, "mean_force");
  }
  EXPECT_EQ(r.frames[0].weak_theta, -0.3);
  EXPECT_TRUE(std::isnan(r.frames[1].weak_theta));  // an unfitted tail is stored as NaN
  ASSERT_EQ(r.windows.size(), 1u);
  const ForcesWindowTables& w = r.windows[0];
  EXPECT_EQ(w.from, 3u);
  EXPECT_EQ(w.to, 4u);
  EXPECT_EQ(w.pearson_r, 0.25);
  EXPECT_EQ(w.p_value, 0.5);
  EXPECT_EQ(w.count, 1u);
  expect_same(w.volatility, c.windows[0].volatility, "volatility");
  expect_same(w.d2min, c.windows[0].d2min, "d2min");
}

TEST(ForcesFile, TheReaderRefusesInfinityUnevenTablesAndOtherKinds) {
  test::TempDir dir;
  ForcesFile c = two_frame_forces();
  c.q[1] = INFINITY;
  write_forces_file(dir / "inf.h5", c, {});
  EXPECT_THROW(read_forces_tables(dir / "inf.h5"), DataError);
  {  // /frames columns of different lengths, as a damaged file would have them
    io::H5File f = io::H5File::create(dir / "uneven.h5");
    io::write_root_attrs(f, schema::kind::forces);
    f.write(schema::forces::frame_index, std::vector<std::uint64_t>{0, 1});
    f.write(schema::forces::frame_time, std::vector<double>{0.5});
  }
  try {
    read_forces_tables(dir / "uneven.h5");
    ADD_FAILURE() << "uneven tables were read";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.message()).find("fdem2forces"), std::string::npos) << e.message();
  }
  {
    io::H5File f = io::H5File::create(dir / "micro_kind.h5");
    io::write_root_attrs(f, schema::kind::micro);
  }
  EXPECT_THROW(read_forces_tables(dir / "micro_kind.h5"), UsageError);
}

TEST(MicroFile, D2minOfAnIncrementIsFoundByLabelInItsFirstState) {
  const MicroTables m = three_grain_micro();
  // The simulation's rows in another order than the file's.
  const auto d = d2min_of_increment(m, "m.h5", grains_labelled({8, 5, 6}), 0, 1);
  ASSERT_EQ(d.size(), 3u);
  EXPECT_EQ(d[0], 0.5);  // grain 8: third row of the file, increment 0
  EXPECT_EQ(d[1], 0.1);
  EXPECT_EQ(d[2], 0.3);
  // Increment 1 -> 2: grain 8 is in state 1 (it leaves in state 2), its D2min is undefined (NaN).
  const auto d12 = d2min_of_increment(m, "m.h5", grains_labelled({8, 5, 6}), 1, 2);
  EXPECT_TRUE(std::isnan(d12[0]));
  EXPECT_EQ(d12[1], 0.2);
  EXPECT_EQ(d12[2], 0.4);
  // No increment 0 -> 2, a grain the file lacks, a file made from tracks: each names --micro and the fix.
  const auto refused = [&](const MicroTables& t, const SimulationGrains& g, std::size_t from, std::size_t to, const std::string& says) {
    try {
      d2min_of_increment(t, "m.h5", g, from, to);
      ADD_FAILURE() << "accepted";
    } catch (const UsageError& e) {
      EXPECT_NE(std::string(e.message()).find("--micro m.h5"), std::string::npos) << e.message();
      EXPECT_NE(std::string(e.message()).find(says), std::string::npos) << e.message();
    }
  };
  refused(m, grains_labelled({5, 6, 8}), 0, 2, "no increment 0 -> 2");
  refused(m, grains_labelled({5, 6, 8, 12}), 0, 1, "lacks 1 of the simulation's grains");
  MicroTables tracks = m;
  tracks.source = "tracks";
  refused(tracks, grains_labelled({5, 6, 8}), 0, 1, "made from tracks");
}

// fdemrun's [model.deformable] d2min rule: the D2min of any increment, keyed by the labels of any
// state (the scan the twin was meshed from); tracks absent there or undefined are left out.
TEST(MicroFile, D2minByLabelOfAStateOverAnIncrement) {
  const MicroTables m = three_grain_micro();
  EXPECT_EQ(d2min_by_label(m, "m.h5", 0, 0), (std::map<std::uint32_t, double>{{5, 0.1}, {6, 0.3}, {8, 0.5}}));
  EXPECT_EQ(d2min_by_label(m, "m.h5", 0, 1), (std::map<std::uint32_t, double>{{5, 0.2}, {6, 0.4}}));  // grain 8's is NaN
  EXPECT_EQ(d2min_by_label(m, "m.h5", 2, 0), (std::map<std::uint32_t, double>{{5, 0.1}, {6, 0.3}}));  // grain 8 left before state 2
  const auto refusal = [&](std::size_t state, std::size_t increment) {
    try {
      d2min_by_label(m, "m.h5", state, increment);
    } catch (const UsageError& e) {
      return e.message();
    }
    return std::string("accepted");
  };
  EXPECT_EQ(refusal(3, 0), "m.h5 has no state 3 (it holds 3); give a state below 3");
  EXPECT_EQ(refusal(0, 2), "m.h5 has no increment 2 (it holds 2); give an increment below 2");
}

TEST(ForcesAnalysis, FrameRangeAndWindowsFollowTheOptions) {
  ForcesOptions o = forces_frame_range(6, -1, -1, 0, "r.h5");
  EXPECT_EQ(o.first, 0u);
  EXPECT_EQ(o.last, 5u);
  EXPECT_EQ(o.window, 5u);  // 0: one window over every frame
  o = forces_frame_range(6, 1, 4, 2, "r.h5");
  EXPECT_EQ(o.first, 1u);
  EXPECT_EQ(o.last, 4u);
  EXPECT_EQ(o.window, 2u);
  EXPECT_THROW(forces_frame_range(0, -1, -1, 0, "r.h5"), DataError);
  EXPECT_THROW(forces_frame_range(1, -1, -1, 0, "r.h5"), DataError);
  EXPECT_THROW(forces_frame_range(6, 3, 3, 0, "r.h5"), UsageError);  // first < last
  EXPECT_THROW(forces_frame_range(6, 0, 6, 0, "r.h5"), UsageError);  // no frame 6
  EXPECT_THROW(forces_frame_range(6, 0, 2, 3, "r.h5"), UsageError);  // a window longer than the span
}

TEST(ForcesAnalysis, EveryFrameAndWindowOfTheRangeIsAnalysed) {
  test::TempDir dir;
  test::LatticeRun run;
  run.side = 2;
  run.frames = 5;
  test::write_lattice_results(dir / "r.h5", run);
  for (std::size_t k = 0; k < 5; ++k)  // one x contact per frame, growing: grains 0 and 1
    test::set_frame_contacts(dir / "r.h5", k, {{0, 1, -1, Eigen::Vector3d::UnitX(), (1.0 + double(k)) * Eigen::Vector3d::UnitX()}});
  const SimulationGrains grains = read_simulation_grains(dir / "r.h5");
  ForcesOptions o = forces_frame_range(5, -1, -1, 2, "r.h5");  // frames 0..4, windows 0 -> 2 and 2 -> 4
  fs::create_directories(dir / "chains");
  ForceChainFiles chains;
  const ForcesFile c = force_statistics(dir / "r.h5", grains, o, nullptr, "", dir / "chains", &chains);
  ASSERT_EQ(c.frames.size(), 5u);
  EXPECT_EQ(c.frames[0].frame, 0u);
  EXPECT_EQ(c.frames[4].frame, 4u);
  EXPECT_EQ(c.frames[3].distribution.mean, 4.0);  // frame 3: the one contact carries 4 N
  EXPECT_EQ(c.frames[3].contacts, 1u);
  ASSERT_EQ(c.windows.size(), 2u);
  EXPECT_EQ(c.windows[1].from, 2u);
  EXPECT_EQ(c.windows[1].to, 4u);
  EXPECT_EQ(c.windows[1].volatility.size(), 8u);
  EXPECT_EQ(c.q.size(), 8u * 5u);
  EXPECT_EQ(c.d2min_source, "centroids");
  EXPECT_EQ(chains.files, (std::vector<std::string>{"chains_000000.vtp", "chains_000001.vtp", "chains_000002.vtp",
                                                    "chains_000003.vtp", "chains_000004.vtp"}));
  for (const std::string& f : chains.files) EXPECT_TRUE(fs::exists(dir / "chains" / f)) << f;
  // A window that is not one: taken from forces_frame_range, never made by hand.
  o.window = 0;
  EXPECT_THROW(force_statistics(dir / "r.h5", grains, o, nullptr, "", {}, nullptr), UsageError);
}
