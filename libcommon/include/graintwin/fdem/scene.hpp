#pragma once
// fdemrun scene files (TOML, docs/fdemrun.md): materials, grains from primitives (box now; sphere
// and ellipsoid through gmsh once the mesh module lands), platens, initial velocities, gravity,
// damping, loading stages and the output schedule. Every table refuses unknown keys, so a typo is
// an error naming the file, the table and the key, not a silently ignored setting.
#include <Eigen/Core>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "graintwin/fdem/model.hpp"

namespace graintwin::fdem {

struct GrainSpec {
  std::string shape = "box";                                 ///< box (sphere, ellipsoid: not yet)
  Eigen::Vector3d size = Eigen::Vector3d::Zero();            ///< m: box edges (x, y, z)
  Eigen::Vector3d position = Eigen::Vector3d::Zero();        ///< m, centre
  double element_size = 0;                                   ///< m
  GrainKind kind = GrainKind::tet4;
  std::uint32_t material = 0;                                ///< index into Scene::materials
  std::uint32_t label = 0;                                   ///< 0: its 1-based position in the scene
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();        ///< m/s
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();  ///< rad/s about its centroid
};

struct PlatenSpec {
  Platen platen;
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  ///< m/s, used by stages that do not set it
};

/// A loading stage: `duration` seconds with the platen velocities and damping it sets.
struct StageSpec {
  std::string name;
  double duration = 0;                                        ///< s
  std::optional<double> damping;                              ///< 1/s; unset: the run's
  std::vector<std::optional<Eigen::Vector3d>> platen_velocity;  ///< per platen; unset: the platen's own
};

struct Scene {
  std::vector<Material> materials;
  std::vector<GrainSpec> grains;
  std::vector<PlatenSpec> platens;
  std::vector<StageSpec> stages;          ///< at least one (a run without [[stages]] is one stage of run.duration)
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();  ///< m/s^2
  double damping = 0;                     ///< mass-proportional alpha, 1/s
  double time_step = 0;                   ///< s; 0 = the stable limit
  double element_safety = 0.8;            ///< fraction of the element critical step
  bool contact = true;
  double frame_interval = 0;              ///< s between saved frames; 0 = first and last only
  double series_interval = 0;             ///< s between time-series rows; 0 = every step
  double checkpoint_interval = 0;         ///< s between checkpoints; 0 = at the end only
  double total_duration() const;
};

/// Parses and checks a scene; UsageError naming the file, the table and the fix on any problem.
Scene read_scene(const std::filesystem::path& path);
/// The model of the scene's grains and platens (grains meshed here, in scene order).
Model build_model(const Scene& scene);

}  // namespace graintwin::fdem
