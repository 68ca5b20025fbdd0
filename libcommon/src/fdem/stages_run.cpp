#include "graintwin/fdem/stages_run.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>

namespace graintwin::fdem {
namespace {

SolverOptions solver_options(const Scene& scene) {
  SolverOptions options;
  options.gravity = scene.gravity;
  options.damping = scene.damping;
  options.stiffness_damping = scene.stiffness_damping;
  options.local_damping = scene.local_damping;
  options.element_safety = scene.element_safety;
  options.rigid_contact_nodes = scene.rigid_contact_nodes;
  options.contact.enabled = scene.contact;
  options.elastostatic_stress = scene.elastostatic_stress;
  options.implicit_grains = scene.implicit_grains;
  return options;
}

/// Thrown by the triaxial test's step hook at the stop step, to leave run_triaxial there.
struct StoppedAtStep {};

}  // namespace

std::uint64_t steps_of(double interval, double dt) {
  return interval > 0 ? std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::llround(interval / dt))) : 0;
}

RunStart start_run(const Scene& scene, Model& model, const std::string& where) {
  const SolverOptions options = solver_options(scene);
  RunStart start;
  start.solver = std::make_unique<Solver>(model, options);
  // Overlaps are checked (or relaxed) on the solver's contact before anything heavy.
  start.overlaps = settle_initial_overlaps(*start.solver, model, scene.overlaps, where);
  if (start.overlaps.passes > 0) {
    start.solver.reset();
    start.solver = std::make_unique<Solver>(model, options);
  }
  // On the settled model: the grains that set the time step made heavier.
  start.scaling = scale_fastest_grains(model, *start.solver, scene.mass_scaled_share);
  if (start.scaling.grains > 0) start.solver->refresh_masses(start.scaling.scaled);
  // Then the elements that set the element step, before any step and after the grains' densities.
  if (scene.element_step_target > 0)
    start.selective_scaling = scale_limiting_nodes(*start.solver, scene.element_step_target, scene.largest_stiffness_damping(),
                                                   scene.max_added_mass_share, where);
  if (scene.overlaps.keep && start.solver->contact_model())
    start.solver->contact_model()->keep_initial_overlaps(start.overlaps.remaining);
  return start;
}

RunSchedule schedule_run(const Scene& scene, const Solver& solver, const std::string& where) {
  RunSchedule s;
  s.limits = solver.time_step_limits(scene.largest_stiffness_damping());
  s.dt = scene.time_step;
  if (s.dt > 0) {
    solver.check_time_step(s.dt, scene.largest_stiffness_damping());
  } else {
    s.dt = scene.time_step_fraction * s.limits.stable();
    if (!std::isfinite(s.dt))
      throw UsageError(where + ": no element or contact limit bounds the time step (rigid grains without contact); set "
                               "[run] time_step");
  }
  check_step_ceiling(estimate_steps(scene, solver, s.dt), scene.max_steps, scene, s.limits, s.dt, where);
  for (const StageSpec& st : scene.stages) s.stage_end.push_back(s.total += steps_of(st.duration, s.dt));
  s.frame_every = scene.frame_interval > 0 ? steps_of(scene.frame_interval, s.dt) : s.total;
  s.row_every = scene.series_interval > 0 ? steps_of(scene.series_interval, s.dt) : 1;
  s.checkpoint_every = steps_of(scene.checkpoint_interval, s.dt);
  return s;
}

std::string run_digest(const std::string& scene_text, const std::string& model_bytes, double dt) {
  return fmt::format("{:016x}", std::hash<std::string>{}(scene_text + model_bytes + fmt::format("|dt={:a}", dt)));
}

void set_initial_velocities(Solver& solver, const Scene& scene) {
  for (std::size_t g = 0; g < scene.grains.size(); ++g)
    solver.set_grain_velocity(scene.primitive_grain(g), scene.grains[g].velocity, scene.grains[g].angular_velocity);
}

