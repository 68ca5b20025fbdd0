#include "graintwin/contacts/contacts_file.hpp"

#include <algorithm>
#include <cmath>

#include "graintwin/core/error.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/table_checks.hpp"
#include "graintwin/io/volume_io.hpp"

namespace graintwin::contacts {

namespace sc = schema::contacts;
using io::units;

namespace {

constexpr const char* kFix = "rewrite it with labels2contacts";

/// Rows of (x, y, z) vectors as an M x 3 array.
std::vector<double> rows3(const std::vector<Vec3>& v) {
  std::vector<double> out;
  out.reserve(3 * v.size());
  for (const Vec3& x : v) out.insert(out.end(), x.begin(), x.end());
  return out;
}

void write_fabric(io::H5File& f, const std::string& group, const Fabric& fab) {
  const std::string g = group + "/";
  std::vector<double> tensor(9), directions(9);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      tensor[3 * i + j] = fab.tensor(i, j);
      directions[3 * i + j] = fab.principal_directions(j, i);  // row i = direction i
    }
  f.write(g + sc::tensor, tensor.data(), {3, 3}, units("1"));
  f.write(g + sc::principal_values, std::vector<double>(fab.principal_values.begin(), fab.principal_values.end()), units("1"));
  f.write(g + sc::principal_directions, directions.data(), {3, 3}, units("1"));
  f.write(g + sc::anisotropy, &fab.anisotropy, {}, units("1"));
  const auto count = static_cast<std::uint64_t>(fab.count);
  f.write(g + sc::count, &count, {});
}

void write_rose(io::H5File& f, const std::string& group, const Rose& r) {
  const std::string g = group + "/";
  const hsize_t nt = r.theta_edges.size() - 1, np = r.phi_edges.size() - 1;
  f.write(g + sc::theta_edges, r.theta_edges, units("rad"));
  f.write(g + sc::phi_edges, r.phi_edges, units("rad"));
  f.write(g + sc::counts, r.counts.data(), {nt, np});
  f.write(g + sc::density, r.density.data(), {nt, np}, units("1/sr"));
}

/// A dataset of exactly `count` values (DataError naming it otherwise).
template <class T>
std::vector<T> read_sized(const io::H5File& f, const std::string& name, std::size_t count) {
  std::vector<T> v = f.read<T>(name);
  if (v.size() != count)
    throw DataError(f.path().string() + ": " + name + " holds " + std::to_string(v.size()) + " values where " +
                    std::to_string(count) + " belong; " + kFix);
  return v;
}

std::vector<Vec3> read_vec3(const io::H5File& f, const std::string& name, std::size_t rows) {
  const auto v = read_sized<double>(f, name, 3 * rows);
  std::vector<Vec3> out(rows);
  for (std::size_t k = 0; k < rows; ++k) out[k] = {v[3 * k], v[3 * k + 1], v[3 * k + 2]};
  return out;
}

Fabric read_fabric(const io::H5File& f, const std::string& group) {
  const std::string g = group + "/";
  Fabric fab;
  const auto tensor = read_sized<double>(f, g + sc::tensor, 9), directions = read_sized<double>(f, g + sc::principal_directions, 9);
  const auto values = read_sized<double>(f, g + sc::principal_values, 3);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      fab.tensor(i, j) = tensor[3 * i + j];
      fab.principal_directions(j, i) = directions[3 * i + j];
    }
  fab.principal_values = {values[0], values[1], values[2]};
  fab.anisotropy = read_sized<double>(f, g + sc::anisotropy, 1)[0];
  fab.count = static_cast<std::size_t>(read_sized<std::uint64_t>(f, g + sc::count, 1)[0]);
  return fab;
}

Rose read_rose(const io::H5File& f, const std::string& group) {
  const std::string g = group + "/";
  Rose r;
  r.theta_edges = f.read<double>(g + sc::theta_edges);
  r.phi_edges = f.read<double>(g + sc::phi_edges);
  if (r.theta_edges.size() < 2 || r.phi_edges.size() < 2)
    throw DataError(f.path().string() + ": the rose " + group + " has fewer than two bin edges in theta or phi; " + kFix);
  const std::size_t bins = (r.theta_edges.size() - 1) * (r.phi_edges.size() - 1);
  std::vector<hsize_t> dims;
  r.counts = f.read<std::uint64_t>(g + sc::counts, &dims);
  if (r.counts.size() != bins)
    throw DataError(f.path().string() + ": the rose " + group + " does not have one count per bin; " + kFix);
  r.density = read_sized<double>(f, g + sc::density, bins);
  return r;
}

