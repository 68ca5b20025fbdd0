#pragma once
// The whole triaxial test of a scene with [triaxial] (docs/fdem_triaxial.md): isotropic
// consolidation inside the servo wall, the membrane's forming procedure (unless the wall stays the
// boundary), then strain-controlled shearing to the target axial strain; every step's energies and
// triaxial measurement go to the results' time series, frames at the start of shearing, at the
// requested axial strains and at the end.
#include <cstdint>
#include <functional>
#include <string>

#include "graintwin/fdem/results_file.hpp"
#include "graintwin/fdem/scene.hpp"
#include "graintwin/fdem/triaxial.hpp"

namespace graintwin::fdem {

/// Where the whole test stands after a step: the running procedure's progress and what the run
/// has gathered, so a checkpoint can resume it (with the solver's and the boundary's state).
struct TriaxialRunProgress {
  TriaxialProgress procedure;
  std::uint64_t consolidation_steps = 0, membrane_steps = 0;
  TriaxialMeasure start;          ///< at the start of shearing (the strains' reference)
  std::uint64_t next_frame = 0;   ///< first of TriaxialSpec::frame_strains not yet saved
  double max_kinetic_ratio = 0;   ///< while shearing
};
/// A checkpoint's /triaxial group: what save_progress wrote; DataError when it is missing or bad.
void save_progress(io::H5File& file, const TriaxialRunProgress& progress);
TriaxialRunProgress load_progress(const io::H5File& file);

struct TriaxialRunHooks {
  /// A phase begins: its name and the steps it will take (0 when it runs until it has settled).
  std::function<void(const std::string& phase, std::size_t steps)> phase;
  /// After every step, with its measurement, report and the test's progress (progress display,
  /// checkpoints, interrupts: it may throw).
  std::function<void(const TriaxialMeasure&, const StepReport&, const TriaxialRunProgress&)> step;
  /// Before every frame, on every rank (e.g. to gather on rank 0 what one rank holds, as
  /// mpi::DistributedRun::gather_output does).
  std::function<void()> before_frame;
  /// After every frame written to the results (e.g. to write it as VTK too).
  std::function<void()> frame;
  /// A restart: called once the boundary is set, to load the solver's (and so the boundary's) state
  /// and the progress from a checkpoint; the test then resumes where that checkpoint was taken.
  std::function<void(TriaxialRunProgress&)> restore;
  /// Once the boundary is set and any restart loaded, before the first step (e.g. to split the run
  /// over ranks where the grains are then).
  std::function<void()> ready;
};

/// What the run did, for the log and the results' parameters.
struct TriaxialRunSummary {
  std::size_t consolidation_steps = 0, membrane_steps = 0, shear_steps = 0;
  double d50 = 0;                 ///< m, of the grains (volume-equivalent spheres)
  double strain_rate = 0;         ///< 1/s, shearing
  double inertial_number = 0;     ///< of the shearing at sigma_3
  double max_kinetic_ratio = 0;   ///< largest kinetic / elastic energy while shearing
  std::size_t membrane_balls = 0;
  double ball_radius = 0;         ///< m
  double density_scaling = 1;     ///< of the membrane, for the run's time step
  TriaxialMeasure start, end;     ///< at the start and the end of shearing
};

/// A run's length in steps, estimated before it starts.
struct StepEstimate {
  double steps = 0;  ///< a double: an absurd estimate (a penalty far too stiff) is reported, not overflowed
  std::string how;   ///< what it is made of, e.g. "6e-05 s of stages at 1.5e-08 s a step"
};

/// The steps the scene's run takes at time step `dt` on `solver` (built from the scene's model):
/// the stages' duration over dt, or for a triaxial test at most [triaxial] consolidation_steps in
/// each consolidation phase (one in the wall, one in the membrane) plus the shearing's steps at
/// its strain rate.
StepEstimate estimate_steps(const Scene& scene, const Solver& solver, double dt);

/// UsageError naming `where` (the scene file) when `estimate` exceeds `max_steps` ([run]
/// max_steps): the steps, what they are made of, what set the time step (the scene's time_step,
/// the element or the contact limit of `limits`) and the fixes.
void check_step_ceiling(const StepEstimate& estimate, double max_steps, const Scene& scene, const StepLimits& limits,
                        double dt, const std::string& where);

/// A status line for a step of a consolidation, whose length is not known in advance: the step
/// against [triaxial] consolidation_steps, the stresses against sigma_3 and the tolerance that
/// settles them, the kinetic energy against the quasi-static ratio, and the settled steps against
/// the kSettledSteps that end it, e.g. "step 1200 of at most 200000, in the wall: axial 11.2 kPa,
/// lateral 7.29 kPa (settle within 1 % of 300 kPa); kinetic / elastic energy 6.12 (settles below
/// 0.05); settled for 0 of 100 steps". For logs; a shearing step gets its stresses and energy.
std::string consolidation_status(const TriaxialSpec& spec, const TriaxialMeasure& m, const StepReport& r,
                                 const TriaxialProgress& at);

/// Runs the test on `solver` (which must have contact, and platens "bottom" and "top") at time
/// step `dt`, a series row every `row_every` steps into `writer` (none: a rank that writes nothing
/// but steps its share). UsageError before any step on a model the test cannot run; DataError
/// when a consolidation does not settle.
TriaxialRunSummary run_triaxial(Solver& solver, const TriaxialSpec& spec, double dt, std::uint64_t row_every,
                                ResultsWriter* writer, const TriaxialRunHooks& hooks = {});

}  // namespace graintwin::fdem
