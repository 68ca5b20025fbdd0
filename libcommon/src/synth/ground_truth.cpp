#include "graintwin/synth/ground_truth.hpp"

#include <algorithm>
#include <cmath>

#include "graintwin/core/error.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/table_checks.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/shape/sh_basis.hpp"
#include "graintwin/synth/loading.hpp"

namespace graintwin::synth {

namespace sg = schema::ground_truth;

namespace {
// Whether the solid (null: its hull is the grain) holds a point within `depth` of world point
// `point` along unit `inward`.
bool solid_near(const GrainSolid* solid, const PackedGrain& pose, const Eigen::Vector3d& point,
                const Eigen::Vector3d& inward, double depth) {
  if (!solid) return true;
  constexpr int kSamples = 16;
  const Eigen::Matrix3d world_to_body = pose.orientation.normalized().toRotationMatrix().transpose();
  for (int k = 0; k <= kSamples; ++k)
    if (solid->contains(world_to_body * (point + (depth * k / kSamples) * inward - pose.position))) return true;
  return false;
}
}  // namespace

std::vector<TrueContact> true_contacts(const std::vector<const shape::RadialTable*>& shapes,
                                       const std::vector<PackedGrain>& poses, double search_gap, double tolerance,
                                       bool separating, const std::vector<const GrainSolid*>& solids) {
  if (!solids.empty() && solids.size() != shapes.size())
    throw UsageError("true_contacts: give one solid (or null) per grain, or none");
  const std::vector<GrainContact> found = find_contacts(shapes, poses, search_gap);
  std::vector<TrueContact> out(found.size());
  std::vector<std::uint8_t> real(found.size(), 1);
  const double depth = std::max(search_gap, 2.0 * tolerance);
#pragma omp parallel for schedule(dynamic)
  for (std::size_t k = 0; k < found.size(); ++k) {
    const GrainContact& c = found[k];
    const PairContact pc =
        separating ? separating_contact(*shapes[c.a], poses[c.a], *shapes[c.b], poses[c.b], c.contact) : c.contact;
    TrueContact& t = out[k];
    t.low = static_cast<std::uint32_t>(c.a + 1);
    t.high = static_cast<std::uint32_t>(c.b + 1);
    // Each measure overstates in its own failure mode: the kernel's at sharp edges and corners,
    // the separating one where the patches are not convex (a bump in a dent, roughness), whose
    // convex hulls overlap more than the grains. Neither understates, so the smaller is kept;
    // the normal is the separating one (on a rough patch, that of the local hulls' contact plane).
    t.overlap = std::min(c.contact.overlap, pc.overlap);
    t.point = pc.point;
    t.normal = pc.normal;
    t.touching = std::abs(t.overlap) <= tolerance;
    if (!solids.empty())
      real[k] = solid_near(solids[c.a], poses[c.a], t.point, -t.normal, depth) &&
                solid_near(solids[c.b], poses[c.b], t.point, t.normal, depth);
  }
  std::size_t kept = 0;
  for (std::size_t k = 0; k < out.size(); ++k)
    if (real[k]) out[kept++] = out[k];
  out.resize(kept);
  return out;
}

namespace {
// N x k row-major copy of per-grain vectors.
template <class F>
std::vector<double> rows(std::size_t n, int k, F&& get) {
  std::vector<double> out(n * static_cast<std::size_t>(k));
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < k; ++c) out[i * k + c] = get(i, c);
  return out;
}
}  // namespace