double attr_or_nan(const io::H5File& f, const std::string& object, const std::string& name) {
  const auto v = f.attr_doubles(object, name);
  return v.size() == 1 ? v[0] : std::nan("");
}

}  // namespace

ContactsFile contacts_content(const std::vector<Contact>& found, const std::vector<Refinement>& fits,
                              const std::vector<segment::GrainRecord>& grains, const ContactsSettings& settings) {
  const std::size_t m = found.size();
  if (settings.refined && fits.size() != m)
    throw UsageError("contacts_content: " + std::to_string(fits.size()) + " fits for " + std::to_string(m) + " contacts");
  ContactsFile out;
  out.settings = settings;
  ContactTable& t = out.contacts;
  t.pair.resize(2 * m), t.voxels.resize(2 * m), t.radius.resize(2 * m);
  t.normal.resize(m), t.normal_pca.resize(m), t.vector_area.resize(m), t.centroid.resize(m), t.point.resize(m), t.branch.resize(m);
  t.area.resize(m), t.confidence.resize(m), t.gap.resize(m), t.gap_sd.resize(m), t.blur.resize(m), t.fit_rms.resize(m);
  t.fit_status.resize(m), t.accepted.resize(m);
  const Refinement not_fitted;
  std::vector<Contact> counted;
  for (std::size_t k = 0; k < m; ++k) {
    const Contact& c = found[k];
    const Refinement& f = settings.refined ? fits[k] : not_fitted;
    t.pair[2 * k] = c.low, t.pair[2 * k + 1] = c.high;
    t.voxels[2 * k] = c.voxels_low, t.voxels[2 * k + 1] = c.voxels_high;
    t.normal_pca[k] = c.normal;
    t.normal[k] = f.ok() ? f.normal : c.normal;
    t.vector_area[k] = c.vector_area;
    t.area[k] = c.area;
    t.centroid[k] = c.centroid;
    t.point[k] = f.ok() ? f.point : c.centroid;
    t.branch[k] = c.branch;
    t.confidence[k] = f.confidence, t.gap[k] = f.gap, t.gap_sd[k] = f.gap_sd, t.blur[k] = f.blur, t.fit_rms[k] = f.rms;
    t.radius[2 * k] = f.radius[0], t.radius[2 * k + 1] = f.radius[1];
    t.fit_status[k] = settings.refined ? static_cast<std::uint8_t>(f.status) : kFitNotAttempted;
    t.accepted[k] = !(f.confidence < settings.min_confidence);  // unknown (NaN) counts
    if (t.accepted[k]) {
      counted.push_back(c);
      counted.back().normal = t.normal[k];
    }
  }
  for (const auto& g : grains) out.grain_label.push_back(g.label), out.grain_touches_edge.push_back(g.touches_edge);
  out.coordination = coordination(grains, counted, settings.include_edge_grains);
  std::vector<Vec3> normals, branches;
  for (const auto& c : counted) normals.push_back(c.normal), branches.push_back(c.branch);
  out.fabric_normal = fabric_tensor(normals);
  out.fabric_branch = fabric_tensor(branches);
  out.rose_normal = rose(normals, settings.theta_bins, settings.phi_bins);
  out.rose_branch = rose(branches, settings.theta_bins, settings.phi_bins);
  return out;
}

std::size_t accepted_count(const ContactsFile& content) {
  return static_cast<std::size_t>(std::count(content.contacts.accepted.begin(), content.contacts.accepted.end(), 1));
}

