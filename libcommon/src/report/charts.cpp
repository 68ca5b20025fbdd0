#include "graintwin/report/charts.hpp"

#include <gsl/gsl_sf_zeta.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>

#include "graintwin/core/error.hpp"

namespace graintwin::report {

bool Chart::add(Series s) {
  if (kind == "rose") {
    // A rose keeps every band (x holds the n + 1 edges); an empty band is drawn at zero.
    if (s.x.size() != s.y.size() + 1) throw UsageError("Chart::add: rose " + s.name + " needs one more edge than values");
    for (double& v : s.y)
      if (!std::isfinite(v)) v = 0.0;
    series.push_back(std::move(s));
    return true;
  }
  const bool vline = s.style == "vline";
  if (!vline && s.x.size() != s.y.size()) throw UsageError("Chart::add: series " + s.name + " has x and y of different lengths");
  const auto keep_x = [&](double v) { return std::isfinite(v) && (!x_log || v > 0.0); };
  const auto keep_y = [&](double v) { return std::isfinite(v) && (!y_log || v > 0.0); };
  Series kept{s.name, s.style, {}, {}, s.group};
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    if (!keep_x(s.x[i]) || (!vline && !keep_y(s.y[i]))) continue;
    kept.x.push_back(s.x[i]);
    if (!vline) kept.y.push_back(s.y[i]);
  }
  if (kept.x.empty()) return false;
  series.push_back(std::move(kept));
  return true;
}

namespace {

/// JSON has no NaN: an undefined value is null.
nlohmann::json number_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

nlohmann::json to_json(const SectionView& v) {
  nlohmann::json values = nlohmann::json::array();
  for (double x : v.value) values.push_back(number_or_null(x));
  return {{"title", v.title},
          {"plane", v.plane},
          {"offset", v.offset},
          {"extent", v.extent},
          {"labels_file", v.labels_file},
          {"volume_file", v.volume_file},
          {"index", v.index},
          {"outline_label", v.outline_label},
          {"outline", v.outline},
          {"identity_label", v.identity_label},
          {"identity", v.identity},
          {"quantity", v.quantity},
          {"value_label", v.value_label},
          {"value", values},
          {"colour_min", number_or_null(v.colour_min)},
          {"colour_max", number_or_null(v.colour_max)},
          {"colour_log", v.colour_log}};
}

nlohmann::json to_json(const NetworkView& v) {
  return {{"segments", v.segments}, {"force", v.force}, {"force_max", v.force_max}, {"radius_max", v.radius_max}, {"bounds", v.bounds}};
}

nlohmann::json to_json(const GrainsView& v) {
  nlohmann::json values = nlohmann::json::array();
  for (double x : v.value) values.push_back(number_or_null(x));
  return {{"centre", v.centre},         {"radius", v.radius},         {"value", values},
          {"highlighted", v.highlighted}, {"membrane", v.membrane},     {"quantity", v.quantity},
          {"colour_min", number_or_null(v.colour_min)}, {"colour_max", number_or_null(v.colour_max)},
          {"colour_log", v.colour_log},   {"bounds", v.bounds}};
}

nlohmann::json to_json(const SurfacesView& v) {
  return {{"mesh_file", v.mesh_file}, {"triangles", v.triangles.size() / 3}, {"grains", v.grains},
          {"grains_cut", v.grains_cut}, {"source_triangles", v.source_triangles}, {"membrane", v.membrane},
          {"membrane_radius", v.membrane_radius}, {"cut", v.cut}, {"bounds", v.bounds}};
}

}  // namespace

nlohmann::json to_json(const Chart& c) {
  nlohmann::json series = nlohmann::json::array();
  for (const Series& s : c.series)
    series.push_back({{"name", s.name}, {"style", s.style}, {"x", s.x}, {"y", s.y}, {"group", s.group}});
  nlohmann::json sections = nlohmann::json::array();
  for (const SectionView& v : c.sections) sections.push_back(to_json(v));
  nlohmann::json j = {{"file", c.file},       {"panel", c.panel}, {"kind", c.kind},   {"title", c.title},   {"x_label", c.x_label},
                      {"y_label", c.y_label}, {"x_log", c.x_log}, {"y_log", c.y_log}, {"series", series}, {"sections", sections}};
  if (c.network) j["network"] = to_json(*c.network);
  if (c.grains) j["grains"] = to_json(*c.grains);
  if (c.surfaces) j["surfaces"] = to_json(*c.surfaces);
  return j;
}

std::vector<std::size_t> pick_evenly(std::size_t count, std::size_t max_count) {
  if (count == 0 || max_count == 0) return {};
  if (count <= max_count) {
    std::vector<std::size_t> all(count);
    for (std::size_t i = 0; i < count; ++i) all[i] = i;
    return all;
  }
  if (max_count == 1) return {count - 1};
  std::vector<std::size_t> picked;
  for (std::size_t k = 0; k < max_count; ++k) {
    const auto i = static_cast<std::size_t>(std::llround(double(k) * double(count - 1) / double(max_count - 1)));
    if (picked.empty() || picked.back() != i) picked.push_back(i);
  }
  return picked;
}

Series pdf_series(const micro::Histogram& h, bool log_bins, std::string name, double x_scale) {
  Series s{std::move(name), "linepoints", {}, {}};
  for (std::size_t b = 0; b < h.count.size() && b + 1 < h.edges.size(); ++b) {
    if (h.count[b] == 0) continue;
    const double lo = h.edges[b], hi = h.edges[b + 1];
    s.x.push_back(x_scale * (log_bins ? std::sqrt(lo * hi) : 0.5 * (lo + hi)));
    s.y.push_back(h.density[b]);
  }
  return s;
}

