#include "graintwin/micro/micro_file.hpp"

#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "graintwin/core/error.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/io/schema.hpp"
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
  f.set_attr(group, "used", static_cast<long long>(h.used));
  f.set_attr(group, "outside", static_cast<long long>(h.outside));
}

namespace {

void write_increment(io::H5File& f, const std::string& g, const IncrementResult& r) {
  write_histogram(f, g + "/pdf_d2min", r.pdf_d2min, "1");
  write_histogram(f, g + "/pdf_eps_q", r.pdf_eps_q, "1");
  const ClusterStatistics& c = r.clusters;
  const std::string cg = g + "/clusters";
  f.ensure_group(cg);
  f.write(cg + "/size", c.size);
  f.write(cg + "/radius_of_gyration", c.radius_of_gyration, units("m"));
  f.set_attr(cg, "selected", static_cast<long long>(c.selected));
  f.set_attr(cg, "threshold_d2min", c.threshold);
  f.set_attr(cg, "size_fit_valid", static_cast<long long>(c.size_fit.valid));
  // An unfitted P(s) (too few clusters) is NaN, never a number that looks like a result.
  const auto fitted = [&](double v) { return c.size_fit.valid ? v : std::nan(""); };
  f.set_attr(cg, "size_alpha", fitted(c.size_fit.alpha));
  f.set_attr(cg, "size_alpha_error", fitted(c.size_fit.alpha_error));
  f.set_attr(cg, "size_s_min", fitted(c.size_fit.x_min));
  f.set_attr(cg, "size_ks", fitted(c.size_fit.ks));
  f.set_attr(cg, "size_tail", static_cast<long long>(c.size_fit.tail));
  f.set_attr(cg, "fractal_dimension", c.fractal_dimension);
  f.set_attr(cg, "fractal_dimension_error", c.fractal_dimension_error);
  f.set_attr(cg, "rg_fit_clusters", static_cast<long long>(c.rg_fit.count));
  const char* axis[3] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) write_histogram(f, g + "/displacement/" + axis[k], r.displacement.component[k], "1");
  write_histogram(f, g + "/displacement/magnitude", r.displacement.magnitude, "1");
}

void write_state(io::H5File& f, const std::string& g, const StateResult& r, const shape::SizeDistribution* psd) {
  f.ensure_group(g + "/rdf");
  f.write(g + "/rdf/r", r.rdf.r, units("m"));
  f.write(g + "/rdf/g", r.rdf.g, units("1"));
  f.set_attr(g + "/rdf", "density", r.rdf.density);
  f.set_attr(g + "/rdf", "points", static_cast<long long>(r.rdf.points));
  f.set_attr(g + "/rdf", "region", r.region.kind == Region::Kind::box ? "box" : "cylinder");
  f.set_attr(g + "/rdf", "region_lo", std::vector<double>{r.region.lo.x(), r.region.lo.y(), r.region.lo.z()});
  f.set_attr(g + "/rdf", "region_hi", std::vector<double>{r.region.hi.x(), r.region.hi.y(), r.region.hi.z()});
  if (r.region.kind == Region::Kind::cylinder) {
    f.set_attr(g + "/rdf", "region_axis_xy", std::vector<double>{r.region.axis.x(), r.region.axis.y()});
    f.set_attr(g + "/rdf", "region_radius", r.region.radius);
  }
  const CoordinationDistribution& cn = r.coordination_distribution;
  f.ensure_group(g + "/coordination");
  std::vector<std::uint32_t> z(cn.count.size());
  for (std::size_t k = 0; k < z.size(); ++k) z[k] = static_cast<std::uint32_t>(k);
  f.write(g + "/coordination/z", z);
  f.write(g + "/coordination/count", cn.count);
  f.set_attr(g + "/coordination", "mean", cn.mean);
  f.set_attr(g + "/coordination", "source", r.coordination_from_contacts ? "contacts" : "distance");
  if (psd) {
    f.ensure_group(g + "/psd");
    f.write(g + "/psd/diameter", psd->diameter, units("m"));
    f.write(g + "/psd/percent_passing", psd->percent_passing, units("%"));
    f.set_attr(g + "/psd", "d50", psd->d50);
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
  f.set_attr(sm::grain_status, "codes", kStatusCodes);
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

}  // namespace graintwin::micro
