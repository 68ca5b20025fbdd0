// fdemrun: run an FDEM scene (docs/methods.md, FDEM).
//   fdemrun scene.toml results.h5 --checkpoint run.ckpt.h5
//   fdemrun scene.toml results.h5 --restart run.ckpt.h5 --force
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <cmath>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>

#include "graintwin/cli/option_checks.hpp"
#include "graintwin/cli/tool.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/interrupt.hpp"
#include "graintwin/fdem/ellipsoid_grain.hpp"
#include "graintwin/fdem/frames_vtk.hpp"
#include "graintwin/fdem/initial_overlap.hpp"
#include "graintwin/fdem/mass_scaling.hpp"
#include "graintwin/fdem/results_file.hpp"
#include "graintwin/fdem/scene.hpp"
#include "graintwin/fdem/solver.hpp"
#include "graintwin/fdem/triaxial_run.hpp"
#include "graintwin/io/atomic_output.hpp"

namespace fs = std::filesystem;
using namespace graintwin;
using namespace graintwin::fdem;

namespace {

/// Steps of `dt` that make up `interval` seconds (at least 1); 0 when the interval is 0.
std::uint64_t steps_of(double interval, double dt) {
  return interval > 0 ? std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::llround(interval / dt))) : 0;
}

std::string digest_of(const std::string& text) { return fmt::format("{:016x}", std::hash<std::string>{}(text)); }

/// A run that ended at --stop-step (its checkpoint written), to be continued with --restart.
struct StoppedAtStep {};

/// A --stop-step must lie beyond the step a restart begins at.
void check_stop_step(std::uint64_t stop_step, const Solver& solver, const fs::path& restart) {
  if (stop_step > 0 && stop_step <= solver.step_count())
    throw UsageError("--stop-step " + std::to_string(stop_step) + " is not beyond step " +
                     std::to_string(solver.step_count()) + " of " + restart.string() + "; give a later step");
}

/// Runs the scene's triaxial test: progress per phase, a status line every few thousand steps of a
/// consolidation (whose length is not known in advance), a warning when shearing was not quasi-static.
TriaxialRunSummary run_triaxial_test(cli::RunContext& ctx, Solver& solver, const TriaxialSpec& spec, double dt,
                                     std::uint64_t row_every, ResultsWriter& writer, TriaxialRunHooks hooks) {
  std::unique_ptr<cli::Progress> progress;
  std::string phase;
  std::size_t taken = 0;
  hooks.phase = [&](const std::string& name, std::size_t steps) {
    if (progress) progress->done();
    progress = steps ? ctx.progress(name + " steps", steps) : nullptr;
    phase = name;
    taken = 0;
    spdlog::info("{} begins at step {}{}", name, solver.step_count(), steps ? fmt::format(" ({} steps)", steps) : "");
  };
  hooks.step = [&, checkpoint = hooks.step](const TriaxialMeasure& m, const StepReport& r, const TriaxialRunProgress& at) {
    if (checkpoint) checkpoint(m, r, at);
    ++taken;
    if (progress) progress->advance();
    if (!progress && taken % 1000 == 0)
      spdlog::info("{}: {} steps, axial {:.4g} kPa, lateral {:.4g} kPa, kinetic / elastic energy {:.3g}, {} contact "
                   "searches rebuilt",
                   phase, taken, 1e-3 * m.axial_stress, 1e-3 * m.lateral_stress,
                   r.energies.kinetic / (r.energies.strain + r.energies.contact_elastic),
                   solver.contact_model()->rebuild_count());
    throw_if_interrupted();
  };
  const TriaxialRunSummary s = run_triaxial(solver, spec, dt, row_every, writer, hooks);
  if (progress) progress->done();
  spdlog::info("consolidated in {} + {} steps; sheared {} steps at {:.4g} /s (inertial number {:.2g}) to eps_1 = {:.4g}: "
               "sigma_1 / sigma_3 {:.4g}, eps_v {:.4g}",
               s.consolidation_steps, s.membrane_steps, s.shear_steps, s.strain_rate, s.inertial_number,
               std::log(s.start.height / s.end.height), s.end.axial_stress / s.end.lateral_stress,
               std::log(s.start.volume / s.end.volume));
  if (spec.membrane)
    spdlog::info("membrane: {} balls of radius {:.4g} mm, density scaled x {:.4g} for the time step", s.membrane_balls,
                 1e3 * s.ball_radius, s.density_scaling);
  if (s.max_kinetic_ratio > kQuasiStaticRatio)
    spdlog::warn("shearing was not quasi-static: the kinetic energy reached {:.3g} of the elastic energy (limit {:.2g}); "
                 "lower [triaxial] shear_inertial_number or strain_rate",
                 s.max_kinetic_ratio, kQuasiStaticRatio);
  return s;
}

