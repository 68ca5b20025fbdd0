// The pieces of the simulated loading: the membrane's surface from its balls, the grains' poses
// from a frame, the pairs' forces, the checks before any work.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>

#include "graintwin/core/error.hpp"
#include "graintwin/experiment/triaxial_loading.hpp"
#include "support/run_tool.hpp"

using namespace graintwin;

namespace {

// Rings of `per_ring` balls at heights z with centre radius r(theta, z) around (ax, ay), every
// other ring turned by half a ball as in the lattice.
std::vector<double> rings(double ax, double ay, const std::vector<double>& zs,
                          const std::function<double(double, double)>& r, int per_ring) {
  std::vector<double> out;
  for (std::size_t ring = 0; ring < zs.size(); ++ring)
    for (int k = 0; k < per_ring; ++k) {
      const double phi = 2.0 * std::numbers::pi * (k + 0.5 * static_cast<double>(ring % 2)) / per_ring - std::numbers::pi;
      const double rho = r(phi, zs[ring]);
      out.insert(out.end(), {ax + rho * std::cos(phi), ay + rho * std::sin(phi), zs[ring]});
    }
  return out;
}

}  // namespace

TEST(MembraneSurface, StraightCylinderGivesItsInnerRadiusEverywhere) {
  const double ball = 0.05e-3, radius = 2e-3;
  std::vector<double> zs;
  for (int k = 0; k < 40; ++k) zs.push_back(k * 0.087e-3);
  const auto surface = experiment::membrane_surface(rings(0.5e-3, -0.2e-3, zs, [&](double, double) { return radius; }, 126),
                                                    Eigen::Vector2d(0.5e-3, -0.2e-3), ball);
  for (double z : {-1e-3, 0.0, 1.3e-3, 3.3e-3, 9e-3})
    for (double t : {-3.1, -1.0, 0.0, 2.0, 3.14}) EXPECT_NEAR(surface(t, z), radius - ball, 1e-12) << z << " " << t;
}

TEST(MembraneSurface, BulgeAndHollowsBetweenGrainsAreFollowed) {
  // A barrel bulge and, around the axis, six hollows where the membrane is pressed between grains:
  // the bilinear bins follow both within a small share of their depth.
  const double ball = 0.03e-3, height = 3e-3, radius = 1.5e-3;
  const auto r = [&](double t, double z) {
    return radius + 0.2e-3 * 4.0 * z * (height - z) / (height * height) - 0.1e-3 * (0.5 + 0.5 * std::cos(6.0 * t));
  };
  std::vector<double> zs;
  for (int k = 0; k <= 57; ++k) zs.push_back(k * height / 57);
  const int per_ring = static_cast<int>(std::round(2.0 * std::numbers::pi * radius / (2.0 * ball)));
  const auto surface = experiment::membrane_surface(rings(0, 0, zs, r, per_ring), Eigen::Vector2d::Zero(), ball);
  double worst = 0.0;
  for (int k = 1; k < 30; ++k)
    for (int a = 0; a < 64; ++a) {
      const double z = k * height / 30, t = -std::numbers::pi + 2.0 * std::numbers::pi * a / 64;
      worst = std::max(worst, std::abs(surface(t, z) - (r(t, z) - ball)));
    }
  EXPECT_LT(worst, 0.1 * 0.1e-3);  // a tenth of the hollows' depth
  EXPECT_GT(surface(0.5, 0.5 * height), surface(0.0, 0.5 * height) + 0.07e-3);  // a hollow at theta 0, a ridge at pi/6
}

TEST(MembraneSurface, NoBallsIsRefused) {
  EXPECT_THROW(experiment::membrane_surface({}, Eigen::Vector2d::Zero(), 1e-4), UsageError);
  EXPECT_THROW(experiment::membrane_surface({0, 0, 0}, Eigen::Vector2d::Zero(), 0.0), UsageError);
}