void write_ground_truth(const std::filesystem::path& path, const GroundTruth& t,
                        const std::vector<std::string>& history) {
  using io::DatasetOptions;
  auto with_units = [](const char* u) {
    DatasetOptions o;
    o.units = u;
    return o;
  };
  io::H5File f = io::H5File::create(path);
  io::write_root_attrs(f, schema::kind::ground_truth);
  f.set_attr(schema::path::root, sg::scan_index, static_cast<long long>(t.scan_index));
  f.set_attr(schema::path::root, sg::axial_strain, t.axial_strain);
  f.set_attr(schema::path::root, sg::sample_height, t.sample_height);
  f.set_attr(schema::path::root, sg::sample_radius, t.sample_radius);
  f.set_attr(schema::path::root, sg::solid_fraction, t.solid_fraction);
  f.set_attr(schema::path::root, sg::void_ratio, t.void_ratio);
  f.set_attr(schema::path::root, sg::contact_tolerance, t.contact_tolerance);
  io::write_image(f, schema::path::labels, t.labels, "1");

  const std::size_t n = t.poses.size();
  std::vector<std::uint32_t> label(n);
  for (std::size_t i = 0; i < n; ++i) label[i] = static_cast<std::uint32_t>(i + 1);
  f.write(sg::grain_label, label);
  const auto& P = t.poses;
  f.write(sg::grain_centroid, rows(n, 3, [&](std::size_t i, int c) { return P[i].position[c]; }).data(), {n, 3},
          with_units("m"));
  f.write(sg::grain_orientation,
          rows(n, 4, [&](std::size_t i, int c) { return c == 0 ? P[i].orientation.w() : P[i].orientation.vec()[c - 1]; })
              .data(),
          {n, 4}, with_units("1"));
  f.set_attr(sg::grain_orientation, sg::orientation_convention, std::string("unit quaternion (w, x, y, z), body to world"));
  f.write(sg::grain_volume, t.volume, with_units("m^3"));
  f.write(sg::grain_equivalent_diameter, t.equivalent_diameter, with_units("m"));
  f.write(sg::grain_sphericity, t.sphericity, with_units("1"));
  f.write(sg::grain_aspect_ratio, t.aspect_ratio, with_units("1"));
  const hsize_t ncoef = static_cast<hsize_t>(t.sh_coeffs.cols());
  const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> cw = t.sh_coeffs, cb = t.sh_coeffs_body,
                                                                               inv = t.sh_invariants;
  f.write(sg::sh_coeffs, cw.data(), {n, ncoef}, with_units("m"));
  f.write(sg::sh_coeffs_body, cb.data(), {n, ncoef}, with_units("m"));
  f.write(sg::sh_invariants, inv.data(), {n, static_cast<hsize_t>(inv.cols())}, with_units("m"));
  if (!t.non_star.empty()) {
    const auto& ns = t.non_star;
    f.write(sg::grain_multi_exit_fraction,
            rows(n, 1, [&](std::size_t i, int) { return ns[i].multi_exit_fraction; }), with_units("1"));
    f.write(sg::grain_hidden_void_fraction,
            rows(n, 1, [&](std::size_t i, int) { return ns[i].hidden_void_fraction; }), with_units("1"));
    f.write(sg::grain_reentry_depth, rows(n, 1, [&](std::size_t i, int) { return ns[i].reentry_depth; }),
            with_units("m"));
  }
  f.set_attr(sg::sh_coeffs, schema::attr::sh_degree, static_cast<long long>(t.sh_degree));
  f.set_attr(sg::sh_coeffs, schema::attr::sh_basis, std::string(shape::kShBasisDescription));

  const std::size_t m = t.contacts.size();
  std::vector<std::uint32_t> pair(2 * m);
  std::vector<std::uint8_t> touching(m);
  std::vector<double> overlap(m);
  for (std::size_t k = 0; k < m; ++k) {
    pair[2 * k] = t.contacts[k].low;
    pair[2 * k + 1] = t.contacts[k].high;
    touching[k] = t.contacts[k].touching;
    overlap[k] = t.contacts[k].overlap;
  }
  f.write(sg::contact_pair, pair.data(), {m, 2});
  f.write(sg::contact_normal, rows(m, 3, [&](std::size_t k, int c) { return t.contacts[k].normal[c]; }).data(), {m, 3},
          with_units("1"));
  f.write(sg::contact_point, rows(m, 3, [&](std::size_t k, int c) { return t.contacts[k].point[c]; }).data(), {m, 3},
          with_units("m"));
  f.write(sg::contact_overlap, overlap, with_units("m"));
  f.write(sg::contact_touching, touching);
  f.set_attr(schema::path::root, sg::loading, std::string(enum_name(kLoadingKindNames, t.simulated ? LoadingKind::simulated : LoadingKind::prescribed)));
  if (t.simulated) {
    if (t.contact_force.size() != m)
      throw UsageError("write_ground_truth: a simulated state needs one contact force per contact");
    f.write(sg::contact_force, rows(m, 3, [&](std::size_t k, int c) { return t.contact_force[k][c]; }).data(), {m, 3},
            with_units("N"));
    f.set_attr(schema::path::root, sg::stress_ratio, t.stress_ratio);
    f.set_attr(schema::path::root, sg::volumetric_strain, t.volumetric_strain);
    const LoadingCurve& c = t.loading_curve;
    if (c.stress_ratio.size() != c.axial_strain.size() || c.volumetric_strain.size() != c.axial_strain.size())
      throw UsageError("write_ground_truth: the loading curve's columns differ in length");
    f.write(sg::curve_axial_strain, c.axial_strain, with_units("1"));
    f.write(sg::curve_stress_ratio, c.stress_ratio, with_units("1"));
    f.write(sg::curve_volumetric_strain, c.volumetric_strain, with_units("1"));
  }
  io::write_history(f, history);
}

