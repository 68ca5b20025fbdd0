#include "graintwin/report/error_budget.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "graintwin/report/panels.hpp"

namespace graintwin::report {

namespace {

using validate::Validation;

constexpr const char* kNoTracks = "This run has no tracks (tracks.h5): the track stage (shapes2tracks) makes them from two scans or more.";
constexpr const char* kPrescribed =
    "The series' loading was prescribed (ctsynth's kinematics), so its truth has no stress-strain curve to score the twin "
    "against; a series made with ctsynth --loading simulated has one.";
constexpr const char* kEmpty = "There are no finite values to draw here.";

Chart chart(const std::string& id, std::string title, std::string x_label, std::string y_label, bool x_log = false, bool y_log = false) {
  Chart c;
  c.panel = "budget_" + id;
  c.file = c.panel + ".png";
  c.title = std::move(title), c.x_label = std::move(x_label), c.y_label = std::move(y_label);
  c.x_log = x_log, c.y_log = y_log;
  return c;
}

std::string number(double v, const char* format) { return std::isfinite(v) ? fmt::format(fmt::runtime(format), v) : "n/a"; }

BudgetLine line(std::string id, std::string title, std::string value, std::string description, Chart c) {
  BudgetLine l{std::move(id), std::move(title), std::move(value), std::move(description), std::nullopt, {}};
  if (c.series.empty()) l.missing = kEmpty;
  else l.chart = std::move(c);
  return l;
}

BudgetLine missing(std::string id, std::string title, std::string description, std::string why) {
  return BudgetLine{std::move(id), std::move(title), "n/a", std::move(description), std::nullopt, std::move(why)};
}

/// Index of each scan or increment, for the x axis.
std::vector<double> indices(std::size_t n) {
  std::vector<double> x(n);
  for (std::size_t k = 0; k < n; ++k) x[k] = double(k);
  return x;
}

template <class T, class F>
Series per_item(const std::vector<T>& items, std::string name, F&& value, std::string style = "linepoints") {
  Series s{std::move(name), std::move(style), indices(items.size()), {}, {}};
  for (const T& item : items) s.y.push_back(value(item));
  return s;
}

/// A chart of counts per scan or increment: one line per column (its name and how to read it).
template <class T>
Chart counts_chart(const std::string& id, std::string title, std::string x_label, std::string y_label, const std::vector<T>& items,
                   const std::vector<std::pair<const char*, double (*)(const T&)>>& columns) {
  Chart c = chart(id, std::move(title), std::move(x_label), std::move(y_label));
  for (const auto& [name, value] : columns) c.add(per_item(items, name, value));
  return c;
}

std::string increment_name(std::size_t from, std::size_t to) { return fmt::format("scans {}-{}", from, to); }

}  // namespace

Series cdf_series(const std::vector<double>& values, std::string name, double x_scale) {
  std::vector<double> v;
  for (double x : values)
    if (std::isfinite(x)) v.push_back(x * x_scale);
  std::sort(v.begin(), v.end());
  Series s{std::move(name), "line", v, {}, {}};
  for (std::size_t k = 0; k < v.size(); ++k) s.y.push_back(double(k + 1) / double(v.size()));
  return s;
}

std::vector<BudgetLine> error_budget(const Validation& v) {
  const validate::BudgetSummary sum = validate::summarise(v);
  std::vector<BudgetLine> lines;
  const auto& scans = v.scans;
  const bool contacts = std::any_of(scans.begin(), scans.end(), [](const auto& s) { return s.has_contacts; });
  const bool shapes = std::any_of(scans.begin(), scans.end(), [](const auto& s) { return s.has_shapes; });
  using Scan = validate::ScanValidation;

  {
    Chart c = counts_chart<Scan>("segmentation", "Segmentation against the true grains", "scan", "true grains", scans,
                                 {{"right (IoU >= 0.8)", [](const Scan& s) { return double(s.segmentation.right); }},
                                  {"split", [](const Scan& s) { return double(s.segmentation.split); }},
                                  {"merged", [](const Scan& s) { return double(s.segmentation.merged); }},
                                  {"missed", [](const Scan& s) { return double(s.segmentation.missed); }}});
    lines.push_back(line("segmentation", "Segmentation: true grains right", number(100.0 * sum.grains_right, "{:.1f} %"),
                         "Share of the true grains that one label reproduces with IoU >= 0.8, over every scan; the chart counts "
                         "them per scan with the split, merged and missed ones.",
                         std::move(c)));
  }
  {
    Chart c = chart("void_ratio", "Void ratio in ct2labels' sample cylinder", "scan", "void ratio e");
    c.add(per_item(scans, "segmentation", [](const Scan& s) { return s.segmentation.void_ratio; }));
    c.add(per_item(scans, "truth", [](const Scan& s) { return s.segmentation.void_ratio_true; }, "dashed"));
    lines.push_back(line("void_ratio", "Void ratio", number(sum.void_ratio_error_max_abs, "{:.4f}"),
                         "Largest |e - e_true| over the scans, both counted by voxel centres in the labels file's sample cylinder.",
                         std::move(c)));
  }
  const std::string contacts_what = "True touching contacts between faithfully segmented grains.";
  if (!contacts) {
    lines.push_back(missing("contacts", "Contacts found", contacts_what, kNoContacts));
    lines.push_back(missing("normals", "Contact normal error", contacts_what, kNoContacts));
    lines.push_back(missing("fabric", "Fabric anisotropy", contacts_what, kNoContacts));
  } else {
    Chart c = counts_chart<Scan>("contacts", "Contacts against the true touching contacts", "scan", "contacts", scans,
                                 {{"found", [](const Scan& s) { return double(s.contacts.found); }},
                                  {"missed", [](const Scan& s) { return double(s.contacts.missed); }},
                                  {"false", [](const Scan& s) { return double(s.contacts.false_found); }}});
    lines.push_back(line("contacts", "Contacts found", number(100.0 * sum.contacts_found_share, "{:.1f} %") + fmt::format(", {} false", sum.contacts_false),
                         contacts_what + " Share found over every scan, and the contacts found between grains that do not touch.",
                         std::move(c)));
    Chart n = chart("normals", "Contact normal error", "angle to the true normal (degrees)", "share of the found contacts");
    for (const Scan& s : scans)
      if (s.has_contacts) n.add(cdf_series(s.contacts.normal_error_deg, s.name));
    lines.push_back(line("normals", "Contact normal error", number(sum.normal_error_median_deg, "{:.2f} degrees"),
                         "Median angle between the measured and the true normal of the found contacts, both oriented from the lower "
                         "to the higher true label; the chart is its distribution per scan.",
                         std::move(n)));
    Chart f = chart("fabric", "Fabric anisotropy a", "scan", "a");
    f.add(per_item(scans, "found contacts' measured normals", [](const Scan& s) { return s.contacts.anisotropy; }));
    f.add(per_item(scans, "truth (every touching contact)", [](const Scan& s) { return s.contacts.anisotropy_true; }, "dashed"));
    lines.push_back(line("fabric", "Fabric anisotropy", number(sum.anisotropy_error_max_abs, "{:.3f}"),
                         "Largest |a - a_true| over the scans (contacts::fabric_tensor of the found contacts' measured normals, and of "
                         "the true normals of every true touching contact).",
                         std::move(f)));
  }
  if (!shapes) {
    lines.push_back(missing("invariants", "SH invariant error", "Faithfully segmented grains' shapes.", kNoShapes));
    lines.push_back(missing("volume", "Grain volume error", "Faithfully segmented grains' volumes.", kNoShapes));
  } else {
    Chart c = chart("invariants", "SH invariant error per degree", "degree n", "median |R_n / R_n,true - 1|", false, true);
    for (const Scan& s : scans)
      if (s.has_shapes) c.add(Series{s.name, "linepoints", indices(s.shapes.invariant_error_by_degree.size()), s.shapes.invariant_error_by_degree, {}});
    lines.push_back(line("invariants", "SH invariant error", number(sum.invariant_error_median, "{:.3f}"),
                         "Median relative error of the rotation invariants R_n of the faithfully segmented grains over the degrees "
                         "n >= 2 (mean over the scans); the chart is the median per degree.",
                         std::move(c)));
    Chart vol = chart("volume", "Grain volume error", "V / V_true - 1", "share of the faithful grains");
    for (const Scan& s : scans)
      if (s.has_shapes) vol.add(cdf_series(s.shapes.volume_error, s.name));
    lines.push_back(line("volume", "Grain volume error", number(sum.volume_error_median, "{:+.4f}"),
                         "Median of V / V_true - 1 over the faithfully segmented grains of every scan (the equivalent diameter's "
                         "error is its cube root's); the chart is its distribution per scan.",
                         std::move(vol)));
  }
  const std::string tracking_what = "The true grains faithfully segmented in both scans of an increment.";
  if (v.tracking.empty()) {
    lines.push_back(missing("tracking", "Tracking", tracking_what, kNoTracks));
    lines.push_back(missing("displacement", "Displacement error", tracking_what, kNoTracks));
    lines.push_back(missing("rotation", "Rotation error", tracking_what, kNoTracks));
  } else {
    using Step = validate::TrackingScore;
    Chart c = counts_chart<Step>("tracking", "Tracking of the true grains", "increment", "true grains", v.tracking,
                                 {{"right", [](const Step& t) { return double(t.right); }},
                                  {"wrong", [](const Step& t) { return double(t.wrong); }},
                                  {"lost", [](const Step& t) { return double(t.lost); }}});
    const std::size_t targets = sum.tracking_right + sum.tracking_wrong + sum.tracking_lost;
    lines.push_back(line("tracking", "Tracking", fmt::format("{} right, {} wrong, {} lost", sum.tracking_right, sum.tracking_wrong, sum.tracking_lost),
                         tracking_what + fmt::format(" Each is right, wrong or lost ({} in all); the chart counts them per increment.", targets),
                         std::move(c)));
    Chart d = chart("displacement", "Displacement error of the right tracks", "|u - u_true| (um)", "share of the right tracks");
    for (const Step& t : v.tracking) d.add(cdf_series(t.displacement_error_m, increment_name(t.from, t.to), 1e6));
    lines.push_back(line("displacement", "Displacement error",
                         number(1e6 * sum.displacement_error_median_m, "{:.2f} um") + ", " +
                             number(100.0 * sum.displacement_error_rel_median, "{:.1f} % of the true displacement"),
                         "Median |u - u_true| of the right tracks' centroid increments over every increment, and the mean over the "
                         "increments of its median share of |u_true|.",
                         std::move(d)));
    Chart r = chart("rotation", "Rotation error of the right tracks", "angle of R_true^-1 R (degrees)", "share of the right tracks");
    for (const Step& t : v.tracking) r.add(cdf_series(t.rotation_error_deg, increment_name(t.from, t.to)));
    lines.push_back(line("rotation", "Rotation error", number(sum.rotation_error_median_deg, "{:.2f} degrees"),
                         "Median angle between the measured and the true rotation of the right tracks whose rotation is defined.",
                         std::move(r)));
  }
  const std::string micro_what = "The run's grains rightly tracked over an increment, against the truth's values computed by the micro "
                                 "module from the true centroids with the run's parameters.";
  if (v.deformation.empty()) {
    lines.push_back(missing("d2min", "D2min and eps_q", micro_what, kNoMicro));
    lines.push_back(missing("clusters", "High-D2min clusters", micro_what, kNoMicro));
  } else {
    using Inc = validate::DeformationScore;
    Chart c = chart("d2min", "D2min against the truth's", "true D2min / d50^2", "measured D2min / d50^2", true, true);
    for (const Inc& d : v.deformation) c.add(Series{increment_name(d.from, d.to), "points", d.d2min_true, d.d2min, {}});
    lines.push_back(line("d2min", "D2min and eps_q", number(sum.d2min_spearman, "Spearman {:.3f}") + number(sum.eps_q_spearman, " (eps_q {:.3f})"),
                         micro_what + " Spearman's rank correlation, mean over the increments; the chart shows every pair.",
                         std::move(c)));
    Chart k = counts_chart<Inc>("clusters", "Members of the top-D2min clusters", "increment", "grains", v.deformation,
                                {{"measured", [](const Inc& d) { return double(d.cluster_members); }},
                                 {"truth", [](const Inc& d) { return double(d.cluster_members_true); }},
                                 {"both", [](const Inc& d) { return double(d.cluster_common); }}});
    lines.push_back(line("clusters", "High-D2min clusters", number(sum.cluster_jaccard, "Jaccard {:.3f}"),
                         micro_what + " The Jaccard index of the measured and the true cluster members, mean over the increments.",
                         std::move(k)));
  }
  const std::string twin_what = "The twin's shearing (simulation.h5) against the truth's simulated triaxial test, over their common "
                                "axial strain range.";
  if (!v.twin.simulated) {
    lines.push_back(missing("twin", "Twin against the truth's test", twin_what, kPrescribed));
  } else if (!v.has_simulation) {
    lines.push_back(missing("twin", "Twin against the truth's test", twin_what, kNoSimulation));
  } else {
    Chart c = chart("twin", "Stress ratio against the truth's", "axial strain eps_1", "sigma_1 / sigma_3");
    c.add(Series{"truth", "dashed", v.twin.axial_strain, v.twin.stress_ratio_true, {}});
    c.add(Series{"twin", "line", v.twin.axial_strain, v.twin.stress_ratio, {}});
    lines.push_back(line("twin", "Twin against the truth's test",
                         number(v.twin.stress_ratio_rms_rel, "stress ratio RMS {:.3f}") +
                             number(v.twin.volumetric_strain_max_abs, ", eps_v within {:.4f}") +
                             number(v.twin.axial_strain_max, " up to eps_1 {:.4f}"),
                         twin_what + " RMS of the relative stress-ratio difference and the largest volumetric-strain difference.",
                         std::move(c)));
  }
  return lines;
}

}  // namespace graintwin::report
