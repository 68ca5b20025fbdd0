#include "graintwin/micro/micro_file.hpp"

#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "graintwin/core/error.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/table_checks.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/io/vtk.hpp"

namespace graintwin::micro {
namespace sm = schema::micro;
using io::units;

void write_histogram(io::H5File& f, const std::string& group, const Histogram& h, const std::string& unit) {
  f.ensure_group(group);
  f.write(group + "/" + sm::edges, h.edges, units(unit));
  f.write(group + "/" + sm::count, h.count);
  f.write(group + "/" + sm::density, h.density, units(unit == "1" ? "1" : "1/" + unit));
  f.set_attr(group, sm::histogram_used, static_cast<long long>(h.used));
  f.set_attr(group, sm::histogram_outside, static_cast<long long>(h.outside));
}

namespace {

void write_increment(io::H5File& f, const std::string& g, const IncrementResult& r) {
  write_histogram(f, g + "/" + sm::pdf_d2min, r.pdf_d2min, "1");
  write_histogram(f, g + "/" + sm::pdf_eps_q, r.pdf_eps_q, "1");
  const ClusterStatistics& c = r.clusters;
  const std::string cg = g + "/" + sm::clusters;
  f.ensure_group(cg);
  f.write(g + "/" + sm::cluster_size, c.size);
  f.write(g + "/" + sm::cluster_rg, c.radius_of_gyration, units("m"));
  f.set_attr(cg, sm::selected, static_cast<long long>(c.selected));
  f.set_attr(cg, sm::threshold_d2min, c.threshold);
  f.set_attr(cg, sm::size_fit_valid, static_cast<long long>(c.size_fit.valid));
  // An unfitted P(s) (too few clusters) is NaN, never a number that looks like a result.
  const auto fitted = [&](double v) { return c.size_fit.valid ? v : std::nan(""); };
  f.set_attr(cg, sm::size_alpha, fitted(c.size_fit.alpha));
  f.set_attr(cg, sm::size_alpha_error, fitted(c.size_fit.alpha_error));
  f.set_attr(cg, sm::size_s_min, fitted(c.size_fit.x_min));
  f.set_attr(cg, sm::size_ks, fitted(c.size_fit.ks));
  f.set_attr(cg, sm::size_tail, static_cast<long long>(c.size_fit.tail));
  f.set_attr(cg, sm::fractal_dimension, c.fractal_dimension);
  f.set_attr(cg, sm::fractal_dimension_error, c.fractal_dimension_error);
  f.set_attr(cg, sm::rg_fit_clusters, static_cast<long long>(c.rg_fit.count));
  const std::string dg = g + "/" + sm::displacement + "/";
  for (int k = 0; k < 3; ++k) write_histogram(f, dg + sm::displacement_histograms[k], r.displacement.component[k], "1");
  write_histogram(f, dg + sm::displacement_histograms[3], r.displacement.magnitude, "1");
}

void write_state(io::H5File& f, const std::string& g, const StateResult& r, const shape::SizeDistribution* psd) {
  const std::string rdf = g + "/" + sm::rdf;
  f.ensure_group(rdf);
  f.write(g + "/" + sm::rdf_r, r.rdf.r, units("m"));
  f.write(g + "/" + sm::rdf_g, r.rdf.g, units("1"));
  f.set_attr(rdf, sm::rdf_density, r.rdf.density);
  f.set_attr(rdf, sm::rdf_points, static_cast<long long>(r.rdf.points));
  f.set_attr(rdf, sm::rdf_region, region_kind_name(r.region.kind));
  f.set_attr(rdf, sm::rdf_region_lo, std::vector<double>{r.region.lo.x(), r.region.lo.y(), r.region.lo.z()});
  f.set_attr(rdf, sm::rdf_region_hi, std::vector<double>{r.region.hi.x(), r.region.hi.y(), r.region.hi.z()});
  if (r.region.kind == Region::Kind::cylinder) {
    f.set_attr(rdf, sm::rdf_region_axis_xy, std::vector<double>{r.region.axis.x(), r.region.axis.y()});
    f.set_attr(rdf, sm::rdf_region_radius, r.region.radius);
  }
  const CoordinationDistribution& cn = r.coordination_distribution;
  f.ensure_group(g + "/" + sm::state_coordination);
  std::vector<std::uint32_t> z(cn.count.size());
  for (std::size_t k = 0; k < z.size(); ++k) z[k] = static_cast<std::uint32_t>(k);
  f.write(g + "/" + sm::state_coordination_z, z);
  f.write(g + "/" + sm::state_coordination_count, cn.count);
  f.set_attr(g + "/" + sm::state_coordination, sm::mean, cn.mean);
  f.set_attr(g + "/" + sm::state_coordination, sm::coordination_source, r.coordination_from_contacts ? "contacts" : "distance");
  if (psd) {
    f.ensure_group(g + "/" + sm::psd);
    f.write(g + "/" + sm::psd_diameter, psd->diameter, units("m"));
    f.write(g + "/" + sm::psd_percent_passing, psd->percent_passing, units("%"));
    f.set_attr(g + "/" + sm::psd, sm::d50, psd->d50);
  }
}

}  // namespace

void write_micro_file(const std::filesystem::path& path, const MicroFile& c, const std::vector<std::string>& history) {
  const SeriesStates& s = c.series;
  const MicroResult& r = c.result;
  const hsize_t n = s.grains, t = s.states, k = r.increments.size();
  if (c.label.size() != n * t || c.state_files.size() != t || r.states.size() != t || (!s.psd.empty() && s.psd.size() != t))
    throw UsageError("write_micro_file: the grains, states and results disagree in size");
  std::vector<double> d2min(n * k), eps_q(n * k), affine(n * k * 9), strain(n * k * 6);
  std::vector<std::uint32_t> neighbours(n * k), coordination(n * t);
  std::vector<std::uint8_t> status(n * k);
  std::vector<std::int32_t> cluster(n * k);
  std::vector<std::uint64_t> from(k), to(k);
  std::vector<double> d50(k);
  for (std::size_t q = 0; q < k; ++q) {
    const IncrementResult& inc = r.increments[q];
    from[q] = inc.from, to[q] = inc.to, d50[q] = inc.d50;
    for (std::size_t i = 0; i < n; ++i) {
      const LocalDeformation& g = inc.grains[i];
      const std::size_t cell = i * k + q;
      d2min[cell] = g.d2min, eps_q[cell] = g.eps_q;
      neighbours[cell] = g.neighbours;
      status[cell] = static_cast<std::uint8_t>(g.status);
      cluster[cell] = inc.clusters.cluster[i];
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) affine[cell * 9 + std::size_t(3 * a + b)] = g.lambda(a, b);
      for (int a = 0; a < 6; ++a) strain[cell * 6 + std::size_t(a)] = g.strain[a];
    }
  }
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t q = 0; q < t; ++q) coordination[i * t + q] = r.states[q].coordination[i];
  io::H5File f = io::H5File::create(path);
  io::write_root_attrs(f, schema::kind::micro);
  f.write(sm::grain_label, c.label.data(), {n, t});
  f.write(sm::grain_d2min, d2min.data(), {n, k}, units("1"));
  f.write(sm::grain_affine, affine.data(), {n, k, 3, 3}, units("1"));
  f.write(sm::grain_strain, strain.data(), {n, k, 6}, units("1"));
  f.write(sm::grain_eps_q, eps_q.data(), {n, k}, units("1"));
  f.write(sm::grain_neighbours, neighbours.data(), {n, k});
  f.write(sm::grain_status, status.data(), {n, k});
  f.set_attr(sm::grain_status, sm::codes, kStatusCodes);
  f.write(sm::grain_cluster, cluster.data(), {n, k});
  f.write(sm::grain_coordination, coordination.data(), {n, t});
  f.write(sm::increment_from, from);
  f.write(sm::increment_to, to);
  f.write(sm::increment_d50, d50, units("m"));
  for (std::size_t q = 0; q < k; ++q) write_increment(f, std::string(sm::increments) + "/" + std::to_string(q), r.increments[q]);
  f.write_strings(sm::state_file, c.state_files);
  f.write(sm::state_d50, s.d50, units("m"));
  for (std::size_t q = 0; q < t; ++q)
    write_state(f, std::string(sm::states) + "/" + std::to_string(q), r.states[q], s.psd.empty() ? nullptr : &s.psd[q]);
  f.write_strings(sm::parameters, {c.parameters_json});
  io::write_history(f, history);
}