namespace {
constexpr const char* kRewrite = "rewrite the series with ctsynth";

// A float table of `rows` x `width` from `f` (DataError naming it otherwise), every value finite.
std::vector<double> finite_table(const io::H5File& f, const std::string& name, std::size_t rows, std::size_t width) {
  std::vector<hsize_t> dims;
  std::vector<double> v = f.read<double>(name, &dims);
  if (v.size() != rows * width || dims.empty() || dims[0] != rows)
    throw DataError(f.path().string() + ": " + name + " does not hold " + std::to_string(rows) + " rows of " +
                    std::to_string(width) + "; " + kRewrite);
  io::require_finite(f, name, v, width, kRewrite);
  return v;
}
}  // namespace

GroundTruth read_ground_truth(const std::filesystem::path& path) {
  const io::H5File f = io::open_kind(path, schema::kind::ground_truth, "pass a truth_NNN.h5 that ctsynth wrote beside its scan");
  GroundTruth t;
  const std::string root = schema::path::root;
  t.scan_index = static_cast<int>(f.attr_int(root, sg::scan_index).value_or(0));
  t.axial_strain = f.attr_double(root, sg::axial_strain);
  t.sample_height = f.attr_double(root, sg::sample_height);
  t.sample_radius = f.attr_double(root, sg::sample_radius);
  t.solid_fraction = f.attr_double(root, sg::solid_fraction);
  t.void_ratio = f.attr_double(root, sg::void_ratio);
  t.contact_tolerance = f.attr_double(root, sg::contact_tolerance);
  t.labels = io::read_image_as<std::uint32_t>(f, schema::path::labels);

  const std::size_t n = io::table_rows(f, sg::grains, kRewrite);
  const std::vector<std::uint32_t> label = f.read<std::uint32_t>(sg::grain_label);
  for (std::size_t i = 0; i < label.size(); ++i)
    if (label[i] != i + 1)
      throw DataError(path.string() + ": " + sg::grain_label + " must number the grains 1..N in order; " + kRewrite);
  const auto centroid = finite_table(f, sg::grain_centroid, n, 3), orientation = finite_table(f, sg::grain_orientation, n, 4);
  t.poses.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    t.poses[i].position = Eigen::Vector3d(centroid[3 * i], centroid[3 * i + 1], centroid[3 * i + 2]);
    t.poses[i].orientation = Eigen::Quaterniond(orientation[4 * i], orientation[4 * i + 1], orientation[4 * i + 2],
                                                orientation[4 * i + 3]);
  }
  t.volume = finite_table(f, sg::grain_volume, n, 1);
  t.equivalent_diameter = finite_table(f, sg::grain_equivalent_diameter, n, 1);
  t.sphericity = finite_table(f, sg::grain_sphericity, n, 1);
  t.aspect_ratio = finite_table(f, sg::grain_aspect_ratio, n, 1);
  if (f.exists(sg::grain_multi_exit_fraction)) {
    const auto me = finite_table(f, sg::grain_multi_exit_fraction, n, 1), hv = finite_table(f, sg::grain_hidden_void_fraction, n, 1),
               rd = finite_table(f, sg::grain_reentry_depth, n, 1);
    t.non_star.resize(n);
    for (std::size_t i = 0; i < n; ++i) t.non_star[i] = {me[i], hv[i], rd[i]};
  }
  t.sh_degree = static_cast<int>(f.attr_int(sg::sh_coeffs, schema::attr::sh_degree).value_or(-1));
  if (t.sh_degree < 0) throw DataError(path.string() + ": " + sg::sh_coeffs + " has no whole-number degree attribute; " + kRewrite);
  const std::size_t ncoef = static_cast<std::size_t>(t.sh_degree + 1) * (t.sh_degree + 1);
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const auto matrix = [&](const char* name, std::size_t width) {
    const auto v = finite_table(f, name, n, width);
    return Eigen::MatrixXd(Eigen::Map<const RowMajor>(v.data(), Eigen::Index(n), Eigen::Index(width)));
  };
  t.sh_coeffs = matrix(sg::sh_coeffs, ncoef);
  t.sh_coeffs_body = matrix(sg::sh_coeffs_body, ncoef);
  t.sh_invariants = matrix(sg::sh_invariants, static_cast<std::size_t>(t.sh_degree + 1));

  const std::size_t m = io::table_rows(f, sg::contacts, kRewrite);
  const std::vector<std::uint32_t> pair = m ? f.read<std::uint32_t>(sg::contact_pair) : std::vector<std::uint32_t>{};
  const auto normal = finite_table(f, sg::contact_normal, m, 3), point = finite_table(f, sg::contact_point, m, 3),
             overlap = finite_table(f, sg::contact_overlap, m, 1);
  const std::vector<std::uint8_t> touching = m ? f.read<std::uint8_t>(sg::contact_touching) : std::vector<std::uint8_t>{};
  if (pair.size() != 2 * m || touching.size() != m)
    throw DataError(path.string() + ": the /contacts columns differ in length; " + kRewrite);
  t.contacts.resize(m);
  for (std::size_t k = 0; k < m; ++k) {
    TrueContact& c = t.contacts[k];
    c.low = pair[2 * k], c.high = pair[2 * k + 1];
    if (c.low == 0 || c.low >= c.high || c.high > n)
      throw DataError(path.string() + ": " + sg::contact_pair + " row " + std::to_string(k) + " is not two grain labels, low first; " +
                      kRewrite);
    c.overlap = overlap[k];
    c.point = Eigen::Vector3d(point[3 * k], point[3 * k + 1], point[3 * k + 2]);
    c.normal = Eigen::Vector3d(normal[3 * k], normal[3 * k + 1], normal[3 * k + 2]);
    c.touching = touching[k] != 0;
  }
  t.simulated = find_enum(kLoadingKindNames, f.attr_string(root, sg::loading).value_or("")) == LoadingKind::simulated;
  if (t.simulated) {
    const auto force = finite_table(f, sg::contact_force, m, 3);
    t.contact_force.resize(m);
    for (std::size_t k = 0; k < m; ++k) t.contact_force[k] = Eigen::Vector3d(force[3 * k], force[3 * k + 1], force[3 * k + 2]);
    t.stress_ratio = f.attr_double(root, sg::stress_ratio);
    t.volumetric_strain = f.attr_double(root, sg::volumetric_strain);
    const std::size_t k = io::table_rows(f, sg::curve, kRewrite);
    t.loading_curve.axial_strain = finite_table(f, sg::curve_axial_strain, k, 1);
    t.loading_curve.stress_ratio = finite_table(f, sg::curve_stress_ratio, k, 1);
    t.loading_curve.volumetric_strain = finite_table(f, sg::curve_volumetric_strain, k, 1);
  }
  return t;
}

}  // namespace graintwin::synth
