#include "graintwin/fdem/triaxial_run.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "graintwin/core/error.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/schema.hpp"

namespace graintwin::fdem {
namespace ck = schema::fdem_checkpoint;
namespace {


std::vector<double> measure_values(const TriaxialMeasure& m) {
  return {m.axial_stress, m.lateral_stress, m.height, m.volume, m.volume_radial};
}

/// The shearing strain rate of `spec` on the solver's grains, 1/s: its strain_rate, else the rate of
/// its inertial number at sigma_3.
double shearing_rate(const Solver& solver, const TriaxialSpec& spec, double d50) {
  return spec.strain_rate > 0 ? spec.strain_rate
                              : strain_rate_of(spec.shear_inertial_number, d50, solver.model().materials.front().density,
                                               spec.options.confining_pressure);
}

/// Steps of shearing to the target strain: H = H0 (1 - rate t) at constant platen speed and eps_1 =
/// ln(H0 / H), plus half the ramp's steps, which cover half the distance of full speed.
double shear_steps(const TriaxialSpec& spec, double rate, double dt) {
  return std::ceil(((1 - std::exp(-spec.target_axial_strain)) + 0.5 * spec.shear_ramp_strain) / (rate * dt));
}

}  // namespace

StepEstimate estimate_steps(const Scene& scene, const Solver& solver, double dt) {
  if (!scene.triaxial) {
    const double duration = scene.total_duration();
    return {duration / dt, fmt::format("{:.3g} s of stages at {:.3g} s a step", duration, dt)};
  }
  const TriaxialSpec& spec = *scene.triaxial;
  const double rate = shearing_rate(solver, spec, grains_d50(solver));
  const double shearing = shear_steps(spec, rate, dt);
  const double phases = spec.membrane ? 2 : 1;
  return {phases * static_cast<double>(spec.consolidation_steps) + shearing,
          fmt::format("at most {:g} x {} consolidation steps, then shearing to eps_1 = {:g} at {:.3g} /s in {:.3g} steps "
                      "of {:.3g} s",
                      phases, spec.consolidation_steps, spec.target_axial_strain, rate, shearing, dt)};
}

void check_step_ceiling(const StepEstimate& estimate, double max_steps, const Scene& scene, const StepLimits& limits,
                        double dt, const std::string& where) {
  if (estimate.steps <= max_steps) return;
  const bool contact_sets = limits.contact_stable <= limits.element_stable;
  const std::string cause =
      scene.time_step > 0
          ? fmt::format("the scene's [run] time_step: give a longer one (the stable limit is {:.3g} s)", limits.stable())
      : contact_sets ? fmt::format("the contact limit (the elements allow {:.3g} s): soften the penalty (normal_penalty, "
                                   "tangential_penalty or penalty_per_size)",
                                   limits.element_stable)
                     : fmt::format("the element limit (the contact allows {:.3g} s): coarsen the mesh (element_size)",
                                   limits.contact_stable);
  throw UsageError(fmt::format("{}: the run would take {:.3g} steps ({}), above the ceiling of {:g} steps; the time step "
                               "{:.3g} s is {}, shorten the run, or raise [run] max_steps",
                               where, estimate.steps, estimate.how, max_steps, dt, cause));
}

std::string consolidation_status(const TriaxialSpec& spec, const TriaxialMeasure& m, const StepReport& r,
                                 const TriaxialProgress& at) {
  using Phase = TriaxialProgress::Phase;
  const double kpa = 1e-3, sigma = spec.options.confining_pressure;
  const std::string energy = fmt::format("kinetic / elastic energy {:.3g}", r.energies.kinetic_ratio());
  if (at.phase == Phase::shearing)
    return fmt::format("step {}: axial {:.4g} kPa, lateral {:.4g} kPa; {}", at.step, kpa * m.axial_stress,
                       kpa * m.lateral_stress, energy);
  const std::string target = fmt::format("within {:g} % of {:.4g} kPa", 100 * spec.options.stress_tolerance, kpa * sigma);
  const std::string stresses =
      at.phase == Phase::wall
          ? fmt::format("in the wall: axial {:.4g} kPa, lateral {:.4g} kPa (settle {})", kpa * m.axial_stress,
                        kpa * m.lateral_stress, target)
      : at.phase == Phase::membrane_fixed
          ? std::string("membrane held while the grains settle against it")
          : fmt::format("membrane released: axial {:.4g} kPa (settles {}), pressure {:.4g} kPa (ramped to {:.4g} kPa)",
                        kpa * m.axial_stress, target, kpa * m.lateral_stress, kpa * sigma);
  return fmt::format("step {} of at most {}, {}; {} (settles below {:g}); settled for {} of {} steps", at.step,
                     spec.consolidation_steps, stresses, energy, kQuasiStaticRatio, at.settled, kSettledSteps);
}

void save_progress(io::H5File& file, const TriaxialRunProgress& p) {
  file.ensure_group(ck::triaxial);
  const TriaxialProgress& q = p.procedure;
  // Counters as doubles: exact below 2^53 steps.
  file.set_attr(ck::triaxial, ck::procedure,
                std::vector<double>{static_cast<double>(q.phase), static_cast<double>(q.step), static_cast<double>(q.settled),
                                    static_cast<double>(q.released), q.h0});
  file.set_attr(ck::triaxial, ck::run,
                std::vector<double>{static_cast<double>(p.consolidation_steps), static_cast<double>(p.membrane_steps),
                                    static_cast<double>(p.next_frame), p.max_kinetic_ratio});
  file.set_attr(ck::triaxial, ck::start, measure_values(p.start));
}

TriaxialRunProgress load_progress(const io::H5File& file) {
  const auto values = [&](const char* name, std::size_t count) {
    std::vector<double> v = file.exists(ck::triaxial) ? file.attr_doubles(ck::triaxial, name) : std::vector<double>{};
    if (v.size() != count)
      throw DataError(file.path().string() + " holds no triaxial test's progress (" + ck::triaxial + " " + name +
                      "); restart a triaxial scene from a checkpoint that fdemrun wrote for it");
    return v;
  };
  const auto q = values(ck::procedure, 5), r = values(ck::run, 4), s = values(ck::start, 5);
  const auto count = [](double v) { return v >= 0 && v < 9007199254740992.0 && v == std::floor(v); };  // below 2^53
  if (!(q[0] >= 0 && q[0] <= static_cast<double>(TriaxialProgress::Phase::shearing)) || !count(q[0]) || !count(q[1]) ||
      !count(q[2]) || !count(q[3]) || !count(r[0]) || !count(r[1]) || !count(r[2]))
    throw DataError(file.path().string() + ": " + ck::triaxial +
                    " holds a phase or step count that is not a whole number in range; the checkpoint is damaged, "
                    "restart from an earlier one");
  TriaxialRunProgress p;
  p.procedure = {static_cast<TriaxialProgress::Phase>(q[0]), static_cast<std::uint64_t>(q[1]),
                 static_cast<std::uint64_t>(q[2]), static_cast<std::uint64_t>(q[3]), q[4]};
  p.consolidation_steps = static_cast<std::uint64_t>(r[0]);
  p.membrane_steps = static_cast<std::uint64_t>(r[1]);
  p.next_frame = static_cast<std::uint64_t>(r[2]);
  p.max_kinetic_ratio = r[3];
  p.start = {s[0], s[1], s[2], s[3], s[4]};
  return p;
}

TriaxialRunSummary run_triaxial(Solver& solver, const TriaxialSpec& spec, double dt, std::uint64_t row_every,
                                ResultsWriter* writer, const TriaxialRunHooks& hooks) {
  if (!solver.has_contact()) throw UsageError("a triaxial test acts through contact; remove [run] contact = false");
  using Phase = TriaxialProgress::Phase;
  const PlatenPair platens = find_platens(solver.model());
  const TriaxialOptions& options = spec.options;
  TriaxialRunSummary summary;
  summary.d50 = grains_d50(solver);
  const double density = solver.model().materials.front().density;
  summary.strain_rate = shearing_rate(solver, spec, summary.d50);
  summary.inertial_number = inertial_number(summary.strain_rate, summary.d50, density, options.confining_pressure);

  TriaxialBoundary boundary(solver.model(), options, summary.d50);
  solver.set_boundary(&boundary);
  struct Detach {  // the boundary lives on this stack frame only
    Solver& s;
    ~Detach() { s.set_boundary(nullptr); }
  } detach{solver};
  TriaxialRunProgress run;
  if (hooks.restore) hooks.restore(run);
  if (hooks.ready) hooks.ready();
  TriaxialProgress& procedure = run.procedure;

  // Series stages: consolidation, membrane (when it replaces the wall), shearing.
  const auto stage = [&]() -> std::uint32_t {
    if (procedure.phase == Phase::shearing) return spec.membrane ? 2 : 1;
    return procedure.phase == Phase::wall ? 0 : 1;
  };
  double shearing_rate = std::numeric_limits<double>::quiet_NaN();
  const auto book = [&](const TriaxialMeasure& m, const StepReport& r) {
    if (writer && (solver.step_count() - 1) % row_every == 0) {
      TriaxialRow row{m, std::numeric_limits<double>::quiet_NaN()};
      if (std::isfinite(shearing_rate))
        row.inertial_number = inertial_number(shearing_rate, summary.d50, density,
                                              (m.axial_stress + 2 * m.lateral_stress) / 3);
      writer->add_row(solver, r, stage(), dt, row);
    }
  };
  const auto after_step = [&](const TriaxialMeasure& m, const StepReport& r) {
    if (hooks.step) hooks.step(m, r, run);
  };
  const auto consolidation_step = [&](const TriaxialMeasure& m, const StepReport& r) { book(m, r), after_step(m, r); };
  const auto take_frame = [&](double axial_strain) {
    if (hooks.before_frame) hooks.before_frame();
    if (!writer) return;
    writer->add_frame(solver, &boundary, axial_strain);
    if (hooks.frame) hooks.frame();
  };
  const auto begin = [&](const char* name, std::size_t steps) {
    if (writer) writer->add_stage(name, solver.time());
    if (hooks.phase) hooks.phase(name, steps);
  };

  if (procedure.phase == Phase::wall) {
    begin("consolidation", 0);
    run.consolidation_steps =
        consolidate_in_wall(solver, boundary, options, dt, spec.consolidation_steps, consolidation_step, &procedure);
  }
  summary.consolidation_steps = run.consolidation_steps;
  if (spec.membrane) {
    if (procedure.phase != Phase::shearing) {
      begin("membrane", 0);
      run.membrane_steps = consolidate_in_membrane(solver, boundary, options, dt, spec.pressure_ramp_steps,
                                                   spec.consolidation_steps, consolidation_step, &procedure);
    }
    summary.membrane_steps = run.membrane_steps;
    summary.membrane_balls = boundary.membrane()->balls();
    summary.ball_radius = boundary.ball_radius();
    summary.density_scaling = boundary.density_scaling();
  }

  const bool fresh_shearing = procedure.phase != Phase::shearing;
  if (fresh_shearing) run.start = measure(solver, boundary, platens);
  summary.start = run.start;
  if (writer) writer->set_strain_reference(run.start.height, run.start.volume);
  const auto expected = static_cast<std::size_t>(shear_steps(spec, summary.strain_rate, dt));
  begin("shearing", expected - std::min<std::size_t>(expected, fresh_shearing ? 0 : procedure.step));
  shearing_rate = summary.strain_rate;
  if (fresh_shearing) {
    procedure = {Phase::shearing, 0, 0, 0, run.start.height};
    take_frame(0.0);
  }
  summary.shear_steps = shear(solver, boundary, options, ShearOptions{summary.strain_rate, spec.target_axial_strain, spec.shear_ramp_strain}, dt,
                              [&](const TriaxialMeasure& m, const StepReport& r) {
                                book(m, r);
                                run.max_kinetic_ratio = std::max(run.max_kinetic_ratio, r.energies.kinetic_ratio());
                                const double strain = std::log(run.start.height / m.height);
                                for (; run.next_frame < spec.frame_strains.size() && strain >= spec.frame_strains[run.next_frame]; ++run.next_frame)
                                  take_frame(strain);
                                after_step(m, r);
                              },
                              &procedure);
  summary.max_kinetic_ratio = run.max_kinetic_ratio;
  summary.end = measure(solver, boundary, platens);
  take_frame(std::log(summary.start.height / summary.end.height));
  return summary;
}

}  // namespace graintwin::fdem
