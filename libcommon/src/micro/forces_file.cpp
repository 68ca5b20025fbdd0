#include "graintwin/micro/forces_file.hpp"

#include <fmt/format.h>

#include <cmath>
#include <fstream>

#include "graintwin/core/error.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/table_checks.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/io/vtk.hpp"
#include "graintwin/micro/micro_file.hpp"

namespace graintwin::micro {
namespace sf = schema::forces;
using io::units;

std::vector<std::size_t> strong_contacts(const std::vector<double>& fn, double mean, double threshold) {
  std::vector<std::size_t> strong;
  if (!(mean > 0.0)) return strong;
  for (std::size_t c = 0; c < fn.size(); ++c)
    if (std::isfinite(fn[c]) && fn[c] > 0.0 && fn[c] >= threshold * mean) strong.push_back(c);
  return strong;
}

FrameForces frame_forces(const std::vector<Eigen::Vector3d>& normals, const std::vector<double>& fn, double per_decade,
                         int theta_bins, int phi_bins, double threshold) {
  FrameForces r;
  r.contacts = fn.size();
  r.distribution = force_distribution(fn, per_decade);
  r.rose = force_rose(normals, fn, theta_bins, phi_bins);
  r.strong = strong_contacts(fn, r.distribution.mean, threshold).size();
  return r;
}

std::vector<double> grain_q(const std::vector<double>& stress) {
  if (stress.size() % 9 != 0) throw UsageError("grain_q: the stress table needs 9 values per grain");
  std::vector<double> q(stress.size() / 9);
  for (std::size_t g = 0; g < q.size(); ++g)
    q[g] = deviatoric_stress_q(Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(stress.data() + 9 * g));
  return q;
}

void write_forces_file(const std::filesystem::path& path, const ForcesFile& c, const std::vector<std::string>& history) {
  const hsize_t g = c.label.size(), nf = c.frames.size(), nw = c.windows.size();
  if (c.q.size() != g * nf) throw UsageError("write_forces_file: q must hold one value per grain and frame");
  std::vector<std::uint64_t> index, contacts, platen, strong, from, to, count;
  std::vector<double> time, mean, scale, scale_error, theta, theta_error, r, p;
  const double nan = std::nan("");
  for (const FrameForces& fr : c.frames) {
    index.push_back(fr.frame), time.push_back(fr.time), contacts.push_back(fr.contacts);
    platen.push_back(fr.platen_contacts), strong.push_back(fr.strong), mean.push_back(fr.distribution.mean);
    const ExponentialFit& s = fr.distribution.strong;
    const WeakForceFit& w = fr.distribution.weak;
    // An unfitted tail is NaN, never a number that looks like a result.
    scale.push_back(s.valid ? s.scale : nan), scale_error.push_back(s.valid ? s.scale_error : nan);
    theta.push_back(w.valid ? w.theta : nan), theta_error.push_back(w.valid ? w.theta_error : nan);
  }
  std::vector<double> volatility(g * nw), d2min(g * nw);
  for (std::size_t k = 0; k < nw; ++k) {
    const VolatilityWindow& w = c.windows[k];
    if (w.volatility.size() != g || w.d2min.size() != g) throw UsageError("write_forces_file: a window does not cover every grain");
    from.push_back(w.from), to.push_back(w.to), r.push_back(w.correlation.r), p.push_back(w.correlation.p_value);
    count.push_back(w.correlation.count);
    for (std::size_t i = 0; i < g; ++i) volatility[i * nw + k] = w.volatility[i], d2min[i * nw + k] = w.d2min[i];
  }
  io::H5File f = io::H5File::create(path);
  io::write_root_attrs(f, schema::kind::forces);
  f.write(sf::grain_label, c.label);
  f.write(sf::grain_q, c.q.data(), {g, nf}, units("Pa"));
  f.set_attr(sf::grain_q, sf::definition, kQDefinition);
  f.write(sf::grain_volatility, volatility.data(), {g, nw}, units("1"));
  f.set_attr(sf::grain_volatility, sf::definition,
             "sample standard deviation of R_i = ln(q_i / q_{i-1}) over the window's frames; NaN where q is not positive");
  f.write(sf::grain_d2min, d2min.data(), {g, nw}, units("1"));
  f.set_attr(sf::grain_d2min, sf::d2min_source, c.d2min_source);
  f.write(sf::frame_index, index);
  f.write(sf::frame_time, time, units("s"));
  f.write(sf::frame_contacts, contacts);
  f.write(sf::frame_platen_contacts, platen);
  f.write(sf::frame_mean_force, mean, units("N"));
  f.write(sf::frame_strong, strong);
  f.set_attr(sf::frame_strong, sf::chain_threshold, c.chain_threshold);
  f.write(sf::frame_strong_scale, scale, units("1"));
  f.write(sf::frame_strong_scale_error, scale_error, units("1"));
  f.write(sf::frame_weak_theta, theta, units("1"));
  f.write(sf::frame_weak_theta_error, theta_error, units("1"));
  for (std::size_t k = 0; k < nf; ++k) {
    const std::string group = std::string(sf::frames) + "/" + std::to_string(k);
    write_histogram(f, group + "/" + sf::frame_pdf, c.frames[k].distribution.pdf, "1");
    const ForceRose& rose = c.frames[k].rose;
    const hsize_t nt = rose.theta_edges.size() - 1, np = rose.phi_edges.size() - 1;
    const std::string rose_group = group + "/" + sf::frame_rose;
    f.ensure_group(rose_group);
    f.write(rose_group + "/" + sf::rose_theta_edges, rose.theta_edges, units("rad"));
    f.write(rose_group + "/" + sf::rose_phi_edges, rose.phi_edges, units("rad"));
    f.write(rose_group + "/" + sf::rose_count, rose.counts.data(), {nt, np});
    f.write(rose_group + "/" + sf::rose_mean_force, rose.mean_force.data(), {nt, np}, units("N"));
  }
  f.write(sf::window_from, from);
  f.write(sf::window_to, to);
  f.write(sf::window_r, r, units("1"));
  f.write(sf::window_p, p, units("1"));
  f.write(sf::window_count, count);
  f.write_strings(sf::parameters, {c.parameters_json});
  io::write_history(f, history);
}

void write_force_chain_vtp(const std::filesystem::path& path, const std::vector<Eigen::Vector3d>& centroids,
                           const std::vector<std::uint32_t>& labels, const std::vector<std::pair<std::size_t, std::size_t>>& pairs,
                           const std::vector<double>& fn, double mean, const std::vector<std::size_t>& chain) {
  io::VtkPolyData d;
  io::VtkArray label{"label", 1, {}}, force{"normal_force", 1, {}}, normalised{"normalised_force", 1, {}};
  std::vector<std::int64_t> point_of(centroids.size(), -1);
  const auto point = [&](std::size_t g) {
    if (point_of[g] < 0) {
      point_of[g] = std::int64_t(d.point_count());
      d.points.insert(d.points.end(), {centroids[g].x(), centroids[g].y(), centroids[g].z()});
      label.values.push_back(double(labels[g]));
    }
    return point_of[g];
  };
  for (std::size_t c : chain) {
    d.add_line(point(pairs[c].first), point(pairs[c].second));
    force.values.push_back(fn[c]);
    normalised.values.push_back(fn[c] / mean);
  }
  d.point_data.push_back(std::move(label));
  d.cell_data.push_back(std::move(force));
  d.cell_data.push_back(std::move(normalised));
  io::write_vtp(path, d);
}

void write_pvd(const std::filesystem::path& path, const std::vector<std::string>& files, const std::vector<double>& times) {
  if (files.size() != times.size()) throw UsageError("write_pvd: one time per file is needed");
  std::ofstream out(path);
  out << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n  <Collection>\n";
  for (std::size_t k = 0; k < files.size(); ++k)
    out << fmt::format("    <DataSet timestep=\"{:.17g}\" part=\"0\" file=\"{}\"/>\n", times[k], files[k]);
  out << "  </Collection>\n</VTKFile>\n";
  if (!out) throw DataError("cannot write " + path.string() + "; check the disk and the folder's permissions");
}

void check_forces_tables(const io::H5File& f) {
  const std::string fix = "rewrite it with fdem2forces";
  for (const char* g : {sf::frames, sf::grains, sf::windows}) io::table_rows(f, g, fix);
  for (const char* g : {sf::frames, sf::grains, sf::windows}) io::require_finite_table(f, g, {}, fix);
}

ForcesTables read_forces_tables(const std::filesystem::path& path) {
  const io::H5File f = io::open_kind(path, schema::kind::forces, "pass the output of fdem2forces");
  check_forces_tables(f);
  ForcesTables d;
  const auto index = f.read<std::uint64_t>(sf::frame_index), contacts = f.read<std::uint64_t>(sf::frame_contacts);
  const auto time = f.read<double>(sf::frame_time), scale = f.read<double>(sf::frame_strong_scale), theta = f.read<double>(sf::frame_weak_theta);
  if (contacts.size() != index.size() || time.size() != index.size() || scale.size() != index.size() || theta.size() != index.size())
    throw DataError(path.string() + ": the /frames tables differ in length; rewrite it with fdem2forces");
  for (std::size_t k = 0; k < index.size(); ++k) {
    const std::string g = std::string(sf::frames) + "/" + std::to_string(k) + "/";
    ForcesFrameTables fr;
    fr.index = index[k], fr.time = time[k], fr.contacts = contacts[k], fr.strong_scale = scale[k], fr.weak_theta = theta[k];
    fr.pdf = read_histogram(f, g + sf::frame_pdf);
    const std::string rose = g + sf::frame_rose + "/";
    fr.rose.theta_edges = f.read<double>(rose + sf::rose_theta_edges);
    fr.rose.phi_edges = f.read<double>(rose + sf::rose_phi_edges);
    fr.rose.counts = f.read<std::uint64_t>(rose + sf::rose_count);
    if (fr.rose.theta_edges.size() < 2 || fr.rose.phi_edges.size() < 2 ||
        fr.rose.counts.size() != (fr.rose.theta_edges.size() - 1) * (fr.rose.phi_edges.size() - 1))
      throw DataError(path.string() + ": the rose " + g + sf::frame_rose + " does not have one count per bin; rewrite the file with its tool");
    fr.rose.mean_force = f.read<double>(rose + sf::rose_mean_force);
    if (fr.rose.mean_force.size() != fr.rose.counts.size())
      throw DataError(path.string() + ": " + rose + sf::rose_mean_force + " does not have one value per rose bin; rewrite it with fdem2forces");
    d.frames.push_back(std::move(fr));
  }
  const auto from = f.read<std::uint64_t>(sf::window_from), to = f.read<std::uint64_t>(sf::window_to);
  const auto r = f.read<double>(sf::window_r), p = f.read<double>(sf::window_p);
  const auto count = f.read<std::uint64_t>(sf::window_count);
  std::vector<hsize_t> dims;
  const auto volatility = f.read<double>(sf::grain_volatility, &dims);
  const auto d2min = f.read<double>(sf::grain_d2min);
  const std::size_t w = from.size(), g = dims.empty() ? 0 : dims[0];
  if (to.size() != w || r.size() != w || p.size() != w || count.size() != w || dims.size() != 2 || dims[1] != w ||
      d2min.size() != volatility.size())
    throw DataError(path.string() + ": the /windows tables and the grains' volatility and D2min disagree in size; rewrite it with fdem2forces");
  for (std::size_t k = 0; k < w; ++k) {
    ForcesWindowTables win{from[k], to[k], r[k], p[k], count[k], {}, {}};
    for (std::size_t i = 0; i < g; ++i) win.volatility.push_back(volatility[i * w + k]), win.d2min.push_back(d2min[i * w + k]);
    d.windows.push_back(std::move(win));
  }
  return d;
}

}  // namespace graintwin::micro
