#include "graintwin/segment/labels_file.hpp"

#include <cmath>
#include <limits>

#include "graintwin/core/error.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/table_checks.hpp"
#include "graintwin/io/volume_io.hpp"

namespace graintwin::segment {
using io::units;
namespace sl = schema::labels;

namespace {
constexpr const char* kFix = "rewrite it with ct2labels";
}  // namespace

void write_labels_file(const std::filesystem::path& path, const LabelsFile& c, const std::vector<std::string>& history) {
  io::H5File f = io::H5File::create(path);
  io::write_root_attrs(f, schema::kind::labels);
  io::write_image(f, schema::path::labels, c.labels, "1");

  const std::size_t n = c.grains.size();
  std::vector<std::uint32_t> label(n);
  std::vector<std::uint64_t> voxels(n);
  std::vector<double> volume(n), centroid(3 * n);
  std::vector<std::uint64_t> bbox(6 * n);
  std::vector<std::uint8_t> edge(n);
  for (std::size_t i = 0; i < n; ++i) {
    const GrainRecord& g = c.grains[i];
    label[i] = g.label;
    voxels[i] = g.voxels;
    volume[i] = g.volume_m3;
    for (int k = 0; k < 3; ++k) centroid[3 * i + k] = g.centroid_xyz[k];
    for (int k = 0; k < 6; ++k) bbox[6 * i + k] = g.bbox[k];
    edge[i] = g.touches_edge ? 1 : 0;
  }
  const hsize_t rows = n;
  f.write(sl::grain_label, label);
  f.write(sl::grain_voxels, voxels);
  f.write(sl::grain_volume, volume, units("m^3"));
  f.write(sl::grain_centroid, centroid.data(), {rows, 3}, units("m"));
  f.write(sl::grain_bbox, bbox.data(), {rows, 6}, units("voxel"));
  f.write(sl::grain_touches_edge, edge);

  const Cylinder& r = c.sample.region;
  // HDF5 attributes hold infinities, but pandas/JSON readers choke on them: an unbounded extent is NaN.
  const auto finite_or_nan = [](double v) { return std::isfinite(v) ? v : std::numeric_limits<double>::quiet_NaN(); };
  f.ensure_group(sl::sample);
  f.set_attr(sl::sample, sl::cylinder_centre_xy, std::vector<double>{r.centre_x, r.centre_y});
  f.set_attr(sl::sample, sl::cylinder_radius, finite_or_nan(r.radius));
  f.set_attr(sl::sample, sl::cylinder_z_range, std::vector<double>{finite_or_nan(r.z_min), finite_or_nan(r.z_max)});
  f.write(sl::sample_void_ratio, std::vector<double>{c.sample.void_ratio.e}, units("1"));
  f.write(sl::sample_solid_volume, std::vector<double>{c.sample.void_ratio.solid_m3}, units("m^3"));
  f.write(sl::sample_void_volume, std::vector<double>{c.sample.void_ratio.void_m3}, units("m^3"));
  f.write_strings(sl::parameters, {c.parameters_json});
  io::write_history(f, history);
}

LabelsFile read_labels_file(const std::filesystem::path& path) {
  const io::H5File f = io::open_kind(path, schema::kind::labels, "pass the output of ct2labels");
  LabelsFile c;
  c.labels = io::read_image_as<std::uint32_t>(f, schema::path::labels);
  const auto label = f.read<std::uint32_t>(sl::grain_label);
  const auto voxels = f.read<std::uint64_t>(sl::grain_voxels);
  const auto volume = f.read<double>(sl::grain_volume);
  const auto centroid = f.read<double>(sl::grain_centroid);
  const auto bbox = f.read<std::uint64_t>(sl::grain_bbox);
  const auto edge = f.read<std::uint8_t>(sl::grain_touches_edge);
  const std::size_t n = label.size();
  if (voxels.size() != n || volume.size() != n || centroid.size() != 3 * n || bbox.size() != 6 * n || edge.size() != n)
    throw DataError(path.string() + " has grain table columns of different lengths; rewrite it with ct2labels");
  io::require_finite(f, sl::grain_volume, volume, 1, kFix);
  io::require_finite(f, sl::grain_centroid, centroid, 3, kFix);
  c.grains.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    GrainRecord& g = c.grains[i];
    g.label = label[i];
    g.voxels = voxels[i];
    g.volume_m3 = volume[i];
    for (int k = 0; k < 3; ++k) g.centroid_xyz[k] = centroid[3 * i + k];
    for (int k = 0; k < 6; ++k) g.bbox[k] = bbox[6 * i + k];
    g.touches_edge = edge[i] != 0;
  }
  // Every reader relies on one row per grain of the image (labels2shapes measures the rows,
  // labels2contacts looks centroids up by label): a table that disagrees would drop or misplace grains.
  const std::string mismatch = grain_table_mismatch(c.labels, c.grains);
  if (!mismatch.empty())
    throw DataError("the grain table of " + path.string() + " does not match its label image: " + mismatch +
                    "; rewrite the file with ct2labels");
  Cylinder& r = c.sample.region;
  const auto centre = f.attr_doubles(sl::sample, sl::cylinder_centre_xy);
  const auto radius = f.attr_doubles(sl::sample, sl::cylinder_radius);
  const auto zr = f.attr_doubles(sl::sample, sl::cylinder_z_range);
  const auto nan_to = [](double v, double inf) { return std::isnan(v) ? inf : v; };
  const double inf = std::numeric_limits<double>::infinity();
  if (centre.size() == 2) r.centre_x = centre[0], r.centre_y = centre[1];
  if (radius.size() == 1) r.radius = nan_to(radius[0], inf);
  if (zr.size() == 2) r.z_min = nan_to(zr[0], -inf), r.z_max = nan_to(zr[1], inf);
  c.sample.void_ratio.e = f.read_scalar<double>(sl::sample_void_ratio);
  c.sample.void_ratio.solid_m3 = f.read_scalar<double>(sl::sample_solid_volume);
  c.sample.void_ratio.void_m3 = f.read_scalar<double>(sl::sample_void_volume);
  c.parameters_json = f.read_string(sl::parameters);
  return c;
}

void check_labels_tables(const io::H5File& f) {
  io::table_rows(f, sl::grains, kFix);
  io::require_finite_table(f, sl::grains, {sl::grain_centroid, sl::grain_volume}, kFix);
}

double read_void_ratio(const std::filesystem::path& path) {
  const io::H5File f = io::open_kind(path, schema::kind::labels, "pass the output of ct2labels");
  if (!f.exists(sl::sample_void_ratio)) return std::numeric_limits<double>::quiet_NaN();
  return f.read_scalar<double>(sl::sample_void_ratio);
}

}  // namespace graintwin::segment
