// fdemrun: run an FDEM scene (docs/methods.md, FDEM).
//   fdemrun scene.toml results.h5 --checkpoint run.ckpt.h5
//   fdemrun scene.toml results.h5 --restart run.ckpt.h5 --force
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>

#include "graintwin/cli/option_checks.hpp"
#include "graintwin/cli/tool.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/interrupt.hpp"
#include "graintwin/core/interval.hpp"
#include "graintwin/mesh/ellipsoid_grain.hpp"
#include "graintwin/fdem/frames_vtk.hpp"
#include "graintwin/fdem/results_file.hpp"
#include "graintwin/fdem/scene.hpp"
#include "graintwin/fdem/stages_run.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "graintwin/micro/micro_file.hpp"
#include "graintwin/mpi/distributed_run.hpp"
#include "graintwin/mpi/session.hpp"

namespace fs = std::filesystem;
using namespace graintwin;
using namespace graintwin::fdem;

namespace {

constexpr const char* kDescription =
    "Run an FDEM scene: grains as elastic 4- or 10-node tetrahedral meshes (total-Lagrangian St Venant-Kirchhoff, "
    "exact under large rotations) or rigid 6-DOF bodies, explicit central differences with lumped masses (HRZ for "
    "10-node elements), mass- and stiffness-proportional (Rayleigh) and local non-viscous damping, gravity, moving "
    "platens and loading stages. The time step is the stable limit of the elements (k h_min / c, shortened by "
    "stiffness damping, x element_safety) and of the contacts unless the scene sets a smaller one; quasi-static runs "
    "may lift the element limit by selective mass scaling ([run] element_step_target: mass on the nodes of the "
    "smallest and flattest elements until a bound on the mesh's highest frequency guarantees the target; the mass "
    "added bounded by max_added_mass_share, 1 % by default). A larger step is "
    "refused with the numbers, and a run whose state turns NaN or whose energy runs away stops "
    "with the step and the likely cause. Writes kind=fdem_results: the energy and platen time series and frames of "
    "grain centroids, rotations, velocities, volume-averaged stresses (compression positive), the deformable grains' "
    "element stresses (with [run] rigid_stress = \"elastostatic\" the rigid grains' too: each one's static linear-elastic "
    "state under its contact forces, computed at frames) and contacts. "
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
    "max_steps. Under mpirun -np N a scene, with [[stages]] or a triaxial test, of rigid or deformable grains runs "
    "across N ranks with the one-rank results bit for bit (rank 0 writes the results and --vtk; the sample is cut again "
    "when the time measured per rank is out of balance; every rank writes its part of a checkpoint at once, beside "
    "the --checkpoint file as <stem>.rank<k>-a.h5 or -b.h5, and it continues on any rank count; [run] rigid_stress = "
    "\"elastostatic\" runs on one rank so far). The scene format is in docs/fdemrun.md.";

/// The command line: the scene, the results and the run's own files.
struct Options {
  fs::path scene, output, checkpoint, restart, model, vtk;
  std::uint64_t stop_step = 0;
};

void add_options(cli::Tool& tool, Options& o) {
  tool.add_input("scene", o.scene, "Scene file (.toml, docs/fdemrun.md)");
  tool.add_output("results", o.output, "Output kind=fdem_results .h5");
  auto& app = tool.cli();
  app.add_option("--checkpoint", o.checkpoint,
                 "Write the solver state here (.h5) every [run] checkpoint_interval and at the end, for --restart");
  app.add_option("--restart", o.restart, "Continue from a checkpoint of the same scene (the results then start there)")
      ->check(CLI::ExistingFile);
  app.add_option("--model", o.model,
                 "Take the grains from this kind=fdem_model file (shapes2mesh) instead of the scene's [model] file, e.g. "
                 "to run one scene on every sample")
      ->check(CLI::ExistingFile);
  app.add_option("--vtk", o.vtk,
                 "Also write every frame as FOLDER/frame_<k>.vtu (deformed meshes: displacement, velocity; grain label, "
                 "element stress) with FOLDER/frames.pvd for ParaView");
  app.add_option("--stop-step", o.stop_step,
                 "Stop once the run reaches this step (0: run to the end), e.g. to split a long run into jobs with "
                 "--checkpoint and --restart; the results hold the steps taken")
      ->check(cli::whole_number_in(0, 1000000000000000LL, "steps"));
  tool.set_examples({"fdemrun pipelines/scenes/fdem_box_drop.toml runs/box_drop.h5",
                     "fdemrun scene.toml results.h5 --checkpoint results.ckpt.h5 --vtk results_frames",
                     "fdemrun scene.toml results.h5 --restart results.ckpt.h5 --force"});
}

/// The run's file names and inputs, checked before the scene is read.
void check_files(const Options& o, bool force) {
  if (o.output.extension() != ".h5") throw UsageError("the results file " + o.output.string() + " must end in .h5");
  if (!o.checkpoint.empty() && o.checkpoint.extension() != ".h5")
    throw UsageError("--checkpoint " + o.checkpoint.string() + " must end in .h5");
  if (!o.checkpoint.empty() && !o.restart.empty() && fs::weakly_canonical(o.checkpoint) == fs::weakly_canonical(o.restart))
    throw UsageError("--checkpoint and --restart name the same file; write the new checkpoint elsewhere");
  for (const fs::path& in : {o.model, o.restart})
    if (!in.empty()) io::declare_input(in);
  if (!o.checkpoint.empty()) io::check_output_allowed(o.checkpoint, force);  // replaced as the run goes
}

std::string file_bytes(const fs::path& path) {
  std::stringstream bytes;
  bytes << std::ifstream(path, std::ios::binary).rdbuf();
  return bytes.str();
}

/// --checkpoint: the solver's state, written over the last one as the run goes (for --restart);
/// split over ranks, by every rank at once (its main file and a part per other rank).
struct Checkpoints {
  const fs::path& path;
  const Solver& solver;
  const std::string& digest;
  const std::unique_ptr<mpi::DistributedRun>& ranks;
  bool writes;  ///< this process writes a checkpoint alone (rank 0, or the only rank)
  mutable char set = 'a';  ///< the ranks' part set the next checkpoint takes
  mutable std::size_t written = 0;
  mutable double seconds = 0;

