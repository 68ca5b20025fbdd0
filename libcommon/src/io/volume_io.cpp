#include "graintwin/io/volume_io.hpp"

#include "graintwin/core/error.hpp"
#include "graintwin/core/strings.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/version.hpp"

namespace graintwin::io {

void write_root_attrs(H5File& file, const std::string& kind) {
  file.set_attr(schema::path::root, schema::attr::kind, kind);
  file.set_attr(schema::path::root, schema::attr::schema_version, static_cast<long long>(schema::version));
  file.set_attr(schema::path::root, schema::attr::creator, std::string("graintwin ") + graintwin::version);
}

std::string file_kind(const H5File& file) {
  return file.attr_string(schema::path::root, schema::attr::kind).value_or("");
}

H5File open_kind(const std::filesystem::path& path, const std::string& kind, const std::string& hint) {
  H5File f = H5File::open(path);
  const std::string found = file_kind(f);
  const std::string tail = hint.empty() ? "" : "; " + hint;
  if (found.empty())
    throw UsageError(path.string() + " is an HDF5 file without a GrainTwin 'kind' attribute, expected kind=" +
                     kind + (hint.empty() ? "; import foreign images with volconvert" : tail));
  if (found != kind)
    throw UsageError(path.string() + " holds kind=" + excerpt(found) + ", expected kind=" + kind + tail);
  const auto v = f.attr_int(schema::path::root, schema::attr::schema_version);
  if (!v)
    throw UsageError(path.string() + " has no schema_version attribute; rewrite it with the current tools");
  if (*v > schema::version || *v < 1)
    throw UsageError(path.string() + " has schema_version " + std::to_string(*v) + ", this build reads up to " +
                     std::to_string(schema::version) + "; update GrainTwin or regenerate the file");
  return f;
}

template <class T>
void write_image(H5File& file, const std::string& path, const Volume<T>& v, const std::string& units) {
  DatasetOptions opt;
  opt.units = units;
  file.write(path, v.data(), {v.nz(), v.ny(), v.nx()}, opt);
  file.set_attr(path, schema::attr::axis_order, std::string("zyx"));
  const Vec3& vs = v.voxel_size();
  const Vec3& o = v.origin();
  file.set_attr(path, schema::attr::voxel_size, std::vector<double>{vs[0], vs[1], vs[2]});
  file.set_attr(path, schema::attr::origin, std::vector<double>{o[0], o[1], o[2]});
}

void write_image(H5File& file, const std::string& path, const AnyVolume& v, const std::string& units) {
  std::visit([&](const auto& vol) { write_image(file, path, vol, units); }, v);
}

ImageHeader read_image_header(const H5File& file, const std::string& path) {
  if (!file.exists(path))
    throw UsageError(file.path().string() + " has no dataset " + path + "; is it the right file?");
  const DatasetInfo di = file.info(path);
  if (di.dims.size() != 3)
    throw DataError(file.path().string() + ":" + path + " is not a 3-D image (rank " +
                    std::to_string(di.dims.size()) + ")");
  ImageHeader h;
  h.shape = {di.dims[0], di.dims[1], di.dims[2]};
  const std::optional<DType> dtype = dtype_named(di.dtype);  // HDF5 element types go by the same names
  if (!dtype)
    throw DataError(file.path().string() + ":" + path + " has element type " + di.dtype +
                    "; volumes must be uint8, uint16, uint32 or float32");
  h.dtype = *dtype;
  const auto order = file.attr_string(path, schema::attr::axis_order).value_or("zyx");
  if (order != "zyx")
    throw DataError(file.path().string() + ":" + path + " has axis_order '" + excerpt(order) + "', expected 'zyx'");
  const auto vs = file.attr_doubles(path, schema::attr::voxel_size);
  if (vs.size() == 3) h.voxel_size = {vs[0], vs[1], vs[2]};
  const auto o = file.attr_doubles(path, schema::attr::origin);
  if (o.size() == 3) h.origin = {o[0], o[1], o[2]};
  h.units = file.attr_string(path, schema::attr::units).value_or("");
  for (double s : h.voxel_size)
    if (!(s > 0.0))
      throw DataError(file.path().string() + ":" + path + " has a non-positive voxel_size; fix it with volconvert --voxel-size");
  return h;
}

template <class T>
Volume<T> read_image_as(const H5File& file, const std::string& path) {
  const ImageHeader h = read_image_header(file, path);
  Volume<T> v(h.shape, h.voxel_size, h.origin);
  if (v.size() > 0) file.read_box(path, {0, 0, 0}, {h.shape[0], h.shape[1], h.shape[2]}, v.data());
  return v;
}

AnyVolume read_image(const H5File& file, const std::string& path) {
  switch (read_image_header(file, path).dtype) {
    case DType::uint8: return read_image_as<std::uint8_t>(file, path);
    case DType::uint16: return read_image_as<std::uint16_t>(file, path);
    case DType::uint32: return read_image_as<std::uint32_t>(file, path);
    case DType::float32: return read_image_as<float>(file, path);
  }
  throw DataError("unreachable");
}

void write_volume_file(const std::filesystem::path& path, const AnyVolume& v,
                       const std::vector<std::string>& history, const std::string& units) {
  H5File f = H5File::create(path);
  write_root_attrs(f, schema::kind::volume);
  write_image(f, schema::path::volume, v, units);
  write_history(f, history);
}

AnyVolume read_volume_file(const std::filesystem::path& path) {
  const H5File f = open_kind(path, schema::kind::volume, "pass a CT volume (import it with volconvert)");
  return read_image(f, schema::path::volume);
}

#define GRAINTWIN_VIO_INSTANTIATE(T)                                                              \
  template void write_image<T>(H5File&, const std::string&, const Volume<T>&, const std::string&); \
  template Volume<T> read_image_as<T>(const H5File&, const std::string&);
GRAINTWIN_VIO_INSTANTIATE(std::uint8_t)
GRAINTWIN_VIO_INSTANTIATE(std::uint16_t)
GRAINTWIN_VIO_INSTANTIATE(std::uint32_t)
GRAINTWIN_VIO_INSTANTIATE(float)
#undef GRAINTWIN_VIO_INSTANTIATE

}  // namespace graintwin::io
