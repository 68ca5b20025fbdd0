#include "graintwin/report/panels.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>

namespace graintwin::report {

namespace {

constexpr const char* kNoForces =
    "This run has no force statistics (forces.h5): the forces stage (fdem2forces on simulation.h5) makes them.";
constexpr const char* kCtNoStress =
    "CT scans measure where grains are, not stresses: the experiment's stress ratio is the load cell's record, which the run's "
    "files do not hold. The scans' axial strains are marked on the simulation's curve.";
constexpr const char* kCtNoGrainStress =
    "CT scans do not measure grain stresses, so the volatility of q exists for the simulation only.";
constexpr const char* kEmpty = "The file holds no finite values to draw here.";

enum class SideName { experiment, simulation };

Chart chart(const std::string& panel, SideName side, std::string title, std::string x_label, std::string y_label, bool x_log = false,
            bool y_log = false) {
  Chart c;
  c.panel = panel;
  c.file = panel + (side == SideName::experiment ? "_experiment.png" : "_simulation.png");
  c.title = std::move(title), c.x_label = std::move(x_label), c.y_label = std::move(y_label);
  c.x_log = x_log, c.y_log = y_log;
  return c;
}

Side missing(std::string why) { return Side{std::nullopt, std::move(why), {}}; }

/// A side showing `c`, or the sentence that its data were empty.
Side shown(Chart c, std::string note = {}) {
  if (c.series.empty()) return missing(kEmpty);
  return Side{std::move(c), {}, std::move(note)};
}

/// Why the simulation side lacks what a chart needs (empty when it has it).
std::string simulation_gap(const SimulationData& s, bool needs_micro, bool needs_forces) {
  if (!s.present && !s.micro && !s.forces) return kNoSimulation;
  if (needs_micro && !s.micro) return kNoSimulationMicro;
  if (needs_forces && !s.forces) return kNoForces;
  return {};
}

std::vector<double> scaled(const std::vector<double>& v, double k) {
  std::vector<double> out(v.size());
  for (std::size_t i = 0; i < v.size(); ++i) out[i] = k * v[i];
  return out;
}

std::string state_name(const std::vector<std::string>& names, std::size_t t) {
  return t < names.size() ? names[t] : fmt::format("state {}", t);
}

/// Names of a micro file's states: the scans' names, or the simulation's frames.
std::vector<std::string> micro_state_names(const MicroData& m, const ExperimentData* experiment) {
  std::vector<std::string> names;
  for (std::size_t t = 0; t < m.states.size(); ++t)
    names.push_back(experiment && t < experiment->scans.size() ? experiment->scans[t].name : fmt::format("frame {}", t));
  return names;
}

std::string increment_name(const MicroIncrement& inc, const std::vector<std::string>& names) {
  return state_name(names, inc.from) + " -> " + state_name(names, inc.to);
}

/// The scans' axial strains (%) to mark on simulation charts: applied where known, else tracked.
std::pair<std::vector<double>, std::string> scan_strain_marks(const ExperimentData& e) {
  if (!e.applied_axial_strain.empty()) return {scaled(e.applied_axial_strain, 100.0), "scans (applied axial strain)"};
  return {scaled(e.tracked_axial_strain, 100.0), "scans (axial strain from the tracks)"};
}

/// The scans' (eps_1, eps_v) points in %: from the tracked centroids' affine map, and from the void
/// ratios at the applied axial strain (else at the tracked one).
std::vector<Series> scan_strain_points(const ExperimentData& e) {
  std::vector<Series> points;
  if (!e.tracked_axial_strain.empty())
    points.push_back({"scans, affine map of the tracked centroids", "points", scaled(e.tracked_axial_strain, 100.0),
                      scaled(e.tracked_volumetric_strain, 100.0)});
  if (!e.void_ratio_volumetric_strain.empty()) {
    if (!e.applied_axial_strain.empty())
      points.push_back({"scans, void ratio at the applied axial strain", "points", scaled(e.applied_axial_strain, 100.0),
                        scaled(e.void_ratio_volumetric_strain, 100.0)});
    else if (!e.tracked_axial_strain.empty())
      points.push_back({"scans, void ratio at the tracked axial strain", "points", scaled(e.tracked_axial_strain, 100.0),
                        scaled(e.void_ratio_volumetric_strain, 100.0)});
  }
  return points;
}

// ---- the panels ---------------------------------------------------------------------------

Panel stress_ratio_panel(const ExperimentData& e, const SimulationData& s) {
  Panel p{"stress_ratio", "Stress ratio against axial strain",
          "sigma_1 / sigma_3 of the simulated triaxial test against its log axial strain eps_1 = ln(H0/H) "
          "(fdemrun's time series /series/stress_ratio and /series/axial_strain); vertical lines mark the scans' axial "
          "strains (--scan-strains, else measured from the tracks).",
          missing(kCtNoStress), {}};
  if (!s.present) {
    p.simulation = missing(kNoSimulation);
  } else if (!s.series.missing.empty()) {
    std::string names;
    for (const auto& m : s.series.missing) names += (names.empty() ? "" : ", ") + m;
    p.simulation = missing("The simulation results hold no " + names +
                           ": fdemrun writes these columns with its triaxial test (a scene with a [triaxial] table, docs/fdem_triaxial.md), which this run's simulation did not use.");
  } else {
    Chart c = chart(p.id, SideName::simulation, "Simulation", "axial strain eps_1 (%)", "sigma_1 / sigma_3");
    c.add({"simulation", "line", scaled(s.series.axial_strain, 100.0), s.series.stress_ratio});
    auto [marks, name] = scan_strain_marks(e);
    c.add({name, "vline", marks, {}});
    p.simulation = shown(std::move(c));
  }
  return p;
}

Panel volumetric_strain_panel(const ExperimentData& e, const SimulationData& s) {
  Panel p{"volumetric_strain", "Volumetric strain against axial strain",
          "Log volumetric strain eps_v = ln(V0/V) against eps_1 (compression positive). Experiment, one point per scan: the "
          "least-squares affine map Lambda of the tracked centroids from the first scan (tracks.h5; eps_1 = -ln Lambda_zz, "
          "eps_v = -ln det Lambda), and eps_v = ln((1 + e_0) / (1 + e)) from the void ratios the labels files measured "
          "(/sample/void_ratio) at the applied axial strain (--scan-strains). Simulation: /series/volumetric_strain against "
          "/series/axial_strain, the scans' points on top.",
          {}, {}};
  const std::vector<Series> points = scan_strain_points(e);
  Chart c = chart(p.id, SideName::experiment, "Experiment (CT scans)", "axial strain eps_1 (%)", "volumetric strain eps_v (%)");
  for (const Series& pt : points) c.add(pt);
  p.experiment = points.empty() ? missing("The scans' strains are unknown: this run has no tracks (track stage, two scans or more) and no "
                                          "--scan-strains file with the void ratios of the labels files.")
                                : shown(std::move(c));
  if (!s.present) {
    p.simulation = missing(kNoSimulation);
  } else if (!s.series.missing.empty()) {
    p.simulation = missing("The simulation results hold no triaxial strains (/series/axial_strain, /series/volumetric_strain): "
                           "fdemrun writes them with its triaxial test (a scene with a [triaxial] table, docs/fdem_triaxial.md).");
  } else {
    Chart sc = chart(p.id, SideName::simulation, "Simulation", "axial strain eps_1 (%)", "volumetric strain eps_v (%)");
    sc.add({"simulation", "line", scaled(s.series.axial_strain, 100.0), scaled(s.series.volumetric_strain, 100.0)});
    for (const Series& pt : points) sc.add(pt);
    p.simulation = shown(std::move(sc));
  }
  return p;
}

Panel psd_panel(const ExperimentData& e, const SimulationData& s, const PanelOptions& o) {
  Panel p{"psd", "Particle size distribution",
          "Percentage passing by volume against the volume-equivalent diameter. Experiment: each scan's grains (shapes.h5, /psd). "
          "Simulation: the simulated grains' volumes (simulation.h5, /grains/volume).",
          {}, {}};
  Chart c = chart(p.id, SideName::experiment, "Experiment (CT scans)", "equivalent diameter (mm)", "passing (% by volume)", true);
  bool any_shapes = false;
  for (std::size_t t : pick_evenly(e.scans.size(), o.max_series)) {
    const ScanData& sc = e.scans[t];
    if (sc.psd.diameter.empty()) continue;
    any_shapes = true;
    c.add({fmt::format("{} (d50 {:.3f} mm)", sc.name, sc.psd.d50 * 1e3), "line", scaled(sc.psd.diameter, 1e3), sc.psd.percent_passing});
  }
  p.experiment = any_shapes ? shown(std::move(c)) : missing(kNoShapes);
  if (!s.present) {
    p.simulation = missing(kNoSimulation);
  } else {
    Chart sc = chart(p.id, SideName::simulation, "Simulation", "equivalent diameter (mm)", "passing (% by volume)", true);
    sc.add({fmt::format("simulated grains (d50 {:.3f} mm)", s.psd.d50 * 1e3), "line", scaled(s.psd.diameter, 1e3), s.psd.percent_passing});
    p.simulation = shown(std::move(sc));
  }
  return p;
}

Series coordination_series(const std::vector<std::uint64_t>& count, double mean, const std::string& name) {
  double total = 0.0;
  for (auto c : count) total += double(c);
  Series s{fmt::format("{} (mean {:.2f})", name, mean), "linepoints", {}, {}};
  for (std::size_t z = 0; z < count.size(); ++z) s.x.push_back(double(z)), s.y.push_back(total > 0 ? double(count[z]) / total : 0.0);
  return s;
}

Panel coordination_panel(const ExperimentData& e, const SimulationData& s, const PanelOptions& o) {
  Panel p{"coordination", "Coordination number distribution",
          "Share of grains with Z contacts. Experiment: each scan's accepted contacts (contacts.h5, /coordination). Simulation: "
          "the frames' grain-grain contacts (simulation_micro.h5, /states/<t>/coordination).",
          {}, {}};
  Chart c = chart(p.id, SideName::experiment, "Experiment (CT scans)", "coordination number Z", "share of grains");
  bool any = false;
  for (std::size_t t : pick_evenly(e.scans.size(), o.max_series))
    if (!e.scans[t].coordination.empty()) any = true, c.add(coordination_series(e.scans[t].coordination, e.scans[t].coordination_mean, e.scans[t].name));
  p.experiment = any ? shown(std::move(c)) : missing(kNoContacts);
  if (const std::string gap = simulation_gap(s, true, false); !gap.empty()) {
    p.simulation = missing(gap);
  } else {
    Chart sc = chart(p.id, SideName::simulation, "Simulation", "coordination number Z", "share of grains");
    const auto names = micro_state_names(*s.micro, nullptr);
    for (std::size_t t : pick_evenly(s.micro->states.size(), o.max_series))
      sc.add(coordination_series(s.micro->states[t].coordination, s.micro->states[t].coordination_mean, names[t]));
    p.simulation = shown(std::move(sc));
  }
  return p;
}

Chart rose_chart(const std::string& panel, SideName side, const std::string& title, const std::string& value_label) {
  Chart c = chart(panel, side, title, "angle from the loading axis z (deg)", value_label);
  c.kind = "rose";
  return c;
}

std::vector<Panel> rose_panels(const ExperimentData& e, const SimulationData& s, const PanelOptions& o) {
  const std::string density = "directions per sr (isotropic 1/(4 pi) = 0.080)";
  std::vector<Panel> out;
  const auto scans = pick_evenly(e.scans.size(), o.max_series);
  const bool contacts = !e.scans.empty() && !e.scans[0].rose_normal.counts.empty();
  {
    Panel p{"rose_normals", "Rose of contact normals",
            "Density of contact normal directions per polar angle from the loading axis z (azimuths summed, axes folded onto the "
            "upper hemisphere and drawn mirrored in the x-z plane). Experiment: contacts.h5 /rose/normal. Simulation: the "
            "grain-grain contact normals of the frames (forces.h5, /frames/<f>/rose/count).",
            {}, {}};
    Chart c = rose_chart(p.id, SideName::experiment, "Experiment (CT scans)", density);
    for (std::size_t t : scans)
      if (!e.scans[t].rose_normal.counts.empty()) c.add(rose_profile(e.scans[t].rose_normal, RoseValue::density, e.scans[t].name));
    p.experiment = contacts ? shown(std::move(c)) : missing(kNoContacts);
    if (const std::string gap = simulation_gap(s, false, true); !gap.empty()) {
      p.simulation = missing(gap);
    } else {
      Chart sc = rose_chart(p.id, SideName::simulation, "Simulation", density);
      for (std::size_t k : pick_evenly(s.forces->frames.size(), o.max_series))
        sc.add(rose_profile(s.forces->frames[k].rose, RoseValue::density, fmt::format("frame {}", s.forces->frames[k].index)));
      p.simulation = shown(std::move(sc));
    }
    out.push_back(std::move(p));
  }
  {
    Panel p{"rose_branches", "Rose of branch vectors",
            "Density of branch vector directions (centroid to centroid of contacting grains) per polar angle from z, as the "
            "normals' rose. Experiment: contacts.h5 /rose/branch. Simulation: computed here from the grain-grain contacts and "
            "centroids of the frames in simulation.h5.",
            {}, {}};
    Chart c = rose_chart(p.id, SideName::experiment, "Experiment (CT scans)", density);
    for (std::size_t t : scans)
      if (!e.scans[t].rose_branch.counts.empty()) c.add(rose_profile(e.scans[t].rose_branch, RoseValue::density, e.scans[t].name));
    p.experiment = contacts ? shown(std::move(c)) : missing(kNoContacts);
    if (!s.present) {
      p.simulation = missing(kNoSimulation);
    } else {
      Chart sc = rose_chart(p.id, SideName::simulation, "Simulation", density);
      for (std::size_t k = 0; k < s.branch_roses.size(); ++k)
        sc.add(rose_profile(s.branch_roses[k], RoseValue::density, fmt::format("frame {}", s.rose_frames[k])));
      p.simulation = shown(std::move(sc));
    }
    out.push_back(std::move(p));
  }
  {
    Panel p{"rose_forces", "Rose of mean normal force",
            "Mean normal force of the grain-grain contacts per polar angle of their normal from z (forces.h5, "
            "/frames/<f>/rose/mean_force weighted by the bins' contact counts).",
            missing(kCtNoForces), {}};
    if (const std::string gap = simulation_gap(s, false, true); !gap.empty()) {
      p.simulation = missing(gap);
    } else {
      Chart sc = rose_chart(p.id, SideName::simulation, "Simulation", "mean normal force (N)");
      for (std::size_t k : pick_evenly(s.forces->frames.size(), o.max_series))
        sc.add(rose_profile(s.forces->frames[k].rose, RoseValue::mean_force, fmt::format("frame {}", s.forces->frames[k].index)));
      p.simulation = shown(std::move(sc));
    }
    out.push_back(std::move(p));
  }
  return out;
}

/// A panel drawn from a kind=micro file on each side: `draw` fills the chart for one file.
Panel micro_panel(std::string id, std::string title, std::string description, const ExperimentData& e, const SimulationData& s,
                  const std::function<Side(const MicroData&, const std::vector<std::string>&, SideName, const std::string&)>& draw) {
  Panel p{std::move(id), std::move(title), std::move(description), {}, {}};
  p.experiment = e.micro ? draw(*e.micro, micro_state_names(*e.micro, &e), SideName::experiment, p.id) : missing(kNoMicro);
  if (const std::string gap = simulation_gap(s, true, false); !gap.empty())
    p.simulation = missing(gap);
  else
    p.simulation = draw(*s.micro, micro_state_names(*s.micro, nullptr), SideName::simulation, p.id);
  return p;
}

std::string side_title(SideName side) { return side == SideName::experiment ? "Experiment (CT scans)" : "Simulation"; }

std::vector<Panel> micro_panels(const ExperimentData& e, const SimulationData& s, const PanelOptions& o) {
  std::vector<Panel> out;
  out.push_back(micro_panel(
      "rdf", "Pair correlation g(r)",
      "g(r) = n(r) / (rho 4 pi r^2 dr) of the grain centroids with Ripley's edge correction, r over the state's d50 "
      "(micro.h5 and simulation_micro.h5, /states/<t>/rdf).",
      e, s, [&](const MicroData& m, const std::vector<std::string>& names, SideName side, const std::string& id) {
        Chart c = chart(id, side, side_title(side), "r / d50", "g(r)");
        for (std::size_t t : pick_evenly(m.states.size(), o.max_series))
          c.add({state_name(names, t), "line", scaled(m.states[t].rdf_r, 1.0 / m.state_d50[t]), m.states[t].rdf_g});
        return shown(std::move(c));
      }));
  out.push_back(micro_panel(
      "displacement", "Incremental displacement distributions",
      "PDFs of each increment's grain displacement over d50: its magnitude (solid) and its axial component z (dashed) "
      "(micro.h5 and simulation_micro.h5, /increments/<k>/displacement).",
      e, s, [&](const MicroData& m, const std::vector<std::string>& names, SideName side, const std::string& id) {
        Chart c = chart(id, side, side_title(side), "displacement / d50", "probability density");
        for (std::size_t k : pick_evenly(m.increments.size(), o.max_series)) {
          const MicroIncrement& inc = m.increments[k];
          Series magnitude = pdf_series(inc.displacement[3], false, "|u| " + increment_name(inc, names));
          Series z = pdf_series(inc.displacement[2], false, "u_z " + increment_name(inc, names));
          magnitude.group = z.group = increment_name(inc, names);
          z.style = "dashed";
          c.add(std::move(magnitude));
          c.add(std::move(z));
        }
        return shown(std::move(c));
      }));
  const auto log_pdf = [&](std::string id, std::string title, std::string what, std::string x_label, bool d2min) {
    return micro_panel(
        std::move(id), std::move(title), std::move(what), e, s,
        [&, x_label, d2min](const MicroData& m, const std::vector<std::string>& names, SideName side, const std::string& pid) {
          Chart c = chart(pid, side, side_title(side), x_label, "probability density", true, true);
          for (std::size_t k : pick_evenly(m.increments.size(), o.max_series)) {
            const MicroIncrement& inc = m.increments[k];
            c.add(pdf_series(d2min ? inc.pdf_d2min : inc.pdf_eps_q, true, increment_name(inc, names)));
          }
          return shown(std::move(c));
        });
  };
  out.push_back(log_pdf("d2min_pdf", "PDF of D2min",
                        "Log-binned PDF of the Falk-Langer non-affine displacement D2min / d50^2 of each grain over its neighbours "
                        "within 1.5 d50, per increment (micro.h5 and simulation_micro.h5, /increments/<k>/pdf_d2min).",
                        "D2min / d50^2", true));
  out.push_back(log_pdf("eps_q_pdf", "PDF of the local deviatoric strain eps_q",
                        "Log-binned PDF of eps_q = sqrt(2/3 e_dev : e_dev) of each grain's local affine strain, per increment "
                        "(micro.h5 and simulation_micro.h5, /increments/<k>/pdf_eps_q).",
                        "eps_q", false));
  out.push_back(micro_panel(
      "cluster_sizes", "Cluster size distribution P(s)",
      "Clusters of the 10 % of grains with the highest D2min (linked when touching): P(S >= s) of the cluster size s "
      "(points) and the maximum-likelihood discrete power law P(s) ~ s^-alpha above s_min (line; Clauset-Shalizi-Newman), "
      "micro.h5 and simulation_micro.h5, /increments/<k>/clusters.",
      e, s, [&](const MicroData& m, const std::vector<std::string>& names, SideName side, const std::string& id) {
        Chart c = chart(id, side, side_title(side), "cluster size s (grains)", "P(S >= s)", true, true);
        std::string note;
        for (std::size_t k : pick_evenly(m.increments.size(), o.max_series)) {
          const MicroIncrement& inc = m.increments[k];
          const std::string name = increment_name(inc, names);
          Series sizes = ccdf_series(inc.cluster_size, name);
          sizes.group = name;
          c.add(std::move(sizes));
          double s_max = 0.0;
          for (double v : inc.cluster_size) s_max = std::max(s_max, v);
          if (inc.size_fit_valid) {
            Series fit = power_law_ccdf(inc.size_alpha, inc.size_s_min, s_max, inc.size_tail, inc.cluster_size.size(),
                                        fmt::format("fit {}: alpha {:.2f}", name, inc.size_alpha));
            fit.group = name;
            c.add(std::move(fit));
            note += fmt::format("{}: {} clusters of {} grains, alpha = {:.2f} +- {:.2f} above s_min = {:g} ({} clusters in the tail). ", name,
                                inc.cluster_size.size(), inc.selected, inc.size_alpha, inc.size_alpha_error, inc.size_s_min, inc.size_tail);
          } else {
            note += fmt::format("{}: {} clusters of {} grains, too few for a power-law fit. ", name, inc.cluster_size.size(), inc.selected);
          }
        }
        return shown(std::move(c), note);
      }));
  out.push_back(micro_panel(
      "cluster_rg", "Cluster radius of gyration against size",
      "Volume-weighted radius of gyration R_g (over d50) of the clusters of two grains or more against their size s, and the "
      "least-squares line log R_g = a + (1/d_f) log s whose slope gives the fractal dimension d_f (micro.h5 and "
      "simulation_micro.h5, /increments/<k>/clusters).",
      e, s, [&](const MicroData& m, const std::vector<std::string>& names, SideName side, const std::string& id) {
        Chart c = chart(id, side, side_title(side), "cluster size s (grains)", "R_g / d50", true, true);
        std::string note;
        for (std::size_t k : pick_evenly(m.increments.size(), o.max_series)) {
          const MicroIncrement& inc = m.increments[k];
          const std::string name = increment_name(inc, names);
          std::vector<double> size, rg;
          for (std::size_t q = 0; q < inc.cluster_size.size() && q < inc.cluster_rg.size(); ++q)
            if (inc.cluster_size[q] >= 2 && inc.cluster_rg[q] > 0) size.push_back(inc.cluster_size[q]), rg.push_back(inc.cluster_rg[q] / inc.d50);
          c.add({name, "points", size, rg, name});
          if (std::isfinite(inc.fractal_dimension) && inc.fractal_dimension > 0) {
            Series fit = log_line_through_mean(size, rg, 1.0 / inc.fractal_dimension, fmt::format("fit {}: d_f {:.2f}", name, inc.fractal_dimension));
            fit.group = name;
            c.add(std::move(fit));
            note += fmt::format("{}: d_f = {:.2f} +- {:.2f} over {} clusters. ", name, inc.fractal_dimension, inc.fractal_dimension_error, size.size());
          } else {
            note += fmt::format("{}: d_f not fitted ({} clusters of two grains or more). ", name, size.size());
          }
        }
        if (c.series.empty()) return missing("No cluster of two grains or more in the increments shown, so there is no R_g against s: " + note);
        return shown(std::move(c), note);
      }));
  return out;
}

Panel force_pdf_panel(const SimulationData& s, const PanelOptions& o) {
  Panel p{"force_pdf", "PDF of the normal contact force",
          "Log-binned PDF of f = f_n / <f_n> over the grain-grain contacts (points), with the maximum-likelihood fits of the last "
          "frame shown: strong forces (f >= 1) P ~ exp(-(f - 1) / scale), weak forces (f < 1) P ~ (theta + 1) f^theta, each "
          "scaled by its share of the contacts (forces.h5, /frames).",
          missing(kCtNoForces), {}};
  if (const std::string gap = simulation_gap(s, false, true); !gap.empty()) {
    p.simulation = missing(gap);
    return p;
  }
  Chart c = chart(p.id, SideName::simulation, "Simulation", "f_n / <f_n>", "probability density", true, true);
  const auto frames = pick_evenly(s.forces->frames.size(), o.max_series);
  for (std::size_t k : frames) {
    Series pts = pdf_series(s.forces->frames[k].pdf, true, fmt::format("frame {}", s.forces->frames[k].index));
    pts.style = "points";
    pts.group = pts.name;
    c.add(std::move(pts));
  }
  std::string note;
  if (!frames.empty()) {
    const ForcesFrame& last = s.forces->frames[frames.back()];
    const double share = share_at_or_above(last.pdf, 1.0);
    const double lo = last.pdf.edges.empty() ? 0.0 : last.pdf.edges.front(), hi = last.pdf.edges.empty() ? 0.0 : last.pdf.edges.back();
    Series strong = strong_force_fit(last.strong_scale, share, hi, fmt::format("strong fit, scale {:.2f}", last.strong_scale));
    Series weak = weak_force_fit(last.weak_theta, share, lo, fmt::format("weak fit, theta {:.2f}", last.weak_theta));
    strong.group = weak.group = fmt::format("frame {}", last.index);
    weak.style = "line";
    c.add(std::move(strong));
    c.add(std::move(weak));
    note = fmt::format("Frame {} ({} contacts): strong scale {:.3g}, weak theta {:.3g}, {:.0f} % of the contacts carry f >= 1.", last.index,
                       last.contacts, last.strong_scale, last.weak_theta, 100.0 * share);
  }
  p.simulation = shown(std::move(c), note);
  return p;
}

Panel volatility_panel(const SimulationData& s) {
  Panel p{"volatility", "Volatility of grain stress against D2min",
          "Each grain's volatility of q = sqrt(1/2 s_ij s_ij) over the last strain window (sample standard deviation of "
          "ln(q_i / q_{i-1})) against its D2min / d50^2 over the same window, with Pearson's r and its two-sided p-value "
          "(forces.h5, /grains/volatility, /grains/d2min, /windows).",
          missing(kCtNoGrainStress), {}};
  if (const std::string gap = simulation_gap(s, false, true); !gap.empty()) {
    p.simulation = missing(gap);
    return p;
  }
  if (s.forces->windows.empty()) {
    p.simulation = missing("forces.h5 holds no strain window; rerun fdem2forces with two frames or more.");
    return p;
  }
  const ForcesWindow& w = s.forces->windows.back();
  Chart c = chart(p.id, SideName::simulation, "Simulation", "D2min / d50^2", "volatility of q", true, false);
  c.add({fmt::format("frames {} -> {}: r = {:.3f}, p = {:.2g}", w.from, w.to, w.pearson_r, w.p_value), "points", w.d2min, w.volatility});
  p.simulation = shown(std::move(c), fmt::format("Frames {} -> {}: Pearson r = {:.3f} (p = {:.3g}) over {} grains.", w.from, w.to,
                                                 w.pearson_r, w.p_value, w.count));
  return p;
}

}  // namespace

std::vector<Panel> build_panels(const ExperimentData& e, const SimulationData& s, const PanelOptions& o) {
  std::vector<Panel> panels;
  panels.push_back(stress_ratio_panel(e, s));
  panels.push_back(volumetric_strain_panel(e, s));
  panels.push_back(psd_panel(e, s, o));
  panels.push_back(coordination_panel(e, s, o));
  for (Panel& p : rose_panels(e, s, o)) panels.push_back(std::move(p));
  for (Panel& p : micro_panels(e, s, o)) panels.push_back(std::move(p));
  panels.push_back(force_pdf_panel(s, o));
  panels.push_back(volatility_panel(s));
  return panels;
}

std::vector<const Chart*> panel_charts(const std::vector<Panel>& panels) {
  std::vector<const Chart*> charts;
  for (const Panel& p : panels)
    for (const Side* side : {&p.experiment, &p.simulation})
      if (side->chart) charts.push_back(&*side->chart);
  return charts;
}

}  // namespace graintwin::report