TEST(FramePoses, RigidMotionOfTheBodyMovesTheShapeAboutTheBodysCentroid) {
  // The shape's origin (packed position) is not the mesh's centroid: a turn about the centroid
  // must move the origin on a circle around it.
  synth::PackedGrain packed;
  packed.position = {1e-3, 2e-3, 3e-3};
  packed.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()));
  const Eigen::Vector3d c0 = packed.position + Eigen::Vector3d(5e-6, -3e-6, 2e-6);
  const Eigen::Quaterniond q0(Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX()));
  const Eigen::Quaterniond turn(Eigen::AngleAxisd(0.7, Eigen::Vector3d(0, 1, 1).normalized()));
  const Eigen::Quaterniond q = turn * q0;
  const Eigen::Vector3d c = c0 + Eigen::Vector3d(-4e-5, 1e-5, -8e-5);
  const auto poses = experiment::frame_poses({packed}, {c0}, {q0}, {c.x(), c.y(), c.z()}, {q.w(), q.x(), q.y(), q.z()});
  ASSERT_EQ(poses.size(), 1u);
  // Any body point: where the reference pose put it, moved by the body's motion.
  const Eigen::Vector3d body_point(1e-4, -2e-4, 5e-5);
  const Eigen::Vector3d start = packed.position + packed.orientation * body_point;
  const Eigen::Vector3d expected = c + turn * (start - c0);
  const Eigen::Vector3d got = poses[0].position + poses[0].orientation * body_point;
  EXPECT_LT((got - expected).norm(), 1e-15);
  EXPECT_THROW(experiment::frame_poses({packed}, {c0}, {q0}, {0, 0}, {1, 0, 0, 0}), UsageError);
}

TEST(PairForces, SumsEachPairsContactPointsAndSkipsPlatens) {
  fdem::ResultsFrame f;
  f.pair = {1, 2, 1, 2, 2, 3, 4, 0};
  f.platen = {-1, -1, -1, 1};
  f.force = {1, 0, 0, 0.5, 1, 0, 0, 0, 2, 9, 9, 9};
  const auto forces = experiment::pair_forces(f);
  ASSERT_EQ(forces.size(), 2u);
  EXPECT_EQ(forces[0].low, 1u);
  EXPECT_EQ(forces[0].high, 2u);
  EXPECT_EQ(forces[0].force, Eigen::Vector3d(1.5, 1, 0));
  EXPECT_EQ(forces[1].low, 2u);
  EXPECT_EQ(forces[1].high, 3u);
  EXPECT_EQ(forces[1].force, Eigen::Vector3d(0, 0, 2));
}

TEST(LoadingChecks, GrainsWhoseShIsAFitABoxOrNoStrainAreRefused) {
  synth::SeriesParams p;
  p.container.kind = synth::Container::Kind::cylinder;
  p.strains = {0.0, 0.05};
  EXPECT_NO_THROW(experiment::check_loading_inputs(p));
  for (auto shape : {synth::GrainShape::angular, synth::GrainShape::library}) {
    synth::SeriesParams q = p;
    q.grains.shape = shape;
    EXPECT_THROW(experiment::check_loading_inputs(q), UsageError);
  }
  synth::SeriesParams box = p;
  box.container.kind = synth::Container::Kind::box;
  EXPECT_THROW(experiment::check_loading_inputs(box), UsageError);
  synth::SeriesParams flat = p;
  flat.strains = {0.0};
  EXPECT_THROW(experiment::check_loading_inputs(flat), UsageError);
}

TEST(LoadingChecks, SceneWithoutTriaxialTableIsRefusedNamingIt) {
  synth::Container cylinder;
  cylinder.kind = synth::Container::Kind::cylinder;
  cylinder.radius = 1.5e-3;
  cylinder.height = 3e-3;
  test::TempDir dir;
  const auto scene = dir / "stages.toml";
  std::ofstream(scene) << "[run]\nduration = 1e-3\n";
  try {
    experiment::check_loading_scene(scene, cylinder, 0.3e-3);
    FAIL() << "accepted a scene without [triaxial]";
  } catch (const UsageError& e) {
    EXPECT_NE(e.message().find("stages.toml"), std::string::npos) << e.message();
    EXPECT_NE(e.message().find("[triaxial]"), std::string::npos) << e.message();
  }
  EXPECT_NO_THROW(experiment::check_loading_scene(std::filesystem::path(GRAINTWIN_SOURCE_DIR) / "pipelines/scenes/triaxial.toml", cylinder, 0.3e-3));
}