  void save(const TriaxialRunProgress* triaxial) const {
    if (path.empty()) return;
    const double start = monotonic_seconds();
    const auto also = [&](io::H5File& f) {
      if (triaxial) save_progress(f, *triaxial);
    };
    if (ranks) {
      ranks->write_checkpoint(path, digest, set, also);
      set = set == 'a' ? 'b' : 'a';
    } else if (writes) {
      io::AtomicOutput ckpt(path, true);
      write_checkpoint(ckpt.temp_path(), solver, digest, also);
      ckpt.replace_now();
    }
    ++written;
    seconds += monotonic_seconds() - start;
  }
  /// Where a failed run can be continued from.
  void add_context(Error& e) const {
    e.add_context(path.empty() ? std::string("no checkpoint was written (use --checkpoint)") : "last checkpoint: " + path.string());
  }
};

/// Continues from --restart: the solver's state, and a triaxial test's progress into `triaxial`; refuses a
/// --checkpoint that would replace one of the restart's part files.
void restart_from(const Options& o, Solver& solver, const std::string& digest, TriaxialRunProgress* triaxial, int ranks) {
  read_checkpoint(o.restart, solver, digest, [&](const io::H5File& f) {
    if (triaxial) *triaxial = load_progress(f);
  });
  // Its parts are inputs now: a --checkpoint that would write over one is refused before any step.
  if (!o.checkpoint.empty()) {
    io::check_output_allowed(o.checkpoint, true);
    check_checkpoint_parts_allowed(o.checkpoint, ranks, true);
  }
  // A --stop-step must lie beyond the step the restart begins at.
  if (o.stop_step > 0 && o.stop_step <= solver.step_count())
    throw UsageError("--stop-step " + std::to_string(o.stop_step) + " is not beyond step " +
                     std::to_string(solver.step_count()) + " of " + o.restart.string() + "; give a later step");
  spdlog::info("restarted from {} at step {} (t = {:.6g} s)", o.restart.string(), solver.step_count(), solver.time());
}

void log_size_penalties(const Scene& scene, const Model& model) {
  for (std::size_t k = 0; k < scene.size_penalties.size(); ++k)
    if (scene.size_penalties[k].per_size > 0)
      spdlog::info("material '{}': p_n = p_t = {:.4g} N/m^3 ({:g} E / h at h = {:.4g} mm)", model.materials[k].name,
                   model.materials[k].normal_penalty, scene.size_penalties[k].per_size,
                   1e3 * scene.size_penalties[k].per_size * model.materials[k].young / model.materials[k].normal_penalty);
}

void log_start(const Scene& scene, const RunStart& start) {
  const OverlapSettlement& settled = start.overlaps;
  if (scene.contact && settled.passes == 0)
    spdlog::info("deepest initial overlap {:.3g} mm, within [run] overlap_tolerance", 1e3 * settled.deepest);
  if (settled.passes > 0)
    spdlog::info("relaxed the initial overlaps ([run] relax_overlaps) in {} pass{}: {} grains moved, by at most {:.3g} mm; "
                 "deepest overlap {:.3g} mm, was {:.3g} mm",
                 settled.passes, settled.passes == 1 ? "" : "es", settled.moved_grains, 1e3 * settled.largest_move,
                 1e3 * settled.deepest_after, 1e3 * settled.deepest);
  const MassScaling& scaling = start.scaling;
  if (scaling.grains > 0)
    spdlog::info("mass scaling ([run] mass_scaled_share = {:g}): {} grains ({:.2g} % of the mass) made up to {:.3g} times denser; "
                 "their contact step limit {:.4g} s lifted to {:.4g} s",
                 scene.mass_scaled_share, scaling.grains, 100.0 * scaling.mass_share, scaling.largest_factor, scaling.step_before,
                 scaling.step_after);
  const SelectiveMassScaling& selective = start.selective_scaling;
  if (scene.element_step_target > 0)
    spdlog::info("selective mass scaling ([run] element_step_target = {:.4g} s): {} nodes up to {:.3g} times heavier, "
                 "{:.4g} kg added ({:.3g} % of the grains' mass, bound {:.3g} %); element step limit {:.4g} s lifted to {:.4g} s "
                 "(guaranteed; the unscaled masses guarantee {:.4g} s)",
                 scene.element_step_target, selective.nodes, selective.largest_factor, selective.added_mass,
                 100.0 * selective.added_share(), 100.0 * selective.max_added_share, selective.step_before,
                 selective.step_after, selective.guaranteed_before);
  if (scene.overlaps.keep && start.solver->contact_model())
    spdlog::info("{} initial overlaps kept force-free ([run] keep_initial_overlaps), the deepest {:.3g} mm", settled.remaining.size(),
                 1e3 * settled.deepest_after);
}

/// How many grains of each kind the run models, and the rule that picked a model file's deformable ones.
nlohmann::json grain_kinds_json(const Scene& scene, const Model& model) {
  const std::array<std::size_t, 3> n = grain_kind_counts(model);
  const bool picked = scene.model && scene.model->deformable;
  return {{"rigid", n[0]}, {"tet4", n[1]}, {"tet10", n[2]}, {"deformable_rule", picked ? scene.model->deformable->rule : ""}};
}

void log_schedule(const Scene& scene, const Model& model, const RunSchedule& s) {
  const std::array<std::size_t, 3> kinds = grain_kind_counts(model);
  const bool split = scene.model && scene.model->kind == GrainKind::tet4;
  spdlog::info("grains: {} rigid, {} tet4, {} tet10{}{}{}", kinds[0], kinds[1], kinds[2],
               split ? fmt::format("; the model file's 10-node elements split into 4-node ones on their nodes ([model] kind){}",
                                   kinds[2] > 0 ? " but where a split would invert a curved element (those grains keep 10 nodes)" : "")
                     : std::string(),
               scene.model && scene.model->deformable
                   ? fmt::format("; the model file's deformable ones ({}) picked by {}", scene.model->deformable->grains.size(),
                                 scene.model->deformable->rule)
                   : std::string(),
               scene.implicit_grains && kinds[1] + kinds[2] > 0 ? "; the deformable ones implicit in their corotated frames" : "");
  spdlog::info("{} grains, {} nodes, {} elements, {} platens; time step {:.4g} s (elements {:.4g} s{}, contact {:.4g} s), {}",
               model.grains.size(), model.nodes.size(), model.element_count(), model.platens.size(), s.dt,
               s.limits.element_stable,
               s.limits.stiffness_damping > 0 ? fmt::format(" with stiffness_damping {:.4g} s", s.limits.stiffness_damping) : "",
               s.limits.contact_stable,
               scene.triaxial ? std::string("a triaxial test") : fmt::format("{} steps over {} stage(s)", s.total, scene.stages.size()));
}

/// The scene's [[stages]] up to the end or --stop-step, with a progress display.
void run_stages_shown(cli::RunContext& ctx, Solver& solver, const Scene& scene, const RunSchedule& schedule, std::uint64_t stop_step,
                      ResultsWriter* writer, StagesRunHooks hooks) {
  const std::uint64_t last = stop_step > 0 ? std::min(stop_step, schedule.total) : schedule.total;
  const std::size_t steps = last - std::min(last, solver.step_count());
  // The rank that writes shows the progress.
  auto progress = writer ? ctx.progress("steps", steps) : std::make_unique<cli::Progress>("steps", steps, false);
  hooks.step = [&, then = hooks.step] {
    if (then) then();
    progress->advance();
    throw_if_interrupted();
  };
  run_stages(solver, scene, schedule, last, writer, hooks);
  progress->done();
}

/// Runs the scene's triaxial test: progress and time left per phase of known length (shearing), a
/// status line every half minute of a consolidation, which runs until it settles (a percentage of its
/// most allowed steps would mislead), a warning when shearing was not quasi-static. The summary, or
/// nothing when the run stopped at --stop-step.
std::optional<TriaxialRunSummary> run_triaxial_shown(cli::RunContext& ctx, Solver& solver, const Scene& scene,
                                                     const RunSchedule& schedule, std::uint64_t stop_step, ResultsWriter* writer,
                                                     TriaxialRunHooks hooks,
                                                     const std::function<void(const TriaxialRunProgress&)>& checkpoint) {
  std::unique_ptr<cli::Progress> progress;
  std::string phase;
  Interval status(kStatusLineSeconds);
  hooks.phase = [&](const std::string& name, std::size_t steps) {
    if (progress) progress->done();
    // The rank that writes shows the progress.
    progress = !steps ? nullptr
               : writer ? ctx.progress(name + " steps", steps)
                        : std::make_unique<cli::Progress>(name + " steps", steps, false);
    phase = name;
    status = Interval(kStatusLineSeconds);
    spdlog::info("{} begins at step {}{}", name, solver.step_count(), steps ? fmt::format(" ({} steps)", steps) : "");
  };
  hooks.step = [&, then = hooks.step](const TriaxialMeasure& m, const StepReport& r, const TriaxialRunProgress& at) {
    if (then) then(m, r, at);
    if (progress)
      progress->advance();
    else if (status.due())
      spdlog::info("{}, {} in: {}; {} contact searches rebuilt", phase, format_duration(status.elapsed()),
                   consolidation_status(*scene.triaxial, m, r, at.procedure), solver.contact_model()->rebuild_count());
    throw_if_interrupted();
  };
  const std::optional<TriaxialRunSummary> run = run_triaxial_scene(solver, scene, schedule, stop_step, writer, hooks, checkpoint);
  if (progress) progress->done();
  if (!run) return run;
  const TriaxialRunSummary& s = *run;
  spdlog::info("consolidated in {} + {} steps; sheared {} steps at {:.4g} /s (inertial number {:.2g}) to eps_1 = {:.4g}: "
               "sigma_1 / sigma_3 {:.4g}, eps_v {:.4g}",
               s.consolidation_steps, s.membrane_steps, s.shear_steps, s.strain_rate, s.inertial_number,
               std::log(s.start.height / s.end.height), s.end.axial_stress / s.end.lateral_stress,
               std::log(s.start.volume / s.end.volume));
  if (scene.triaxial->membrane)
    spdlog::info("membrane: {} balls of radius {:.4g} mm, density scaled x {:.4g} for the time step", s.membrane_balls,
                 1e3 * s.ball_radius, s.density_scaling);
  if (s.max_kinetic_ratio > kQuasiStaticRatio)
    spdlog::warn("shearing was not quasi-static: the kinetic energy reached {:.3g} of the elastic energy (limit {:.2g}); "
                 "lower [triaxial] shear_inertial_number or strain_rate",
                 s.max_kinetic_ratio, kQuasiStaticRatio);
  return run;
}

void log_ranks(const mpi::DistributedRun& run, int ranks) {
  const mpi::RankTraffic& t = run.traffic();
  const double sent = static_cast<double>(t.doubles);
  spdlog::info("{} ranks: rank 0 owns {} grains at the end; it sent {} grain states ({} migrations, {} history entries), "
               "{:.3g} MB in all ({:.2g} % migrating grains, {:.2g} % the step's sums, the rest ghosts), and spent {:.3g} s "
               "in the exchanges ({:.3g} s waiting for messages; {} steps moved grains, their exchanges {:.3g} s beyond the "
               "other steps' mean); the sample was cut again {} times by measured work",
               ranks, run.owned().size(), t.bodies, t.migrations, t.history, 8e-6 * sent,
               sent > 0 ? 100.0 * static_cast<double>(t.migration_doubles) / sent : 0.0,
               sent > 0 ? 100.0 * static_cast<double>(t.sum_words) / sent : 0.0, t.exchange_seconds, t.wait_seconds,
               t.migration_steps,
               t.migration_seconds(), run.rebalances());
}

void log_end(const ResultsWriter& writer, const Solver& solver, int threads, double vtk_seconds, const Checkpoints& checkpoints) {
  spdlog::info("{} frames, final time {:.6g} s after {} steps{}", writer.frames(), solver.time(), solver.step_count(),
               solver.has_contact() ? fmt::format(", contact search rebuilt {} times", solver.contact_model()->rebuild_count())
                                    : std::string());
  spdlog::info("time: {}", describe_step_times(solver.step_times(), solver.model().grains.size(), threads));
  spdlog::info("output: {} frames in {:.3g} s{}, {} checkpoints in {:.3g} s", writer.frames(), writer.frame_seconds(),
               vtk_seconds > 0 ? fmt::format(" (and their VTK in {:.3g} s)", vtk_seconds) : std::string(), checkpoints.written,
               checkpoints.seconds);
  const auto& grains = solver.model().grains;
  const auto deformable = std::count_if(grains.begin(), grains.end(), [](const Grain& g) { return g.kind != GrainKind::rigid; });
  std::vector<double> differences;
  for (double d : writer.stress_differences())
    if (std::isfinite(d)) differences.push_back(d);
  if (deformable > 0 && !differences.empty())
    spdlog::info("stress of the deformable grains ({}), Love-Weber of their contact and boundary forces against their elements' "
                 "average: median relative difference {:.3g} in the last frame that has one ({:.3g} to {:.3g} over {} frames; "
                 "inertia, damping and gravity make it)",
                 deformable, differences.back(), *std::min_element(differences.begin(), differences.end()),
                 *std::max_element(differences.begin(), differences.end()), differences.size());
}

}  // namespace