nlohmann::json run_parameters(const Scene& scene, const std::string& scene_path, const std::string& scene_text,
                              const RunStart& start, const RunSchedule& schedule, int threads, const std::string& restart) {
  const OverlapSettlement& o = start.overlaps;
  const MassScaling& m = start.scaling;
  const SelectiveMassScaling& em = start.selective_scaling;
  return {{"scene", scene_path},
          {"scene_text", scene_text},
          {"time_step", schedule.dt},
          {"steps", schedule.total},
          {"threads", threads},
          {"restart", restart},
          {"model_file", scene.model ? scene.model->path.string() : ""},
          {"initial_overlaps",
           {{"deepest", o.deepest},
            {"relaxation_passes", o.passes},
            {"moved_grains", o.moved_grains},
            {"largest_move", o.largest_move},
            {"deepest_after", o.deepest_after}}},
          {"mass_scaling",
           {{"share", scene.mass_scaled_share},
            {"grains", m.grains},
            {"largest_factor", m.largest_factor},
            {"mass_share", m.mass_share},
            {"step_before", m.step_before},
            {"step_after", m.step_after}}},
          {"damping",
           {{"mass_proportional", scene.damping},
            {"stiffness_proportional", scene.stiffness_damping},
            {"local", scene.local_damping}}},
          {"deformable_integration", scene.implicit_grains ? "implicit" : "explicit"},
          {"selective_mass_scaling",
           {{"target_step", em.target_step},
            {"step_before", em.step_before},
            {"step_after", em.step_after},
            {"guaranteed_before", em.guaranteed_before},
            {"nodes", em.nodes},
            {"largest_factor", em.largest_factor},
            {"added_mass", em.added_mass},
            {"added_mass_share", em.added_share()},
            {"max_added_mass_share", em.max_added_share}}}};
}

nlohmann::json triaxial_summary_json(const TriaxialRunSummary& s) {
  return {{"consolidation_steps", s.consolidation_steps}, {"membrane_steps", s.membrane_steps},
          {"shear_steps", s.shear_steps},                 {"d50", s.d50},
          {"strain_rate", s.strain_rate},                 {"inertial_number", s.inertial_number},
          {"max_kinetic_ratio", s.max_kinetic_ratio},     {"membrane_balls", s.membrane_balls},
          {"ball_radius", s.ball_radius},                 {"membrane_density_scaling", s.density_scaling}};
}

void run_stages(Solver& solver, const Scene& scene, const RunSchedule& schedule, std::uint64_t last, ResultsWriter* writer,
                const StagesRunHooks& hooks) {
  double start = 0;
  for (const StageSpec& st : scene.stages) {
    if (writer) writer->add_stage(st.name, start);
    start += st.duration;
  }
  const auto add_frame = [&] {
    if (hooks.before_frame) hooks.before_frame();
    if (!writer) return;
    writer->add_frame(solver);
    if (hooks.frame) hooks.frame();
  };
  std::uint32_t stage = 0;
  while (solver.step_count() < last) {
    const std::uint64_t n = solver.step_count();
    while (n >= schedule.stage_end[stage]) ++stage;
    const StageSpec& s = scene.stages[stage];
    solver.set_damping(s.damping.value_or(scene.damping));
    solver.set_stiffness_damping(s.stiffness_damping.value_or(scene.stiffness_damping));
    solver.set_local_damping(s.local_damping.value_or(scene.local_damping));
    for (std::size_t k = 0; k < scene.platens.size(); ++k)
      solver.set_platen_velocity(k, s.platen_velocity[k].value_or(scene.platens[k].velocity));
    if (n % schedule.frame_every == 0) add_frame();
    StepReport report;
    try {
      report = solver.step(schedule.dt);
    } catch (Error& e) {
      if (hooks.step_failed) hooks.step_failed(e);
      throw;
    }
    if (writer && n % schedule.row_every == 0) writer->add_row(solver, report, stage, schedule.dt);
    const std::uint64_t done = solver.step_count();
    if (hooks.checkpoint && ((schedule.checkpoint_every > 0 && done % schedule.checkpoint_every == 0) || done == last))
      hooks.checkpoint();
    if (hooks.step) hooks.step();
  }
  add_frame();
}

std::optional<TriaxialRunSummary> run_triaxial_scene(Solver& solver, const Scene& scene, const RunSchedule& schedule,
                                                     std::uint64_t stop_step, ResultsWriter* writer, TriaxialRunHooks hooks,
                                                     const std::function<void(const TriaxialRunProgress&)>& checkpoint) {
  // A triaxial test's length is known only as it settles: checkpoints every interval, at the stop
  // step and at the end.
  TriaxialRunProgress last_progress;
  hooks.step = [&, then = hooks.step](const TriaxialMeasure& m, const StepReport& r, const TriaxialRunProgress& at) {
    last_progress = at;
    const std::uint64_t done = solver.step_count();
    if (schedule.checkpoint_every > 0 && done % schedule.checkpoint_every == 0) checkpoint(at);
    if (stop_step > 0 && done >= stop_step) {
      checkpoint(at);
      throw StoppedAtStep{};
    }
    if (then) then(m, r, at);
  };
  try {
    const TriaxialRunSummary summary = run_triaxial(solver, *scene.triaxial, schedule.dt, schedule.row_every, writer, hooks);
    checkpoint(last_progress);
    return summary;
  } catch (const StoppedAtStep&) {
    return std::nullopt;
  }
}

}  // namespace graintwin::fdem