std::string read_micro_source(const io::H5File& f) {
  const nlohmann::json p = nlohmann::json::parse(f.read_string(sm::parameters), nullptr, false);
  if (!p.is_object() || !p.contains("source") || !p["source"].is_string())
    throw DataError(fmt::format("{}: {} is not a JSON object naming its source; the file is damaged, rewrite it with tracks2micro",
                                f.path().string(), sm::parameters));
  return p["source"].get<std::string>();
}

void write_micro_vtp(const std::filesystem::path& path, const MicroFile& c) {
  const SeriesStates& s = c.series;
  const auto& incs = c.result.increments;
  io::VtkPolyData d;
  std::vector<std::size_t> shown;
  for (std::size_t i = 0; i < s.grains; ++i)
    for (const IncrementResult& inc : incs) {
      const Eigen::Vector3d& p = s.position[i * s.states + inc.from];
      if (p.allFinite() && s.position[i * s.states + inc.to].allFinite()) {
        shown.push_back(i);
        d.points.insert(d.points.end(), {p.x(), p.y(), p.z()});
        break;
      }
    }
  d.add_vertices(0, shown.size());
  io::VtkArray grain{"grain", 1, {}};
  for (std::size_t i : shown) grain.values.push_back(double(i));
  d.point_data.push_back(std::move(grain));
  for (std::size_t q = 0; q < incs.size(); ++q) {
    const std::string tag = "_" + std::to_string(q);
    io::VtkArray d2{"d2min" + tag, 1, {}}, eq{"eps_q" + tag, 1, {}}, cl{"cluster" + tag, 1, {}}, ok{"defined" + tag, 1, {}};
    for (std::size_t i : shown) {
      const LocalDeformation& g = incs[q].grains[i];
      const bool defined = g.status == DeformationStatus::ok;
      d2.values.push_back(defined ? g.d2min : 0.0);
      eq.values.push_back(defined ? g.eps_q : 0.0);
      cl.values.push_back(double(incs[q].clusters.cluster[i]));
      ok.values.push_back(defined ? 1.0 : 0.0);
    }
    for (auto* a : {&d2, &eq, &cl, &ok}) d.point_data.push_back(std::move(*a));
  }
  io::write_vtp(path, d);
}