ContactNetwork contact_network(const ContactsFile& content, const std::vector<segment::GrainRecord>& grains) {
  const ContactTable& t = content.contacts;
  const auto centroid_of = [&](std::uint32_t label) {
    const auto it = std::lower_bound(grains.begin(), grains.end(), label,
                                     [](const segment::GrainRecord& g, std::uint32_t l) { return g.label < l; });
    if (it == grains.end() || it->label != label)
      throw DataError("contact_network: grain " + std::to_string(label) + " of a contact has no row in the grain table");
    return it->centroid_xyz;
  };
  ContactNetwork net;
  for (std::size_t k = 0; k < t.size(); ++k) {
    const std::uint32_t low = t.pair[2 * k], high = t.pair[2 * k + 1];
    net.pairs.push_back({low, high});
    net.centroids.push_back({centroid_of(low), centroid_of(high)});
  }
  net.points = t.point;
  net.normals = t.normal;
  net.values = {{"area", t.area}, {"confidence", t.confidence}, {"gap", t.gap},
                {"accepted", std::vector<double>(t.accepted.begin(), t.accepted.end())}};
  return net;
}

void write_contacts_file(const std::filesystem::path& path, const ContactsFile& c, const std::vector<std::string>& history) {
  const ContactTable& t = c.contacts;
  io::H5File f = io::H5File::create(path);
  io::write_root_attrs(f, schema::kind::contacts);
  // Each column with its own rows: the table is written as it is (a damaged one, as tests make, is
  // refused by the reader), never read past a shorter column.
  const auto rows = [](const auto& column, std::size_t per_row) { return static_cast<hsize_t>(column.size() / per_row); };
  f.write(sc::pair, t.pair.data(), {rows(t.pair, 2), 2});
  f.write(sc::normal, rows3(t.normal).data(), {rows(t.normal, 1), 3}, units("1"));
  f.write(sc::normal_pca, rows3(t.normal_pca).data(), {rows(t.normal_pca, 1), 3}, units("1"));
  f.write(sc::vector_area, rows3(t.vector_area).data(), {rows(t.vector_area, 1), 3}, units("m^2"));
  f.write(sc::area, t.area, units("m^2"));
  f.write(sc::centroid, rows3(t.centroid).data(), {rows(t.centroid, 1), 3}, units("m"));
  f.write(sc::point, rows3(t.point).data(), {rows(t.point, 1), 3}, units("m"));
  f.write(sc::branch, rows3(t.branch).data(), {rows(t.branch, 1), 3}, units("m"));
  f.write(sc::voxels, t.voxels.data(), {rows(t.voxels, 2), 2});
  f.write(sc::confidence, t.confidence, units("1"));
  f.write(sc::gap, t.gap, units("m"));
  f.write(sc::gap_sd, t.gap_sd, units("m"));
  f.write(sc::radius, t.radius.data(), {rows(t.radius, 2), 2}, units("m"));
  f.write(sc::blur, t.blur, units("m"));
  f.write(sc::fit_rms, t.fit_rms, units("1"));
  f.write(sc::fit_status, t.fit_status);
  f.set_attr(sc::fit_status, sc::codes, std::string(kFitStatusCodes));
  f.write(sc::accepted, t.accepted);
  const ContactsSettings& s = c.settings;
  f.set_attr(sc::group, sc::min_voxels, static_cast<long long>(s.min_voxels));
  f.set_attr(sc::group, sc::refined, static_cast<long long>(s.refined));
  f.set_attr(sc::group, sc::window_vox, s.window_vox);
  f.set_attr(sc::group, sc::gap_tolerance_vox, s.gap_tolerance_vox);
  f.set_attr(sc::group, sc::min_confidence, s.min_confidence);

  f.write(sc::grain_label, c.grain_label);
  f.write(sc::grain_coordination, c.coordination.per_grain);
  f.write(sc::grain_touches_edge, c.grain_touches_edge);
  std::vector<std::uint32_t> zs(c.coordination.histogram.size());
  for (std::size_t i = 0; i < zs.size(); ++i) zs[i] = static_cast<std::uint32_t>(i);
  f.write(sc::coordination_z, zs);
  f.write(sc::coordination_count, c.coordination.histogram);
  f.set_attr(sc::coordination, sc::coordination_mean, c.coordination.mean);
  f.set_attr(sc::coordination, sc::grains_counted, static_cast<long long>(c.coordination.counted));
  f.set_attr(sc::coordination, sc::include_edge_grains, static_cast<long long>(s.include_edge_grains));
  write_fabric(f, sc::fabric_normal, c.fabric_normal);
  write_fabric(f, sc::fabric_branch, c.fabric_branch);
  write_rose(f, sc::rose_normal, c.rose_normal);
  write_rose(f, sc::rose_branch, c.rose_branch);
  io::write_history(f, history);
}

