#include "graintwin/shape/shapes_file.hpp"

#include <algorithm>

#include "graintwin/core/error.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/table_checks.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/shape/sh_basis.hpp"

namespace graintwin::shape {

namespace {
/// Far above labels2shapes' --degree limit (40), far below where (degree + 1)^2 overflows an int.
constexpr long long kMaxStoredShDegree = 1000;
}  // namespace
using io::units;
namespace ss = schema::shapes;
namespace {


/// One column of a per-grain quantity, or an N x k table of vectors.
template <class T, class Get>
std::vector<T> column(const std::vector<GrainShape>& g, std::size_t k, Get&& get) {
  std::vector<T> out(g.size() * k);
  for (std::size_t i = 0; i < g.size(); ++i)
    for (std::size_t c = 0; c < k; ++c) out[i * k + c] = get(g[i], c);
  return out;
}

}  // namespace

void write_shapes_file(const std::filesystem::path& path, const ShapesFile& c, const std::vector<std::string>& history) {
  const auto& g = c.grains;
  const hsize_t n = g.size();
  const std::size_t ncoef = static_cast<std::size_t>(sh_count(c.degree));
  for (const GrainShape& s : g)
    if (static_cast<std::size_t>(s.coeffs.size()) != ncoef || s.invariants.size() != c.degree + 1)
      throw UsageError("write_shapes_file: every grain needs coefficients of degree " + std::to_string(c.degree));
  io::H5File f = io::H5File::create(path);
  io::write_root_attrs(f, schema::kind::shapes);
  const auto scalar = [&](const char* name, const char* unit, auto get) {
    f.write(name, column<double>(g, 1, [&](const GrainShape& s, std::size_t) { return get(s); }), units(unit));
  };
  f.write(ss::grain_label, column<std::uint32_t>(g, 1, [](const GrainShape& s, std::size_t) { return s.label; }));
  f.write(ss::grain_voxels, column<std::uint64_t>(g, 1, [](const GrainShape& s, std::size_t) { return s.voxels; }));
  scalar(ss::grain_volume, "m^3", [](const GrainShape& s) { return s.volume; });
  f.write(ss::grain_centroid, column<double>(g, 3, [](const GrainShape& s, std::size_t k) { return s.centroid[k]; }).data(),
          {n, 3}, units("m"));
  scalar(ss::grain_surface_area, "m^2", [](const GrainShape& s) { return s.surface_area; });
  scalar(ss::grain_equivalent_diameter, "m", [](const GrainShape& s) { return s.equivalent_diameter; });
  scalar(ss::grain_sphericity, "1", [](const GrainShape& s) { return s.sphericity; });
  f.write(ss::grain_semi_axes, column<double>(g, 3, [](const GrainShape& s, std::size_t k) { return s.semi_axes[k]; }).data(),
          {n, 3}, units("m"));
  // axes[i, k, :] is the unit direction (x, y, z) of semi-axis k of grain i.
  f.write(ss::grain_axes, column<double>(g, 9, [](const GrainShape& s, std::size_t k) { return s.axes(k % 3, k / 3); }).data(),
          {n, 3, 3}, units("1"));
  scalar(ss::grain_aspect_ratio, "1", [](const GrainShape& s) { return s.aspect_ratio; });
  scalar(ss::grain_elongation, "1", [](const GrainShape& s) { return s.elongation; });
  scalar(ss::grain_flatness, "1", [](const GrainShape& s) { return s.flatness; });

  f.write(ss::coeffs, column<double>(g, ncoef, [](const GrainShape& s, std::size_t k) { return s.coeffs[static_cast<Eigen::Index>(k)]; }).data(),
          {n, ncoef}, units("m"));
  f.set_attr(ss::coeffs, schema::attr::sh_degree, static_cast<long long>(c.degree));
  f.set_attr(ss::coeffs, schema::attr::sh_basis, std::string(kShBasisDescription));
  f.set_attr(ss::coeffs, ss::coeffs_origin, "the grain's centroid (" + std::string(ss::grain_centroid) + "), world (image) axes");
  f.write(ss::degree, column<std::int32_t>(g, 1, [](const GrainShape& s, std::size_t) { return s.sh_degree; }));
  f.write(ss::invariants,
          column<double>(g, static_cast<std::size_t>(c.degree + 1), [](const GrainShape& s, std::size_t k) { return s.invariants[static_cast<Eigen::Index>(k)]; }).data(),
          {n, static_cast<hsize_t>(c.degree + 1)}, units("m"));
  const auto sh_scalar = [&](const char* name, auto get) {
    f.write(name, column<double>(g, 1, [&](const GrainShape& s, std::size_t) { return get(s); }), units("1"));
  };
  sh_scalar(ss::rms_error, [](const GrainShape& s) { return s.rms_error; });
  sh_scalar(ss::max_error, [](const GrainShape& s) { return s.max_error; });
  sh_scalar(ss::volume_error, [](const GrainShape& s) { return s.volume_error; });
  f.write(ss::multi_exit_fraction, column<double>(g, 1, [](const GrainShape& s, std::size_t) { return s.multi_exit_fraction; }),
          units("1"));
  f.write(ss::hidden_void_fraction,
          column<double>(g, 1, [](const GrainShape& s, std::size_t) { return s.hidden_void_fraction; }), units("1"));
  f.write(ss::reentry_depth, column<double>(g, 1, [](const GrainShape& s, std::size_t) { return s.reentry_depth; }),
          units("m"));
  f.write(ss::edge_sigma, column<double>(g, 1, [](const GrainShape& s, std::size_t) { return s.edge_sigma; }), units("m"));
  f.write(ss::flags, column<std::uint8_t>(g, 1, [](const GrainShape& s, std::size_t) { return s.flags; }));
  f.set_attr(ss::flags, ss::flag_bits,
             std::string("1 not star-shaped, 2 centroid outside, 4 unreliable fit, 8 touches edge, 16 small, "
                         "32 tolerance not met"));

  f.write(ss::psd_diameter, c.psd.diameter, units("m"));
  f.write(ss::psd_percent_passing, c.psd.percent_passing, units("%"));
  f.write(ss::psd_d50, std::vector<double>{c.psd.d50}, units("m"));
  f.write_strings(ss::parameters, {c.parameters_json});
  io::write_history(f, history);
}

ShapesFile read_shapes_file(const std::filesystem::path& path) {
  const io::H5File f = io::open_kind(path, schema::kind::shapes, "pass the output of labels2shapes");
  ShapesFile c;
  const long long degree_attr = f.attr_int(ss::coeffs, schema::attr::sh_degree).value_or(-1);
  if (degree_attr < 0) throw DataError(path.string() + " has no SH degree on " + ss::coeffs + "; rewrite it with labels2shapes");
  // (degree + 1)^2 coefficients per grain: a damaged attribute must not overflow the count.
  if (degree_attr > kMaxStoredShDegree)
    throw DataError(path.string() + ": " + ss::coeffs + " declares SH degree " + std::to_string(degree_attr) + ", above the " +
                    std::to_string(kMaxStoredShDegree) + " any tool writes; rewrite it with labels2shapes");
  c.degree = static_cast<int>(degree_attr);
  const auto label = f.read<std::uint32_t>(ss::grain_label);
  const std::size_t n = label.size(), ncoef = static_cast<std::size_t>(sh_count(c.degree)), ninv = static_cast<std::size_t>(c.degree + 1);
  const auto need = [&](const char* name, std::size_t k) {
    auto v = f.read<double>(name);
    if (v.size() != n * k)
      throw DataError(path.string() + ": " + name + " has " + std::to_string(v.size()) + " values for " + std::to_string(n) +
                      " grains; rewrite it with labels2shapes");
    // labels2shapes writes finite numbers only: a NaN centroid or coefficient would reach meshes and tracks.
    io::require_finite(f, name, v, k, "rewrite it with labels2shapes");
    return v;
  };
  const auto voxels = f.read<std::uint64_t>(ss::grain_voxels);
  const auto volume = need(ss::grain_volume, 1), centroid = need(ss::grain_centroid, 3), area = need(ss::grain_surface_area, 1),
             deq = need(ss::grain_equivalent_diameter, 1), sph = need(ss::grain_sphericity, 1),
             semi = need(ss::grain_semi_axes, 3), axes = need(ss::grain_axes, 9), ar = need(ss::grain_aspect_ratio, 1),
             el = need(ss::grain_elongation, 1), fl = need(ss::grain_flatness, 1), coeffs = need(ss::coeffs, ncoef),
             inv = need(ss::invariants, ninv), rms = need(ss::rms_error, 1), mx = need(ss::max_error, 1),
             ve = need(ss::volume_error, 1), mef = need(ss::multi_exit_fraction, 1);
  // The star-shape depth and edge measures came later: files written before them read as zeros.
  const auto optional = [&](const char* name) { return f.exists(name) ? need(name, 1) : std::vector<double>(n, 0.0); };
  const auto hidden = optional(ss::hidden_void_fraction), depth = optional(ss::reentry_depth),
             sigma = optional(ss::edge_sigma);
  const auto degree = f.read<std::int32_t>(ss::degree);
  const auto flags = f.read<std::uint8_t>(ss::flags);
  if (voxels.size() != n || degree.size() != n || flags.size() != n)
    throw DataError(path.string() + " has grain columns of different lengths; rewrite it with labels2shapes");
  // Grains are found by label (tracks, meshes, the report): a label twice would make one of them win silently.
  std::vector<std::uint32_t> sorted = label;
  std::sort(sorted.begin(), sorted.end());
  if (!sorted.empty() && sorted[0] == 0)
    throw DataError(path.string() + ": " + ss::grain_label + " holds label 0, which is background; rewrite it with labels2shapes");
  if (const auto twice = std::adjacent_find(sorted.begin(), sorted.end()); twice != sorted.end())
    throw DataError(path.string() + ": " + ss::grain_label + " names grain " + std::to_string(*twice) + " twice; rewrite it with labels2shapes");
  c.grains.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    GrainShape& s = c.grains[i];
    s.label = label[i];
    s.voxels = voxels[i];
    s.volume = volume[i];
    s.centroid = Eigen::Vector3d(centroid[3 * i], centroid[3 * i + 1], centroid[3 * i + 2]);
    s.surface_area = area[i];
    s.equivalent_diameter = deq[i];
    s.sphericity = sph[i];
    s.semi_axes = Eigen::Vector3d(semi[3 * i], semi[3 * i + 1], semi[3 * i + 2]);
    for (int k = 0; k < 9; ++k) s.axes(k % 3, k / 3) = axes[9 * i + static_cast<std::size_t>(k)];
    s.aspect_ratio = ar[i];
    s.elongation = el[i];
    s.flatness = fl[i];
    s.sh_degree = degree[i];
    s.coeffs = Eigen::Map<const Eigen::VectorXd>(coeffs.data() + i * ncoef, static_cast<Eigen::Index>(ncoef));
    s.invariants = Eigen::Map<const Eigen::VectorXd>(inv.data() + i * ninv, static_cast<Eigen::Index>(ninv));
    s.rms_error = rms[i];
    s.max_error = mx[i];
    s.volume_error = ve[i];
    s.multi_exit_fraction = mef[i];
    s.hidden_void_fraction = hidden[i];
    s.reentry_depth = depth[i];
    s.edge_sigma = sigma[i];
    s.flags = flags[i];
  }
  c.psd.diameter = f.read<double>(ss::psd_diameter);
  c.psd.percent_passing = f.read<double>(ss::psd_percent_passing);
  if (c.psd.diameter.size() != c.psd.percent_passing.size())
    throw DataError(path.string() + ": " + ss::psd_diameter + " and " + ss::psd_percent_passing + " differ in length (" + std::to_string(c.psd.diameter.size()) +
                    " and " + std::to_string(c.psd.percent_passing.size()) + "); rewrite it with labels2shapes");
  c.psd.d50 = f.read_scalar<double>(ss::psd_d50);
  c.parameters_json = f.read_string(ss::parameters);
  return c;
}

std::size_t shapes_grain_count(const io::H5File& f) {
  const auto dims = f.info(ss::grain_label).dims;
  return dims.empty() ? 0 : dims[0];
}

}  // namespace graintwin::shape