Histogram read_histogram(const io::H5File& f, const std::string& group) {
  Histogram h;
  h.edges = f.read<double>(group + "/" + sm::edges);
  h.count = f.read<std::uint64_t>(group + "/" + sm::count);
  h.density = f.read<double>(group + "/" + sm::density);
  h.used = static_cast<std::uint64_t>(f.attr_int(group, sm::histogram_used).value_or(0));
  h.outside = static_cast<std::uint64_t>(f.attr_int(group, sm::histogram_outside).value_or(0));
  if (h.count.size() != h.density.size() || (!h.count.empty() && h.edges.size() != h.count.size() + 1))
    throw DataError(f.path().string() + ": the histogram " + group + " has tables of uneven length; rewrite the file with its tool");
  return h;
}

namespace {

double attr_or_nan(const io::H5File& f, const std::string& object, const std::string& name) {
  const auto v = f.attr_doubles(object, name);
  return v.size() == 1 ? v[0] : std::nan("");
}

}  // namespace

void check_micro_tables(const io::H5File& f) {
  const std::string fix = "rewrite it with tracks2micro";
  for (const char* g : {sm::grains, sm::increments, sm::states}) io::table_rows(f, g, fix);
  for (const char* g : {sm::grains, sm::increments, sm::states}) io::require_finite_table(f, g, {sm::d50_column}, fix);
}