int main(int argc, char** argv) {
  // Under mpirun the ranks share the run (docs/fdemrun.md, across machines); started alone, it is one
  // rank without MPI.
  mpi::Session session(argc, argv, mpi::Session::Start::when_launched);
  const bool writes = session.rank() == 0;  // rank 0 writes every output and tells the run
  cli::Tool tool("fdemrun", kDescription);
  tool.share_cores_with(session.ranks_on_this_machine());
  Options o;
  add_options(tool, o);

  const int code = tool.run(argc, argv, [&](cli::RunContext& ctx) {
    if (!writes) spdlog::set_level(spdlog::level::warn);
    check_files(o, ctx.force());
    std::optional<io::AtomicOutput> vtk_out;
    if (!o.vtk.empty() && writes) vtk_out.emplace(o.vtk, ctx.force());
    const Scene scene = read_scene(o.scene, o.model, [](const fs::path& micro, std::size_t state, std::size_t increment) {
      return micro::d2min_by_label(micro::read_micro_tables(micro), micro.string(), state, increment);
    });
    mpi::check_runs_across_ranks(session, scene, o.scene.string());
    if (!o.checkpoint.empty()) check_checkpoint_parts_allowed(o.checkpoint, session.size(), ctx.force());
    if (scene.model) io::declare_input(scene.model->path);
    const std::string scene_text = file_bytes(o.scene);
    const std::string model_bytes = scene.model ? file_bytes(scene.model->path) : std::string();  // a restart needs the same model file too
    Model model = build_model(scene, mesh::append_ellipsoid_grain);
    log_size_penalties(scene, model);
    const RunStart start = start_run(scene, model, o.scene.string());
    log_start(scene, start);
    Solver& solver = *start.solver;
    const RunSchedule schedule = schedule_run(scene, solver, o.scene.string());
    log_schedule(scene, model, schedule);

    const std::string digest = run_digest(scene_text, model_bytes, schedule.dt);
    std::optional<io::AtomicOutput> out;
    if (writes) out.emplace(o.output, ctx.force());
    if (!o.restart.empty() && !scene.triaxial)
      restart_from(o, solver, digest, nullptr, session.size());
    else if (o.restart.empty())
      set_initial_velocities(solver, scene);
    // Split after a restart: the ranks cut the sample where its grains are now (a triaxial test's
    // restart is loaded once its boundary is set).
    std::unique_ptr<mpi::DistributedRun> ranks;
    const auto split = [&] { ranks = mpi::split_over_ranks(session, solver); };
    if (!scene.triaxial) split();
    nlohmann::json p = run_parameters(scene, o.scene.string(), scene_text, start, schedule, ctx.threads(), o.restart.string());
    p["grain_kinds"] = grain_kinds_json(scene, model);
    p["ranks"] = {{"count", session.size()}};
    std::optional<ResultsWriter> writer;
    if (writes) writer.emplace(out->temp_path(), solver, p.dump());
    std::optional<VtkFrameWriter> frames;
    if (vtk_out) frames.emplace(vtk_out->temp_path());
    const Checkpoints checkpoints{o.checkpoint, solver, digest, ranks, writes};
    double vtk_seconds = 0;
    const auto add_vtk_frame = [&] {
      if (!frames) return;
      const double start = monotonic_seconds();
      frames->add(solver);
      vtk_seconds += monotonic_seconds() - start;
    };
    const auto gather = [&] {  // rank 0 writes what one rank holds
      if (ranks) ranks->gather_output();
    };
    const auto rebalance = [&] {  // across ranks: cut the sample again when the measured work is out of balance
      if (ranks && solver.step_count() % mpi::kBalanceCheckSteps == 0) ranks->rebalance();
    };
    if (scene.triaxial) {
      TriaxialRunHooks hooks;
      hooks.before_frame = gather;
      hooks.frame = add_vtk_frame;
      if (!o.restart.empty()) hooks.restore = [&](TriaxialRunProgress& at) { restart_from(o, solver, digest, &at, session.size()); };
      hooks.ready = split;
      hooks.step = [&](const TriaxialMeasure&, const StepReport&, const TriaxialRunProgress&) { rebalance(); };
      std::optional<TriaxialRunSummary> summary;
      try {
        summary = run_triaxial_shown(ctx, solver, scene, schedule, o.stop_step, writer ? &*writer : nullptr, hooks,
                                     [&](const TriaxialRunProgress& at) { checkpoints.save(&at); });
      } catch (Error& e) {
        checkpoints.add_context(e);
        throw;
      }
      if (summary) {
        p["triaxial"] = triaxial_summary_json(*summary);
      } else {
        spdlog::info("stopped at step {} (--stop-step){}", solver.step_count(),
                     o.checkpoint.empty() ? std::string() : "; continue with --restart " + o.checkpoint.string());
        p["stopped_at_step"] = solver.step_count();
      }
      p["steps"] = solver.step_count();
    } else {
      StagesRunHooks hooks;
      hooks.before_frame = gather;
      hooks.frame = add_vtk_frame;
      hooks.checkpoint = [&] { checkpoints.save(nullptr); };
      hooks.step_failed = [&](Error& e) { checkpoints.add_context(e); };
      hooks.step = rebalance;
      run_stages_shown(ctx, solver, scene, schedule, o.stop_step, writer ? &*writer : nullptr, hooks);
    }
    if (ranks) {  // what travelled between the ranks, summed over them (collective)
      const mpi::RankTraffic& t = ranks->traffic();
      p["ranks"] = {{"count", session.size()},
                    {"migrations", mpi::sum_over_ranks(session, t.migrations)},
                    {"history_entries", mpi::sum_over_ranks(session, t.history)},
                    {"grain_states_sent", mpi::sum_over_ranks(session, t.bodies)},
                    {"bytes_sent", 8 * mpi::sum_over_ranks(session, t.doubles)},
                    {"sum_bytes_sent", 8 * mpi::sum_over_ranks(session, t.sum_words)},
                    {"migration_bytes_sent", 8 * mpi::sum_over_ranks(session, t.migration_doubles)},
                    {"rebalances", ranks->rebalances()}};
    }
    if (writer) writer->set_parameters(p.dump());
    if (!writes) return;
    writer->finish(ctx.history());
    if (frames) frames->finish();
    io::commit_outputs({&*out, vtk_out ? &*vtk_out : nullptr});
    log_end(*writer, solver, ctx.threads(), vtk_seconds, checkpoints);
    if (ranks) log_ranks(*ranks, session.size());
  });
  // An error one rank met alone leaves the others waiting for it in a collective: end them all.
  if (code != 0 && session.size() > 1) session.abort(code);
  return code;
}