Series ccdf_series(const std::vector<double>& sizes, std::string name) {
  std::vector<double> v;
  for (double s : sizes)
    if (std::isfinite(s) && s > 0.0) v.push_back(s);
  std::sort(v.begin(), v.end());
  Series out{std::move(name), "points", {}, {}};
  for (std::size_t i = 0; i < v.size(); ++i)
    if (i == 0 || v[i] != v[i - 1]) {
      out.x.push_back(v[i]);
      out.y.push_back(double(v.size() - i) / double(v.size()));
    }
  return out;
}

Series power_law_ccdf(double alpha, double s_min, double s_max, std::size_t tail, std::size_t n, std::string name) {
  Series out{std::move(name), "line", {}, {}};
  if (!(alpha > 1.0) || !(s_min >= 1.0) || n == 0) return out;
  const double norm = gsl_sf_hzeta(alpha, s_min);
  for (double s = s_min; s <= s_max; s += 1.0) {
    out.x.push_back(s);
    out.y.push_back(double(tail) / double(n) * gsl_sf_hzeta(alpha, s) / norm);
  }
  return out;
}

Series log_line_through_mean(const std::vector<double>& x, const std::vector<double>& y, double slope, std::string name) {
  Series out{std::move(name), "dashed", {}, {}};
  double sx = 0.0, sy = 0.0, lo = INFINITY, hi = -INFINITY;
  std::size_t n = 0;
  for (std::size_t i = 0; i < x.size() && i < y.size(); ++i)
    if (x[i] > 0.0 && y[i] > 0.0 && std::isfinite(x[i]) && std::isfinite(y[i])) {
      sx += std::log10(x[i]), sy += std::log10(y[i]), ++n;
      lo = std::min(lo, x[i]), hi = std::max(hi, x[i]);
    }
  if (n == 0 || !std::isfinite(slope)) return out;
  const double mx = sx / double(n), my = sy / double(n);
  for (double v : {lo, hi}) {
    out.x.push_back(v);
    out.y.push_back(std::pow(10.0, my + slope * (std::log10(v) - mx)));
  }
  return out;
}

namespace {
/// Points of f(t) at `count` log-spaced t over [lo, hi].
template <class F>
void sample_log(Series& s, double lo, double hi, F&& f) {
  constexpr int count = 40;
  if (!(lo > 0.0) || !(hi > lo)) return;
  for (int k = 0; k < count; ++k) {
    const double t = lo * std::pow(hi / lo, double(k) / double(count - 1));
    s.x.push_back(t);
    s.y.push_back(f(t));
  }
}
}  // namespace

Series strong_force_fit(double scale, double strong_share, double f_max, std::string name) {
  Series s{std::move(name), "dashed", {}, {}};
  if (scale > 0.0) sample_log(s, 1.0, f_max, [&](double f) { return strong_share * std::exp(-(f - 1.0) / scale) / scale; });
  return s;
}

Series weak_force_fit(double theta, double strong_share, double f_min, std::string name) {
  Series s{std::move(name), "dashed", {}, {}};
  if (theta > -1.0) sample_log(s, f_min, 1.0, [&](double f) { return (1.0 - strong_share) * (theta + 1.0) * std::pow(f, theta); });
  return s;
}

double share_at_or_above(const micro::Histogram& h, double x) {
  std::uint64_t above = 0, all = 0;
  for (std::size_t b = 0; b < h.count.size() && b < h.edges.size(); ++b) {
    all += h.count[b];
    if (h.edges[b] >= x * (1.0 - 1e-12)) above += h.count[b];
  }
  return all ? double(above) / double(all) : std::nan("");
}

Series rose_profile(const micro::ForceRose& rose, RoseValue value, std::string name) {
  const std::size_t nt = rose.theta_edges.size() - 1, np = rose.phi_edges.size() - 1;
  if (rose.theta_edges.size() < 2 || rose.phi_edges.size() < 2 || rose.counts.size() != nt * np ||
      (value == RoseValue::mean_force && rose.mean_force.size() != nt * np))
    throw DataError("rose " + name + ": the bin edges and the table disagree in size");
  Series s{std::move(name), "line", {}, {}};
  std::uint64_t total = 0;
  for (std::uint64_t c : rose.counts) total += c;
  for (double e : rose.theta_edges) s.x.push_back(e * 180.0 / std::numbers::pi);
  for (std::size_t t = 0; t < nt; ++t) {
    double count = 0.0, force = 0.0;
    for (std::size_t p = 0; p < np; ++p) {
      const std::uint64_t c = rose.counts[t * np + p];
      count += double(c);
      if (value == RoseValue::mean_force && c > 0) force += double(c) * rose.mean_force[t * np + p];
    }
    // Solid angle of the band on the upper hemisphere; each axis counts at d and -d (contacts::Rose).
    const double band = 2.0 * std::numbers::pi * (std::cos(rose.theta_edges[t]) - std::cos(rose.theta_edges[t + 1]));
    if (value == RoseValue::density)
      s.y.push_back(total ? count / (2.0 * double(total) * band) : std::nan(""));
    else
      s.y.push_back(count > 0.0 ? force / count : std::nan(""));
  }
  return s;
}

}  // namespace graintwin::report
