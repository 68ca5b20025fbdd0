#include "graintwin/fdem/triaxial_run.hpp"

#include <algorithm>
#include <cmath>

#include "graintwin/core/error.hpp"

namespace graintwin::fdem {

TriaxialRunSummary run_triaxial(Solver& solver, const TriaxialSpec& spec, double dt, std::uint64_t row_every,
                                ResultsWriter& writer, const TriaxialRunHooks& hooks) {
  if (!solver.has_contact()) throw UsageError("a triaxial test acts through contact; remove [run] contact = false");
  const PlatenPair platens = find_platens(solver.model());
  const TriaxialOptions& options = spec.options;
  TriaxialRunSummary summary;
  summary.d50 = grains_d50(solver);
  const double density = solver.model().materials.front().density;
  summary.strain_rate = spec.strain_rate > 0 ? spec.strain_rate
                                             : strain_rate_of(spec.shear_inertial_number, summary.d50, density,
                                                              options.confining_pressure);
  summary.inertial_number = inertial_number(summary.strain_rate, summary.d50, density, options.confining_pressure);

  TriaxialBoundary boundary(solver.model(), options, summary.d50);
  solver.set_boundary(&boundary);
  struct Detach {  // the boundary lives on this stack frame only
    Solver& s;
    ~Detach() { s.set_boundary(nullptr); }
  } detach{solver};

  std::uint32_t stage = 0;
  double shearing_rate = std::numeric_limits<double>::quiet_NaN();
  const auto book = [&](const TriaxialMeasure& m, const StepReport& r) {
    if ((solver.step_count() - 1) % row_every == 0) {
      TriaxialRow row{m, std::numeric_limits<double>::quiet_NaN()};
      if (std::isfinite(shearing_rate))
        row.inertial_number = inertial_number(shearing_rate, summary.d50, density,
                                              (m.axial_stress + 2 * m.lateral_stress) / 3);
      writer.add_row(solver, r, stage, dt, row);
    }
    if (hooks.step) hooks.step(m, r);
  };
  const auto take_frame = [&](double axial_strain) {
    writer.add_frame(solver, &boundary, axial_strain);
    if (hooks.frame) hooks.frame();
  };
  const auto begin = [&](const char* name, std::size_t steps) {
    writer.add_stage(name, solver.time());
    if (hooks.phase) hooks.phase(name, steps);
  };

  begin("consolidation", 0);
  summary.consolidation_steps = consolidate_in_wall(solver, boundary, options, dt, spec.consolidation_steps, book);
  if (spec.membrane) {
    ++stage;
    begin("membrane", 0);
    summary.membrane_steps = consolidate_in_membrane(solver, boundary, options, dt, spec.pressure_ramp_steps,
                                                     spec.consolidation_steps, book);
    summary.membrane_balls = boundary.membrane()->balls();
    summary.ball_radius = boundary.ball_radius();
    summary.density_scaling = boundary.density_scaling();
  }

  ++stage;
  summary.start = measure(solver, boundary, platens);
  writer.set_strain_reference(summary.start.height, summary.start.volume);
  // H = H0 (1 - rate t) at constant platen speed, and eps_1 = ln(H0 / H).
  // Plus half the ramp's steps, which cover half the distance of full speed.
  const auto expected = static_cast<std::size_t>(std::ceil(
      ((1 - std::exp(-spec.target_axial_strain)) + 0.5 * spec.shear_ramp_strain) / (summary.strain_rate * dt)));
  begin("shearing", expected);
  take_frame(0.0);
  shearing_rate = summary.strain_rate;
  std::size_t next_frame = 0;
  summary.shear_steps = shear(solver, boundary, options, ShearOptions{summary.strain_rate, spec.target_axial_strain, spec.shear_ramp_strain}, dt,
                              [&](const TriaxialMeasure& m, const StepReport& r) {
                                book(m, r);
                                const Energies& e = r.energies;
                                summary.max_kinetic_ratio = std::max(summary.max_kinetic_ratio, e.kinetic / (e.strain + e.contact_elastic));
                                const double strain = std::log(summary.start.height / m.height);
                                for (; next_frame < spec.frame_strains.size() && strain >= spec.frame_strains[next_frame]; ++next_frame)
                                  take_frame(strain);
                              });
  summary.end = measure(solver, boundary, platens);
  take_frame(std::log(summary.start.height / summary.end.height));
  return summary;
}

}  // namespace graintwin::fdem