void log_end(const ResultsWriter& writer, Solver& solver) {
  spdlog::info("{} frames, final time {:.6g} s after {} steps{}", writer.frames(), solver.time(), solver.step_count(),
               solver.has_contact() ? fmt::format(", contact search rebuilt {} times", solver.contact_model()->rebuild_count())
                                    : std::string());
}

nlohmann::json summary_json(const TriaxialRunSummary& s) {
  return {{"consolidation_steps", s.consolidation_steps}, {"membrane_steps", s.membrane_steps},
          {"shear_steps", s.shear_steps},                 {"d50", s.d50},
          {"strain_rate", s.strain_rate},                 {"inertial_number", s.inertial_number},
          {"max_kinetic_ratio", s.max_kinetic_ratio},     {"membrane_balls", s.membrane_balls},
          {"ball_radius", s.ball_radius},                 {"membrane_density_scaling", s.density_scaling}};
}

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool(
      "fdemrun",
      "Run an FDEM scene: grains as elastic 4- or 10-node tetrahedral meshes (total-Lagrangian St Venant-Kirchhoff, "
      "exact under large rotations) or rigid 6-DOF bodies, explicit central differences with lumped masses (HRZ for "
      "10-node elements), mass-proportional damping, gravity, moving platens and loading stages. The time step is the "
      "stable limit of the elements (k h_min / c x element_safety) and of the contacts unless the scene sets a smaller "
      "one; a larger one is refused with the numbers, and a run whose state turns NaN or whose energy runs away stops "
      "with the step and the likely cause. Writes kind=fdem_results: the energy and platen time series and frames of "
      "grain centroids, rotations, velocities, volume-averaged stresses (compression positive) and contacts. "
      "Checkpoints (--checkpoint) let --restart continue a run exactly; --vtk writes every frame as a .vtu of the "
      "deformed meshes with a .pvd index for ParaView. Grains come from a kind=fdem_model file (shapes2mesh) and/or "
      "primitives: boxes (structured mesh), spheres and ellipsoids (gmsh). Contact (penalty, dashpot, friction, "
      "platens) comes from the fdem contact module and is switched off with [run] contact = false; it is verified "
      "against a spring-dashpot bounce (restitution, contact time), a block on an incline, and on spheres meshed fine "
      "at the contact against Hertz and Chung & Ooi (2011) tests 1, 2, 6, 7 and LIGGGHTS (docs/fdemrun.md); a scene "
      "grades a sphere's or ellipsoid's mesh towards points with refine_at, fine_element_size and size_growth. The "
      "default penalty (the paper's 100 E per metre) is far too soft for mm grains: about 10 E / h (h: element size at the "
      "contact) reproduces Hertz; a material's penalty_per_size = 10 sets that (h: penalty_element_size, or the median "
      "surface edge of its grains). A scene with [triaxial] runs the triaxial test instead of [[stages]] (docs/fdem_triaxial.md): "
      "isotropic consolidation to sigma_3 inside a rigid servo wall, the membrane's forming procedure (bonded-ball "
      "membrane, clamped ends, confining pressure; or boundary = \"wall\" to keep the wall), then strain-controlled "
      "shearing to a target axial strain; its series adds sigma_1, sigma_3, sigma_1/sigma_3, the sample volume by eq. 27 "
      "and eq. 28, the log strains eps_1 and eps_v from the start of shearing, the kinetic/elastic energy ratio and the "
      "inertial number, and frames are saved at the start of shearing, at the frame_strains and at the end; its "
      "checkpoints also hold the wall, the membrane and where the procedure stands, so --restart resumes it mid-phase. "
      "Before the first step it refuses grains started inside each other or behind a platen deeper than [run] "
      "overlap_tolerance (or pushes them apart with relax_overlaps = true) and a run of more estimated steps than [run] "
      "max_steps. The scene format is in docs/fdemrun.md.");
  fs::path scene_path, output, checkpoint, restart, model_path;
  tool.add_input("scene", scene_path, "Scene file (.toml, docs/fdemrun.md)");
  tool.add_output("results", output, "Output kind=fdem_results .h5");
  auto& app = tool.cli();
  app.add_option("--checkpoint", checkpoint,
                 "Write the solver state here (.h5) every [run] checkpoint_interval and at the end, for --restart");
  app.add_option("--restart", restart, "Continue from a checkpoint of the same scene (the results then start there)")
      ->check(CLI::ExistingFile);
  app.add_option("--model", model_path,
                 "Take the grains from this kind=fdem_model file (shapes2mesh) instead of the scene's [model] file, e.g. "
                 "to run one scene on every sample")
      ->check(CLI::ExistingFile);
  fs::path vtk_folder;
  app.add_option("--vtk", vtk_folder,
                 "Also write every frame as FOLDER/frame_<k>.vtu (deformed meshes: displacement, velocity; grain label, "
                 "element stress) with FOLDER/frames.pvd for ParaView");
  std::uint64_t stop_step = 0;
  app.add_option("--stop-step", stop_step,
                 "Stop once the run reaches this step (0: run to the end), e.g. to split a long run into jobs with "
                 "--checkpoint and --restart; the results hold the steps taken")
      ->check(cli::whole_number_in(0, 1000000000000000LL, "steps"));
  tool.set_examples({"fdemrun pipelines/scenes/fdem_box_drop.toml runs/box_drop.h5",
                     "fdemrun scene.toml results.h5 --checkpoint results.ckpt.h5 --vtk results_frames",
                     "fdemrun scene.toml results.h5 --restart results.ckpt.h5 --force"});

  return tool.run(argc, argv, [&](cli::RunContext& ctx) {
    if (output.extension() != ".h5") throw UsageError("the results file " + output.string() + " must end in .h5");
    if (!checkpoint.empty() && checkpoint.extension() != ".h5")
      throw UsageError("--checkpoint " + checkpoint.string() + " must end in .h5");
    if (!checkpoint.empty() && !restart.empty() && fs::weakly_canonical(checkpoint) == fs::weakly_canonical(restart))
      throw UsageError("--checkpoint and --restart name the same file; write the new checkpoint elsewhere");
    for (const fs::path& in : {model_path, restart})
      if (!in.empty()) io::declare_input(in);
    if (!checkpoint.empty()) io::check_output_allowed(checkpoint, ctx.force());  // replaced as the run goes
    std::optional<io::AtomicOutput> vtk_out;
    if (!vtk_folder.empty()) vtk_out.emplace(vtk_folder, ctx.force());
    const Scene scene = read_scene(scene_path, model_path);
    if (scene.model) io::declare_input(scene.model->path);
    std::stringstream text;
    text << std::ifstream(scene_path).rdbuf();
    std::stringstream model_bytes;  // a restart needs the same model file too
    if (scene.model) model_bytes << std::ifstream(scene.model->path, std::ios::binary).rdbuf();
    Model model = build_model(scene, append_ellipsoid_grain);
    for (std::size_t k = 0; k < scene.size_penalties.size(); ++k)
      if (scene.size_penalties[k].per_size > 0)
        spdlog::info("material '{}': p_n = p_t = {:.4g} N/m^3 ({:g} E / h at h = {:.4g} mm)", model.materials[k].name,
                     model.materials[k].normal_penalty, scene.size_penalties[k].per_size,
                     1e3 * scene.size_penalties[k].per_size * model.materials[k].young / model.materials[k].normal_penalty);
    SolverOptions options;
    options.gravity = scene.gravity;
    options.damping = scene.damping;
    options.element_safety = scene.element_safety;
    options.rigid_contact_nodes = scene.rigid_contact_nodes;
    options.contact.enabled = scene.contact;
    auto built = std::make_unique<Solver>(model, options);
    // Overlaps are checked (or relaxed) on the solver's contact before anything heavy; relaxing moves
    // grains of the model, so the solver is built anew on it.
    const OverlapSettlement settled = settle_initial_overlaps(*built, model, scene.overlaps, scene_path.string());
    if (scene.contact && settled.passes == 0)
      spdlog::info("deepest initial overlap {:.3g} mm, within [run] overlap_tolerance", 1e3 * settled.deepest);
    if (settled.passes > 0) {
      spdlog::info("relaxed the initial overlaps ([run] relax_overlaps) in {} pass{}: {} grains moved, by at most {:.3g} mm; "
                   "deepest overlap {:.3g} mm, was {:.3g} mm",
                   settled.passes, settled.passes == 1 ? "" : "es", settled.moved_grains, 1e3 * settled.largest_move,
                   1e3 * settled.deepest_after, 1e3 * settled.deepest);
      built.reset();
      built = std::make_unique<Solver>(model, options);
    }
    // The grains that set the time step made heavier (scene [run] mass_scaled_share), on the
    // settled model: the solver is built anew on their materials.
    const MassScaling scaling = scale_fastest_grains(model, *built, scene.mass_scaled_share);
    if (scaling.grains > 0) {
      spdlog::info("mass scaling ([run] mass_scaled_share = {:g}): {} grains ({:.2g} % of the mass) made up to {:.3g} times denser; "
                   "their contact step limit {:.4g} s lifted to {:.4g} s",
                   scene.mass_scaled_share, scaling.grains, 100.0 * scaling.mass_share, scaling.largest_factor, scaling.step_before,
                   scaling.step_after);
      built.reset();
      built = std::make_unique<Solver>(model, options);
    }
    Solver& solver = *built;
    if (scene.overlaps.keep && solver.contact_model()) {
      solver.contact_model()->keep_initial_overlaps(settled.remaining);
      spdlog::info("{} initial overlaps kept force-free ([run] keep_initial_overlaps), the deepest {:.3g} mm", settled.remaining.size(),
                   1e3 * settled.deepest_after);
    }
    const StepLimits limits = solver.time_step_limits();
    double dt = scene.time_step;
    if (dt > 0) {
      solver.check_time_step(dt);
    } else {
      dt = limits.stable();
      if (!std::isfinite(dt))
        throw UsageError(scene_path.string() + ": no element or contact limit bounds the time step (rigid grains without "
                         "contact); set [run] time_step");
    }
    check_step_ceiling(estimate_steps(scene, solver, dt), scene.max_steps, scene, limits, dt, scene_path.string());
    std::uint64_t total = 0;
    std::vector<std::uint64_t> stage_end;
    for (const StageSpec& st : scene.stages) stage_end.push_back(total += steps_of(st.duration, dt));
    const std::uint64_t frame_every = scene.frame_interval > 0 ? steps_of(scene.frame_interval, dt) : total;
    const std::uint64_t row_every = scene.series_interval > 0 ? steps_of(scene.series_interval, dt) : 1;
    const std::uint64_t checkpoint_every = scene.checkpoint_interval > 0 ? steps_of(scene.checkpoint_interval, dt) : total;
    spdlog::info("{} grains, {} nodes, {} elements, {} platens; time step {:.4g} s (elements {:.4g} s, contact {:.4g} s), {}",
                 model.grains.size(), model.nodes.size(), model.element_count(), model.platens.size(), dt,
                 limits.element_stable, limits.contact_stable,
                 scene.triaxial ? std::string("a triaxial test")
                                : fmt::format("{} steps over {} stage(s)", total, scene.stages.size()));

    const std::string digest = digest_of(text.str() + model_bytes.str() + fmt::format("|dt={:a}", dt));
    io::AtomicOutput out(output, ctx.force());
    if (!restart.empty() && !scene.triaxial) {
      read_checkpoint(restart, solver, digest);
      check_stop_step(stop_step, solver, restart);
      spdlog::info("restarted from {} at step {} (t = {:.6g} s)", restart.string(), solver.step_count(), solver.time());
    } else if (restart.empty()) {
      for (std::size_t g = 0; g < scene.grains.size(); ++g)
        solver.set_grain_velocity(scene.primitive_grain(g), scene.grains[g].velocity, scene.grains[g].angular_velocity);
    }
    nlohmann::json p = {{"scene", scene_path.string()}, {"scene_text", text.str()}, {"time_step", dt},
                        {"steps", total},           {"threads", ctx.threads()},    {"restart", restart.string()},
                        {"model_file", scene.model ? scene.model->path.string() : ""},
                        {"initial_overlaps",
                         {{"deepest", settled.deepest},
                          {"relaxation_passes", settled.passes},
                          {"moved_grains", settled.moved_grains},
                          {"largest_move", settled.largest_move},
                          {"deepest_after", settled.deepest_after}}},
                        {"mass_scaling",
                         {{"share", scene.mass_scaled_share},
                          {"grains", scaling.grains},
                          {"largest_factor", scaling.largest_factor},
                          {"mass_share", scaling.mass_share},
                          {"step_before", scaling.step_before},
                          {"step_after", scaling.step_after}}}};
    ResultsWriter writer(out.temp_path(), solver, p.dump());
    std::optional<VtkFrameWriter> frames;
    if (vtk_out) frames.emplace(vtk_out->temp_path());
    const auto save_checkpoint = [&](const TriaxialRunProgress* triaxial) {
      if (checkpoint.empty()) return;
      io::AtomicOutput ckpt(checkpoint, true);
      write_checkpoint(ckpt.temp_path(), solver, digest, [&](io::H5File& f) {
        if (triaxial) save_progress(f, *triaxial);
      });
      ckpt.replace_now();
    };
    const auto with_checkpoint_context = [&](Error& e) {
      e.add_context(checkpoint.empty() ? std::string("no checkpoint was written (use --checkpoint)")
                                       : "last checkpoint: " + checkpoint.string());
    };
    if (scene.triaxial) {
      TriaxialRunHooks hooks;
      hooks.frame = [&] {
        if (frames) frames->add(solver);
      };
      if (!restart.empty())
        hooks.restore = [&](TriaxialRunProgress& at) {
          read_checkpoint(restart, solver, digest, [&](const io::H5File& f) { at = load_progress(f); });
          check_stop_step(stop_step, solver, restart);
          spdlog::info("restarted from {} at step {} (t = {:.6g} s)", restart.string(), solver.step_count(), solver.time());
        };
      // A triaxial test's length is known only as it settles: checkpoints every interval, at a
      // --stop-step and at the end.
      const std::uint64_t every = scene.checkpoint_interval > 0 ? steps_of(scene.checkpoint_interval, dt) : 0;
      TriaxialRunProgress last_progress;
      hooks.step = [&](const TriaxialMeasure&, const StepReport&, const TriaxialRunProgress& at) {
        last_progress = at;
        if (every > 0 && solver.step_count() % every == 0) save_checkpoint(&at);
        if (stop_step > 0 && solver.step_count() >= stop_step) {
          save_checkpoint(&at);
          throw StoppedAtStep{};
        }
      };
      try {
        const TriaxialRunSummary summary = run_triaxial_test(ctx, solver, *scene.triaxial, dt, row_every, writer, hooks);
        p["triaxial"] = summary_json(summary);
        save_checkpoint(&last_progress);
      } catch (const StoppedAtStep&) {
        spdlog::info("stopped at step {} (--stop-step){}", solver.step_count(),
                     checkpoint.empty() ? std::string() : "; continue with --restart " + checkpoint.string());
        p["stopped_at_step"] = solver.step_count();
      } catch (Error& e) {
        with_checkpoint_context(e);
        throw;
      }
      p["steps"] = solver.step_count();
      writer.set_parameters(p.dump());
      writer.finish(ctx.history());
      if (frames) frames->finish();
      io::commit_outputs({&out, vtk_out ? &*vtk_out : nullptr});
      log_end(writer, solver);
      return;
    }
    double start = 0;
    for (const StageSpec& st : scene.stages) writer.add_stage(st.name, start), start += st.duration;
    const auto add_frame = [&] {
      writer.add_frame(solver);
      if (frames) frames->add(solver);
    };
    const std::uint64_t last = stop_step > 0 ? std::min(stop_step, total) : total;
    auto progress = ctx.progress("steps", last - std::min(last, solver.step_count()));
    std::uint32_t stage = 0;
    while (solver.step_count() < last) {
      const std::uint64_t n = solver.step_count();
      while (n >= stage_end[stage]) ++stage;
      const StageSpec& s = scene.stages[stage];
      solver.set_damping(s.damping.value_or(scene.damping));
      for (std::size_t k = 0; k < scene.platens.size(); ++k)
        solver.set_platen_velocity(k, s.platen_velocity[k].value_or(scene.platens[k].velocity));
      if (n % frame_every == 0) add_frame();
      StepReport report;
      try {
        report = solver.step(dt);
      } catch (Error& e) {
        with_checkpoint_context(e);
        throw;
      }
      if (n % row_every == 0) writer.add_row(solver, report, stage, dt);
      if (solver.step_count() % checkpoint_every == 0 || solver.step_count() == last) save_checkpoint(nullptr);
      progress->advance();
      throw_if_interrupted();
    }
    progress->done();
    add_frame();
    writer.finish(ctx.history());
    if (frames) frames->finish();
    io::commit_outputs({&out, vtk_out ? &*vtk_out : nullptr});
    log_end(writer, solver);
  });
}