void check_contacts_tables(const io::H5File& f) {
  for (const char* table : {sc::group, sc::grains, sc::coordination}) io::table_rows(f, table, kFix);
  // NaN is the fit columns' "not measured"; the geometry of a contact is always measured.
  io::require_finite_table(f, sc::group, {sc::normal, sc::normal_pca, sc::branch, sc::point, sc::centroid, sc::area, sc::vector_area}, kFix);
}

ContactsFile read_contacts_file(const std::filesystem::path& path) {
  const io::H5File f = io::open_kind(path, schema::kind::contacts, "pass the output of labels2contacts");
  check_contacts_tables(f);
  ContactsFile c;
  ContactTable& t = c.contacts;
  std::vector<hsize_t> dims;
  t.pair = f.read<std::uint32_t>(sc::pair, &dims);
  if (dims.size() != 2 || dims[1] != 2)
    throw DataError(path.string() + ": " + sc::pair + " is not a table of (low, high) label pairs; " + kFix);
  const std::size_t m = dims[0];
  t.voxels = read_sized<std::uint64_t>(f, sc::voxels, 2 * m);
  t.normal = read_vec3(f, sc::normal, m);
  t.normal_pca = read_vec3(f, sc::normal_pca, m);
  t.vector_area = read_vec3(f, sc::vector_area, m);
  t.area = read_sized<double>(f, sc::area, m);
  t.centroid = read_vec3(f, sc::centroid, m);
  t.point = read_vec3(f, sc::point, m);
  t.branch = read_vec3(f, sc::branch, m);
  t.confidence = read_sized<double>(f, sc::confidence, m);
  t.gap = read_sized<double>(f, sc::gap, m);
  t.gap_sd = read_sized<double>(f, sc::gap_sd, m);
  t.radius = read_sized<double>(f, sc::radius, 2 * m);
  t.blur = read_sized<double>(f, sc::blur, m);
  t.fit_rms = read_sized<double>(f, sc::fit_rms, m);
  t.fit_status = read_sized<std::uint8_t>(f, sc::fit_status, m);
  t.accepted = read_sized<std::uint8_t>(f, sc::accepted, m);
  ContactsSettings& s = c.settings;
  s.min_voxels = static_cast<std::uint64_t>(f.attr_int(sc::group, sc::min_voxels).value_or(0));
  s.refined = f.attr_int(sc::group, sc::refined).value_or(0) != 0;
  s.window_vox = attr_or_nan(f, sc::group, sc::window_vox);
  s.gap_tolerance_vox = attr_or_nan(f, sc::group, sc::gap_tolerance_vox);
  s.min_confidence = attr_or_nan(f, sc::group, sc::min_confidence);
  s.include_edge_grains = f.attr_int(sc::coordination, sc::include_edge_grains).value_or(0) != 0;

  c.grain_label = f.read<std::uint32_t>(sc::grain_label);
  const std::size_t n = c.grain_label.size();
  c.coordination.per_grain = read_sized<std::uint32_t>(f, sc::grain_coordination, n);
  c.grain_touches_edge = read_sized<std::uint8_t>(f, sc::grain_touches_edge, n);
  c.coordination.histogram = f.read<std::uint64_t>(sc::coordination_count);
  c.coordination.mean = attr_or_nan(f, sc::coordination, sc::coordination_mean);
  c.coordination.counted = static_cast<std::size_t>(f.attr_int(sc::coordination, sc::grains_counted).value_or(0));
  c.fabric_normal = read_fabric(f, sc::fabric_normal);
  c.fabric_branch = read_fabric(f, sc::fabric_branch);
  c.rose_normal = read_rose(f, sc::rose_normal);
  c.rose_branch = read_rose(f, sc::rose_branch);
  s.theta_bins = static_cast<int>(c.rose_normal.theta_edges.size() - 1);
  s.phi_bins = static_cast<int>(c.rose_normal.phi_edges.size() - 1);
  return c;
}

}  // namespace graintwin::contacts
