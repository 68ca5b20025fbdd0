// tracks2micro's stage (micro/micro_analysis): the states of tracked grains from the scans' shapes
// files, refused when the files do not fit the tracks, and the analysis of their increments with
// the parameters it records.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <numbers>

#include "graintwin/core/error.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/micro/micro_analysis.hpp"
#include "graintwin/shape/shapes_file.hpp"
#include "support/phantoms.hpp"
#include "support/run_tool.hpp"

using namespace graintwin;
using namespace graintwin::micro;

namespace {

constexpr int kSide = 5;
constexpr double kSpacing = 0.5e-3;  // = the grains' diameter = d50

/// A cubic lattice of kSide^3 grains (labels 10 + index) in three scans, each stretched axially by
/// 0.5 % more than the one before, with their shapes files and tracks.
struct TrackedLattice {
  test::TempDir dir;
  TrackedGrains tracks;
  double volume = std::numbers::pi / 6.0 * std::pow(kSpacing, 3);

  TrackedLattice() {
    const std::size_t n = kSide * kSide * kSide, t = 3;
    tracks.tracks = n, tracks.scans = t;
    tracks.label.resize(n * t);
    tracks.centroid.resize(n * t * 3);
    for (std::size_t s = 0; s < t; ++s) {
      std::vector<std::uint32_t> labels;
      std::vector<Eigen::Vector3d> centroids;
      for (std::size_t i = 0; i < n; ++i) {
        labels.push_back(std::uint32_t(10 + i));
        centroids.push_back(Eigen::Vector3d(double(i % kSide), double(i / kSide % kSide), double(i / (kSide * kSide))) * kSpacing);
        centroids.back().z() *= 1.0 - 0.005 * double(s);
        tracks.label[i * t + s] = labels.back();
        for (int q = 0; q < 3; ++q) tracks.centroid[(i * t + s) * 3 + std::size_t(q)] = centroids.back()[q];
      }
      tracks.scan_files.push_back((dir / ("shapes_" + std::to_string(s) + ".h5")).string());
      test::write_sphere_shapes(tracks.scan_files.back(), labels, centroids, kSpacing, "lattice shapes");
      tracks.scan_d50.push_back(kSpacing);
    }
  }
};

}  // namespace

TEST(MicroAnalysis, TrackedStatesTakeVolumesAndSizesFromTheShapesFiles) {
  const TrackedLattice lattice;
  std::vector<std::string> opened;
  const MicroFile c = tracked_states(lattice.tracks, "tracks.h5", {}, {},
                                     [&](const io::H5File& f) { opened.push_back(f.path().string()); });
  EXPECT_EQ(opened, lattice.tracks.scan_files);  // every shapes file is an input, in scan order
  EXPECT_EQ(c.state_files, lattice.tracks.scan_files);
  ASSERT_EQ(c.series.states, 3u);
  ASSERT_EQ(c.series.grains, lattice.tracks.tracks);
  for (double v : c.series.volume) EXPECT_DOUBLE_EQ(v, lattice.volume);
  ASSERT_EQ(c.series.psd.size(), 3u);
  EXPECT_DOUBLE_EQ(c.series.psd[2].d50, kSpacing);
  EXPECT_TRUE(c.series.coordination.empty());  // no contacts files: coordination by distance
  EXPECT_EQ(c.label, lattice.tracks.label);
  EXPECT_DOUBLE_EQ(c.series.position[1 * 3 + 2].z(), lattice.tracks.centroid[(1 * 3 + 2) * 3 + 2]);
}

TEST(MicroAnalysis, TrackedStatesRefuseFilesThatDoNotFitTheTracks) {
  TrackedLattice lattice;
  // Shapes files in place of the stored paths: one per scan.
  EXPECT_THROW(tracked_states(lattice.tracks, "tracks.h5", {lattice.tracks.scan_files[0], lattice.tracks.scan_files[1]}, {}),
               UsageError);
  // Contacts files: one per scan, and existing.
  EXPECT_THROW(tracked_states(lattice.tracks, "tracks.h5", {}, {lattice.dir / "c0.h5", lattice.dir / "c1.h5"}), UsageError);
  EXPECT_THROW(
      tracked_states(lattice.tracks, "tracks.h5", {}, {lattice.dir / "c0.h5", lattice.dir / "c1.h5", lattice.dir / "c2.h5"}),
      UsageError);
  // A track naming a grain its scan's shapes file lacks.
  TrackedGrains unknown = lattice.tracks;
  unknown.label[3 * 3 + 1] = 9999;
  try {
    tracked_states(unknown, "tracks.h5", {}, {});
    FAIL() << "a track with an unknown grain was accepted";
  } catch (const DataError& e) {
    EXPECT_NE(e.message().find("lacks 1 grains the tracks name in scan 1"), std::string::npos) << e.message();
  }
  // A stored shapes file that is gone.
  TrackedGrains moved = lattice.tracks;
  moved.scan_files[2] = (lattice.dir / "gone.h5").string();
  EXPECT_THROW(tracked_states(moved, "tracks.h5", {}, {}), UsageError);
  // One scan is no increment.
  TrackedGrains single = lattice.tracks;
  single.scans = 1;
  EXPECT_THROW(tracked_states(single, "tracks.h5", {}, {}), UsageError);
}

TEST(MicroAnalysis, IncrementsFollowFromAndToAndTheParametersRecordTheRun) {
  const TrackedLattice lattice;
  MicroOptions o;
  o.region = Region::Kind::box;
  MicroFile c = tracked_states(lattice.tracks, "tracks.h5", {}, {});
  std::vector<std::string> steps;
  analyse_states(c, "tracks.h5", schema::kind::tracks, -1, -1, o, [&](const std::string& step) {
    steps.push_back(step);
    return std::function<void(double)>();
  });
  EXPECT_EQ(steps, std::vector<std::string>{"micro-mechanics"});
  ASSERT_EQ(c.result.increments.size(), 2u);  // every pair of consecutive scans
  EXPECT_EQ(c.result.increments[1].from, 1u);
  // Uniform axial strain: the interior grains' local strain is the applied one, 0.5 % of the scan before.
  const LocalDeformation& g = c.result.increments[0].grains[(2 * kSide + 2) * kSide + 2];
  ASSERT_EQ(g.status, DeformationStatus::ok);
  EXPECT_NEAR(g.strain[2], 0.005, 1e-9);
  const nlohmann::json p = nlohmann::json::parse(c.parameters_json);
  EXPECT_EQ(p["source"], "tracks");
  EXPECT_EQ(p["coordination"], "distance");
  EXPECT_EQ(p["region"], "box");
  EXPECT_EQ(p["increments"], nlohmann::json::parse("[[0, 1], [1, 2]]"));

  analyse_states(c, "tracks.h5", schema::kind::tracks, 0, 2, o);
  ASSERT_EQ(c.result.increments.size(), 1u);
  EXPECT_EQ(c.result.increments[0].to, 2u);
  try {
    analyse_states(c, "results.h5", schema::kind::fdem_results, 0, 3, o);
    FAIL() << "an increment to a state the series lacks was analysed";
  } catch (const UsageError& e) {
    EXPECT_EQ(e.message(), "--from/--to must name frames 0..2 of results.h5");
  }
}