MicroTables read_micro_tables(const std::filesystem::path& path) {
  const io::H5File f = io::open_kind(path, schema::kind::micro, "pass the output of tracks2micro");
  check_micro_tables(f);
  MicroTables m;
  m.source = read_micro_source(f);
  m.state_d50 = f.read<double>(sm::state_d50);
  for (std::size_t t = 0; t < m.state_d50.size(); ++t) {
    const std::string g = std::string(sm::states) + "/" + std::to_string(t) + "/";
    MicroStateTables st;
    st.rdf_r = f.read<double>(g + sm::rdf_r);
    st.rdf_g = f.read<double>(g + sm::rdf_g);
    st.coordination = f.read<std::uint64_t>(g + sm::state_coordination_count);
    st.coordination_mean = attr_or_nan(f, g + sm::state_coordination, sm::mean);
    if (f.exists(g + sm::psd)) {
      st.psd.diameter = f.read<double>(g + sm::psd_diameter);
      st.psd.percent_passing = f.read<double>(g + sm::psd_percent_passing);
      st.psd.d50 = attr_or_nan(f, g + sm::psd, sm::d50);
    }
    // Each pair is drawn as x against y: unequal columns would reach the charts as nonsense.
    if (st.rdf_r.size() != st.rdf_g.size() || st.psd.diameter.size() != st.psd.percent_passing.size())
      throw DataError(path.string() + ": state " + std::to_string(t) + "'s g(r) or PSD columns differ in length; rewrite it with tracks2micro");
    m.states.push_back(std::move(st));
  }
  const auto from = f.read<std::uint64_t>(sm::increment_from), to = f.read<std::uint64_t>(sm::increment_to);
  const auto d50 = f.read<double>(sm::increment_d50);
  if (to.size() != from.size() || d50.size() != from.size())
    throw DataError(path.string() + ": /increments/from, /to and /d50 differ in length; rewrite it with tracks2micro");
  for (std::size_t k = 0; k < from.size(); ++k) {
    const std::string g = std::string(sm::increments) + "/" + std::to_string(k) + "/";
    MicroIncrementTables inc;
    inc.from = from[k], inc.to = to[k], inc.d50 = d50[k];
    inc.pdf_d2min = read_histogram(f, g + sm::pdf_d2min);
    inc.pdf_eps_q = read_histogram(f, g + sm::pdf_eps_q);
    for (int a = 0; a < 4; ++a) inc.displacement[a] = read_histogram(f, g + sm::displacement + "/" + sm::displacement_histograms[a]);
    const std::string c = g + sm::clusters;
    inc.cluster_size = f.read<double>(g + sm::cluster_size);
    inc.cluster_rg = f.read<double>(g + sm::cluster_rg);
    inc.selected = static_cast<std::size_t>(f.attr_int(c, sm::selected).value_or(0));
    inc.size_fit_valid = f.attr_int(c, sm::size_fit_valid).value_or(0) != 0;
    inc.size_alpha = attr_or_nan(f, c, sm::size_alpha);
    inc.size_alpha_error = attr_or_nan(f, c, sm::size_alpha_error);
    inc.size_s_min = attr_or_nan(f, c, sm::size_s_min);
    inc.size_tail = static_cast<std::size_t>(f.attr_int(c, sm::size_tail).value_or(0));
    inc.fractal_dimension = attr_or_nan(f, c, sm::fractal_dimension);
    inc.fractal_dimension_error = attr_or_nan(f, c, sm::fractal_dimension_error);
    if (inc.cluster_size.size() != inc.cluster_rg.size())
      throw DataError(path.string() + ": " + c + "/size and /radius_of_gyration differ in length; rewrite it with tracks2micro");
    m.increments.push_back(std::move(inc));
  }
  std::vector<hsize_t> label_dims, d2_dims, eq_dims, cl_dims;
  m.grain_label = f.read<std::uint32_t>(sm::grain_label, &label_dims);
  m.grain_d2min = f.read<double>(sm::grain_d2min, &d2_dims);
  m.grain_eps_q = f.read<double>(sm::grain_eps_q, &eq_dims);
  m.grain_cluster = f.read<std::int32_t>(sm::grain_cluster, &cl_dims);
  m.grains = label_dims.empty() ? 0 : label_dims[0];
  const std::vector<hsize_t> per_increment{m.grains, m.increments.size()};
  if (label_dims.size() != 2 || label_dims[1] != m.states.size() || d2_dims != per_increment || eq_dims != per_increment ||
      cl_dims != per_increment)
    throw DataError(path.string() + ": " + sm::grain_label + " is not grains x states or " + sm::grain_d2min + ", " + sm::grain_eps_q +
                    " or " + sm::grain_cluster + " not grains x increments; rewrite it with tracks2micro");
  m.parameters_json = f.read_string(sm::parameters);
  return m;
}

std::vector<double> d2min_of_increment(const MicroTables& m, const std::string& name, const SimulationGrains& grains,
                                       std::size_t from, std::size_t to) {
  if (m.source != schema::kind::fdem_results)
    throw UsageError("--micro " + name + " was made from " + m.source + ", not from simulation frames; run tracks2micro on the results file");
  std::size_t k = m.increments.size();
  for (std::size_t q = 0; q < m.increments.size(); ++q)
    if (m.increments[q].from == from && m.increments[q].to == to) k = q;
  if (k == m.increments.size())
    throw UsageError("--micro " + name + " has no increment " + std::to_string(from) + " -> " + std::to_string(to) +
                     "; run tracks2micro RESULTS MICRO --from " + std::to_string(from) + " --to " + std::to_string(to) +
                     " or leave out --micro");
  const std::size_t t = m.states.size(), kk = m.increments.size();
  std::vector<double> out(grains.label.size(), std::nan(""));
  std::size_t found = 0;
  for (std::size_t i = 0; i < m.grains; ++i) {
    const auto it = grains.row.find(m.grain_label[i * t + from]);
    if (it != grains.row.end()) out[it->second] = m.grain_d2min[i * kk + k], ++found;
  }
  if (found != grains.label.size())
    throw UsageError("--micro " + name + " lacks " + std::to_string(grains.label.size() - found) +
                     " of the simulation's grains; make it from the same results file with tracks2micro");
  return out;
}

std::map<std::uint32_t, double> d2min_by_label(const MicroTables& m, const std::string& name, std::size_t state,
                                               std::size_t increment) {
  const std::size_t t = m.states.size(), k = m.increments.size();
  if (state >= t) throw UsageError(fmt::format("{} has no state {} (it holds {}); give a state below {}", name, state, t, t));
  if (increment >= k)
    throw UsageError(fmt::format("{} has no increment {} (it holds {}); give an increment below {}", name, increment, k, k));
  std::map<std::uint32_t, double> out;
  for (std::size_t i = 0; i < m.grains; ++i) {
    const std::uint32_t label = m.grain_label[i * t + state];
    const double d2min = m.grain_d2min[i * k + increment];
    if (label != 0 && std::isfinite(d2min)) out[label] = d2min;
  }
  return out;
}

}  // namespace graintwin::micro
