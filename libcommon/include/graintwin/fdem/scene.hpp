#pragma once
// fdemrun scene files (TOML, docs/fdemrun.md): grains from a kind=fdem_model file and/or from
// primitives (box meshed here; sphere and ellipsoid through gmsh, graintwin_mesh), materials,
// platens, initial velocities, gravity, damping, loading stages and the output schedule. Every
// table refuses unknown keys, so a typo is an error naming the file, the table and the key, not a
// silently ignored setting.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "graintwin/core/enum_names.hpp"
#include "graintwin/fdem/initial_overlap.hpp"
#include "graintwin/fdem/model.hpp"
#include "graintwin/fdem/size_grading.hpp"
#include "graintwin/fdem/triaxial.hpp"

namespace graintwin::fdem {

/// The shapes a scene's [[grains]] may take, by their scene names.
enum class PrimitiveShape { box, sphere, ellipsoid };
inline constexpr std::array<EnumName<PrimitiveShape>, 3> kPrimitiveShapeNames{
    {{PrimitiveShape::box, "box"}, {PrimitiveShape::sphere, "sphere"}, {PrimitiveShape::ellipsoid, "ellipsoid"}}};

/// A primitive grain of the scene.
struct GrainSpec {
  PrimitiveShape shape = PrimitiveShape::box;
  /// m: box edges (x, y, z); sphere and ellipsoid: the semi-axes (a sphere's are its radius).
  Eigen::Vector3d size = Eigen::Vector3d::Zero();
  Eigen::Vector3d position = Eigen::Vector3d::Zero();        ///< m, centre
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  ///< ellipsoid axes -> world
  double element_size = 0;                                   ///< m
  GrainKind kind = GrainKind::tet4;
  std::uint32_t material = 0;                                ///< index into Scene::materials
  std::uint32_t label = 0;                                   ///< 0: its 1-based position in the scene
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();        ///< m/s
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();  ///< rad/s about its centroid
  /// Spheres and ellipsoids: element size graded from `fine` at the points (world, m) up to
  /// element_size (the coarse size), e.g. to resolve a Hertz contact at the pole that will touch.
  std::optional<SizeGrading> grading;
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
  std::optional<double> stiffness_damping;                    ///< s; unset: the run's
  std::optional<double> local_damping;                        ///< unset: the run's
  std::vector<std::optional<Eigen::Vector3d>> platen_velocity;  ///< per platen; unset: the platen's own
};

/// The deformable grains of a model file ([model.deformable], docs/fdemrun.md): the rule that
/// picked them and the grains it picked; the file's other grains are modelled rigid, the picked
/// ones keep their mesh's order (tet4 or tet10).
struct DeformableSelection {
  std::string rule;                   ///< e.g. "labels 3, 7", "D2min above 0.01 in micro.h5 (increment 2)"
  std::vector<std::uint32_t> grains;  ///< rows of the model file's grains, ascending, never empty
};

/// D2min / d50^2 of each track of a kind=micro file over increment `increment`, keyed by the
/// track's label in state `state`; tracks absent from that state or with D2min undefined are left
/// out. Given to read_scene by programs that link the micro module (fdemrun: micro::d2min_by_label).
using D2minByLabel = std::function<std::map<std::uint32_t, double>(const std::filesystem::path& micro, std::size_t state,
                                                                   std::size_t increment)>;

/// Grains of a kind=fdem_model file (shapes2mesh) taken into the scene.
struct ModelSource {
  std::filesystem::path path;           ///< empty for a model given in memory
  std::shared_ptr<const Model> model;   ///< as read; build_model copies it
  /// Every grain of the file modelled as this: rigid, or tet4 (10-node elements split into 4-node ones
  /// on their own nodes, split_into_linear_grains).
  std::optional<GrainKind> kind;
  std::optional<DeformableSelection> deformable;  ///< only these grains deformable, the rest rigid
};

/// A triaxial test ([triaxial], docs/fdem_triaxial.md): its stages are goal-based (isotropic
/// consolidation inside the servo wall, then the membrane's forming procedure, then shearing),
/// so a scene with [triaxial] has no [[stages]].
struct TriaxialSpec {
  TriaxialOptions options;
  bool membrane = true;                ///< false: the rigid servo wall stays the lateral boundary
  double shear_inertial_number = 1e-3;  ///< sets the shearing strain rate unless strain_rate does
  double strain_rate = 0;               ///< 1/s of the platen gap; 0 = from shear_inertial_number
  double target_axial_strain = 0.1;     ///< log strain eps_1 at which shearing ends
  double shear_ramp_strain = 5e-3;      ///< ShearOptions::ramp_strain
  /// Axial strains (e.g. the scans') at which frames are saved, besides the start of shearing and
  /// its end; ascending, below target_axial_strain.
  std::vector<double> frame_strains;
  std::size_t consolidation_steps = 200000;  ///< most steps each consolidation phase may take
  std::size_t pressure_ramp_steps = 2000;    ///< steps over which the membrane pressure is ramped up
};

/// A material's penalty set per element size at the contact (docs/fdemrun.md, sphere impacts):
/// p_n = p_t = per_size x E / h, h = element_size, or when 0 contact_element_size() of the built
/// model's grains of that material.
struct SizePenalty {
  double per_size = 0;      ///< 0: the material's own p_n and p_t stand
  double element_size = 0;  ///< m; 0 = measured on the model
};

struct Scene {
  /// The model file's materials first (a [[materials]] table of the same name replaces one), then
  /// the scene's other materials.
  std::vector<Material> materials;
  std::vector<SizePenalty> size_penalties;  ///< one per material
  std::optional<ModelSource> model;       ///< grains 0 .. model grains - 1 of the built model
  std::vector<GrainSpec> grains;          ///< primitives, after the model's grains
  /// The scene's [[platens]], or the model file's (at rest) when the scene has none.
  std::vector<PlatenSpec> platens;
  std::optional<SampleCylinder> sample;   ///< [sample], else the model file's
  std::vector<StageSpec> stages;          ///< at least one (a run without [[stages]] is one stage of run.duration); none with [triaxial]
  std::optional<TriaxialSpec> triaxial;   ///< a triaxial test instead of [[stages]]
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();  ///< m/s^2
  double damping = 0;                     ///< mass-proportional alpha, 1/s
  double stiffness_damping = 0;           ///< stiffness-proportional beta, s (SolverOptions::stiffness_damping)
  double local_damping = 0;               ///< local non-viscous damping, [0, 1) (SolverOptions::local_damping)
  /// [run] rigid_stress = "elastostatic": rigid grains' element stresses from their elastostatic state
  /// (SolverOptions::elastostatic_stress); "love_weber", the default: their Love-Weber grain stress only.
  bool elastostatic_stress = false;
  /// [run] deformable_integration = "implicit": deformable grains stepped implicitly in their
  /// corotated frames, past their element step (SolverOptions::implicit_grains); "explicit", the default.
  bool implicit_grains = false;
  double time_step = 0;                   ///< s; 0 = the stable limit times time_step_fraction
  /// The automatic step's share of the stable limit, in (0, 1]: a few per cent less is the smallest
  /// perturbation of a run, which shows how far its chaotic outcome scatters (docs/fdemrun.md).
  double time_step_fraction = 1.0;
  double element_safety = 0.8;            ///< fraction of the element critical step
  double rigid_contact_nodes = 12;        ///< SolverOptions::rigid_contact_nodes
  bool contact = true;
  double frame_interval = 0;              ///< s between saved frames; 0 = first and last only
  double series_interval = 0;             ///< s between time-series rows; 0 = every step
  double checkpoint_interval = 0;         ///< s between checkpoints; 0 = at the end only
  /// Initial overlaps (fdem/initial_overlap.hpp): [run] overlap_tolerance and relax_overlaps.
  OverlapOptions overlaps;
  /// [run] mass_scaled_share: the share of the grains, those with the smallest contact time steps,
  /// whose density is scaled so the step is the rest's (scale_fastest_grains); 0 = none.
  double mass_scaled_share = 0;
  /// [run] element_step_target: the element stable step (s) selective mass scaling lifts the
  /// deformable grains to, with a proof (scale_limiting_nodes); 0 = none. Quasi-static runs only: a
  /// [triaxial] test, or [[stages]] that all damp.
  double element_step_target = 0;
  /// [run] max_added_mass_share: the most mass selective mass scaling may add, a share of the grains' mass.
  double max_added_mass_share = 0.01;
  /// Most steps a run may take, estimated before it starts (check_step_ceiling); [run] max_steps.
  double max_steps = 1e7;
  double total_duration() const;
  /// Whether the built model will hold a deformable grain (the model file's, as [model] kind or
  /// [model.deformable] leave them, or a primitive's).
  bool has_deformable_grains() const;
  /// The largest stiffness damping of the run and its stages, s: the one the time step must allow for.
  double largest_stiffness_damping() const;
  /// Index in the built model of primitive grain k (the model file's grains come first).
  std::size_t primitive_grain(std::size_t k) const { return (model ? model->model->grains.size() : 0) + k; }
};

/// Parses and checks a scene (and reads its model file, a path relative to the scene's folder, or
/// `model_file` when given, which replaces [model] file); UsageError naming the file, the table
/// and the fix on any problem.
/// `d2min` reads the kind=micro file of a [model.deformable] d2min rule (UsageError when the scene
/// has one and it is not given).
Scene read_scene(const std::filesystem::path& path, const std::filesystem::path& model_file = {},
                 const D2minByLabel& d2min = {});
/// The same with the model's grains given in memory (ModelSource::path empty): [model] file, if
/// any, is not read.
Scene read_scene(const std::filesystem::path& path, std::shared_ptr<const Model> model, const D2minByLabel& d2min = {});

/// Appends a sphere or ellipsoid grain to a model. gmsh is linked only into graintwin_mesh, so
/// programs that mesh pass mesh::append_ellipsoid_grain (mesh/ellipsoid_grain.hpp).
using CurvedGrainMesher = std::function<void(Model&, const GrainSpec&)>;

/// The model of the scene: the model file's grains, then the primitives in scene order (boxes
/// meshed here, spheres and ellipsoids by `mesh_curved`), the platens and the sample cylinder;
/// penalties set per element size are resolved on the built meshes. UsageError when the scene has
/// curved grains and no mesher is given, or a per-size penalty names a material no grain uses.
Model build_model(const Scene& scene, const CurvedGrainMesher& mesh_curved = {});

/// How many grains of the model are rigid, tet4 and tet10 (indexed by GrainKind).
std::array<std::size_t, 3> grain_kind_counts(const Model& model);

/// Median element edge at the surfaces of the grains of `material`, m: the surface triangles'
/// median edge, doubled for 10-node grains (their curved faces are split through the mid-edge
/// nodes). 0 when no grain uses the material.
double contact_element_size(const Model& model, std::uint32_t material);

}  // namespace graintwin::fdem
