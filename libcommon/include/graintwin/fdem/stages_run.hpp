#pragma once
// A scene's run between reading the scene and writing its results (fdemrun; docs/fdemrun.md): the
// solver started on the built model (initial overlaps checked or relaxed, the fastest grains
// mass-scaled), the time step and step counts, the checkpoints' digest, the run's parameters, and
// the time loop over the scene's [[stages]] or its triaxial test (fdem/triaxial_run) with
// checkpoints and an early stop.
#include <nlohmann/json.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/initial_overlap.hpp"
#include "graintwin/fdem/mass_scaling.hpp"
#include "graintwin/fdem/results_file.hpp"
#include "graintwin/fdem/scene.hpp"
#include "graintwin/fdem/solver.hpp"
#include "graintwin/fdem/triaxial_run.hpp"

namespace graintwin::fdem {

/// Steps of `dt` (s) that make up `interval` seconds: at least 1, or 0 when the interval is 0.
std::uint64_t steps_of(double interval, double dt);

/// The solver a run starts from and what was done to the model before it.
struct RunStart {
  std::unique_ptr<Solver> solver;  ///< built on the model given to start_run, which must outlive it
  OverlapSettlement overlaps;
  MassScaling scaling;
  SelectiveMassScaling selective_scaling;  ///< selective mass scaling ([run] element_step_target)
};

/// Builds the solver of `scene` (gravity, damping, element safety, contact) on `model` (the scene's
/// built model), checks or relaxes the initial overlaps (settle_initial_overlaps; `where` names the
/// scene file in its errors), scales the fastest grains' density ([run] mass_scaled_share), scales
/// mass onto the nodes that limit the element step ([run] element_step_target; UsageError beyond [run]
/// max_added_mass_share) and, with [run] keep_initial_overlaps, makes the overlaps left force-free. Relaxation and scaling
/// change `model`, so the solver is built anew after each.
RunStart start_run(const Scene& scene, Model& model, const std::string& where);

/// The run's time step and its step counts.
struct RunSchedule {
  double dt = 0;                         ///< s: the scene's [run] time_step, else the stable limit
  StepLimits limits;                     ///< of the solver, with the scene's largest stiffness damping
  std::uint64_t total = 0;               ///< steps of all [[stages]] (0 for a triaxial test)
  std::vector<std::uint64_t> stage_end;  ///< per stage, the step count at its end
  std::uint64_t frame_every = 0;         ///< steps between frames; `total` (first frame only) without [run] frame_interval
  std::uint64_t row_every = 1;           ///< steps between series rows
  std::uint64_t checkpoint_every = 0;    ///< steps between checkpoints; 0: at the end (or a stop) only
};

/// The schedule of `scene`'s run on `solver`: UsageError naming `where` (the scene file) when the
/// scene's time step is not stable, when nothing bounds the step (rigid grains without contact and
/// no [run] time_step), or when the run's estimated steps exceed [run] max_steps.
RunSchedule schedule_run(const Scene& scene, const Solver& solver, const std::string& where);

/// What a checkpoint is tied to (16 hex digits): the scene's text, its model file's bytes and the
/// time step, so that a restart refuses a checkpoint of another scene, model or step.
std::string run_digest(const std::string& scene_text, const std::string& model_bytes, double dt);

/// Gives the scene's primitive grains their initial velocities (a fresh run, not a restart).
void set_initial_velocities(Solver& solver, const Scene& scene);

/// The results' parameters (JSON object): the scene (its path and text), the time step and the
/// stages' steps, the threads, the restart checkpoint ("" for none), the model file, what was done
/// to the initial overlaps, the damping and both kinds of mass scaling.
nlohmann::json run_parameters(const Scene& scene, const std::string& scene_path, const std::string& scene_text,
                              const RunStart& start, const RunSchedule& schedule, int threads, const std::string& restart);

/// A triaxial test's summary in the results' parameters ("triaxial").
nlohmann::json triaxial_summary_json(const TriaxialRunSummary& summary);

/// The run's calls out of the stages' time loop.
struct StagesRunHooks {
  /// before each frame, on every rank (a run split over ranks gathers the output state on rank 0)
  std::function<void()> before_frame;
  std::function<void()> frame;              ///< after a frame went to the results (e.g. to write it as VTK too)
  std::function<void()> checkpoint;         ///< every schedule.checkpoint_every steps and after the last step
  std::function<void()> step;               ///< after every step and its checkpoint (progress, interrupts; may throw)
  std::function<void(Error&)> step_failed;  ///< a step threw this: add what the caller knows before it propagates
};

/// Runs the scene's [[stages]] (named in the results with their start times) from the solver's
/// current step (0, or a restart's) up to step `last` (schedule.total, or earlier to stop): each
/// step takes its stage's damping (all three kinds) and platen velocities; a series row every
/// row_every steps, a frame every frame_every steps and one after the last step. `writer` is
/// nullptr on the ranks of a run split over ranks that write nothing (all but rank 0): they step
/// alike and join in hooks.before_frame.
void run_stages(Solver& solver, const Scene& scene, const RunSchedule& schedule, std::uint64_t last, ResultsWriter* writer,
                const StagesRunHooks& hooks);

/// Runs the scene's triaxial test (run_triaxial) with checkpoints: `checkpoint` every
/// schedule.checkpoint_every steps, at `stop_step` (0: none) and at the end, before hooks.step.
/// The test's summary, or nothing when it stopped at `stop_step` (its checkpoint written).
/// `writer`: as for run_stages.
std::optional<TriaxialRunSummary> run_triaxial_scene(Solver& solver, const Scene& scene, const RunSchedule& schedule,
                                                     std::uint64_t stop_step, ResultsWriter* writer, TriaxialRunHooks hooks,
                                                     const std::function<void(const TriaxialRunProgress&)>& checkpoint);

}  // namespace graintwin::fdem
