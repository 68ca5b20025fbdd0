#include "graintwin/io/h5file.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include <fmt/format.h>

#include "graintwin/core/error.hpp"
#include "graintwin/core/strings.hpp"
#include "graintwin/io/schema.hpp"

namespace graintwin::io {

namespace {

// HDF5 prints its error stack to stderr by default; we turn failures into exceptions instead.
struct SilenceHdf5 {
  SilenceHdf5() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }
} silence_hdf5;

herr_t collect_error(unsigned n, const H5E_error2_t* err, void* out) {
  auto* s = static_cast<std::string*>(out);
  if (n == 0 && err->desc) *s = err->desc;  // innermost: the most specific cause
  return 0;
}

std::string hdf5_detail() {
  std::string detail;
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_DOWNWARD, collect_error, &detail);
  H5Eclear2(H5E_DEFAULT);
  return detail.empty() ? "" : " (" + detail + ")";
}

template <class T>
hid_t native_type();
template <> hid_t native_type<std::uint8_t>() { return H5T_NATIVE_UINT8; }
template <> hid_t native_type<std::int8_t>() { return H5T_NATIVE_INT8; }
template <> hid_t native_type<std::uint16_t>() { return H5T_NATIVE_UINT16; }
template <> hid_t native_type<std::int16_t>() { return H5T_NATIVE_INT16; }
template <> hid_t native_type<std::uint32_t>() { return H5T_NATIVE_UINT32; }
template <> hid_t native_type<std::int32_t>() { return H5T_NATIVE_INT32; }
template <> hid_t native_type<std::uint64_t>() { return H5T_NATIVE_UINT64; }
template <> hid_t native_type<std::int64_t>() { return H5T_NATIVE_INT64; }
template <> hid_t native_type<float>() { return H5T_NATIVE_FLOAT; }
template <> hid_t native_type<double>() { return H5T_NATIVE_DOUBLE; }

H5Id string_type() {
  H5Id t(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(t.get(), H5T_VARIABLE);
  H5Tset_cset(t.get(), H5T_CSET_UTF8);
  return t;
}

std::vector<hsize_t> auto_chunk(const std::vector<hsize_t>& dims, std::size_t elem_bytes) {
  // About 256 KiB per chunk: large enough for gzip, small enough for partial reads.
  const hsize_t target = std::max<hsize_t>(1, (256 * 1024) / elem_bytes);
  std::vector<hsize_t> chunk(dims.size(), 1);
  if (dims.size() == 3) {
    chunk = {std::min<hsize_t>(dims[0], 16), std::min<hsize_t>(dims[1], 64),
             std::min<hsize_t>(dims[2], 256)};
  } else {
    hsize_t inner = 1;
    for (std::size_t i = 1; i < dims.size(); ++i) {
      chunk[i] = dims[i];
      inner *= dims[i];
    }
    chunk[0] = std::clamp<hsize_t>(target / std::max<hsize_t>(inner, 1), 1, dims[0]);
  }
  for (std::size_t i = 0; i < dims.size(); ++i) chunk[i] = std::max<hsize_t>(1, std::min(chunk[i], dims[i]));
  return chunk;
}

std::string parent_of(const std::string& path) {
  const auto pos = path.find_last_of('/');
  if (pos == std::string::npos || pos == 0) return "/";
  return path.substr(0, pos);
}

}  // namespace

H5Id& H5Id::operator=(H5Id&& o) noexcept {
  if (this != &o) {
    if (id_ >= 0 && close_) close_(id_);
    id_ = o.id_;
    close_ = o.close_;
    o.id_ = -1;
  }
  return *this;
}

H5Id::~H5Id() {
  if (id_ >= 0 && close_) close_(id_);
}

H5File H5File::create(const std::filesystem::path& path) {
  H5Id fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  H5Pset_fclose_degree(fapl.get(), H5F_CLOSE_STRONG);
  hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.get());
  if (f < 0) throw DataError(path.string() + ": cannot create HDF5 file" + hdf5_detail() + "; check that the folder exists and is writable");
  return H5File(path, H5Id(f, H5Fclose));
}

H5File H5File::open(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec))
    throw UsageError(path.string() + ": no such file; check the path");
  if (std::filesystem::is_directory(path, ec))
    throw UsageError(path.string() + " is a folder, not an HDF5 file; pass a .h5 file");
  const htri_t is = H5Fis_hdf5(path.c_str());
  H5Eclear2(H5E_DEFAULT);
  if (is <= 0)
    throw UsageError(path.string() + " is not an HDF5 file; convert images with volconvert first");
  H5Id fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  H5Pset_fclose_degree(fapl.get(), H5F_CLOSE_STRONG);
  hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, fapl.get());
  if (f < 0) throw DataError(path.string() + ": cannot open HDF5 file" + hdf5_detail() + "; the file may be truncated or damaged");
  return H5File(path, H5Id(f, H5Fclose));
}

std::string H5File::where(const std::string& object) const { return path_.string() + ":" + object; }

bool H5File::exists(const std::string& object) const {
  if (object == "/" || object.empty()) return true;
  // Check every level so that a missing parent group is not an error.
  std::string partial;
  for (const auto& part : split(object, '/')) {
    if (part.empty()) continue;
    partial += "/" + part;
    const htri_t e = H5Lexists(file_.get(), partial.c_str(), H5P_DEFAULT);
    if (e <= 0) {
      H5Eclear2(H5E_DEFAULT);
      return false;
    }
  }
  return true;
}

bool H5File::is_group(const std::string& object) const {
  if (!exists(object)) return false;
  H5O_info_t info;
  if (H5Oget_info_by_name(file_.get(), object.c_str(), &info, H5P_DEFAULT) < 0) {
    H5Eclear2(H5E_DEFAULT);
    return false;
  }
  return info.type == H5O_TYPE_GROUP;
}

std::vector<std::string> H5File::list(const std::string& group) const {
  std::vector<std::string> names;
  H5Id g(H5Gopen2(file_.get(), group.c_str(), H5P_DEFAULT), H5Gclose);
  if (!g.valid()) throw DataError(where(group) + ": no such group" + hdf5_detail());
  H5Literate(
      g.get(), H5_INDEX_NAME, H5_ITER_INC, nullptr,
      [](hid_t, const char* name, const H5L_info_t*, void* out) -> herr_t {
        static_cast<std::vector<std::string>*>(out)->push_back(name);
        return 0;
      },
      &names);
  std::sort(names.begin(), names.end());
  return names;
}

void H5File::ensure_group(const std::string& group) {
  std::string partial;
  for (std::size_t i = 1; i <= group.size(); ++i) {
    if (i == group.size() || group[i] == '/') {
      partial = group.substr(0, i);
      if (partial.empty() || partial == "/") continue;
      if (!exists(partial)) {
        H5Id gcpl(H5Pcreate(H5P_GROUP_CREATE), H5Pclose);
        H5Pset_obj_track_times(gcpl.get(), false);
        H5Id g(H5Gcreate2(file_.get(), partial.c_str(), H5P_DEFAULT, gcpl.get(), H5P_DEFAULT), H5Gclose);
        if (!g.valid()) throw DataError(where(partial) + ": cannot create group" + hdf5_detail());
      }
    }
  }
}

namespace {
void write_attr_raw(hid_t file, const std::string& obj, const std::string& name, hid_t type,
                    hid_t space, const void* data, const std::string& where) {
  if (H5Aexists_by_name(file, obj.c_str(), name.c_str(), H5P_DEFAULT) > 0)
    H5Adelete_by_name(file, obj.c_str(), name.c_str(), H5P_DEFAULT);
  H5Id a(H5Acreate_by_name(file, obj.c_str(), name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!a.valid() || H5Awrite(a.get(), type, data) < 0)
    throw DataError(where + ": cannot write attribute '" + name + "'" + hdf5_detail());
}
}  // namespace

void H5File::set_attr(const std::string& object, const std::string& name, const std::string& value) {
  H5Id t = string_type();
  H5Id s(H5Screate(H5S_SCALAR), H5Sclose);
  const char* p = value.c_str();
  write_attr_raw(file_.get(), object, name, t.get(), s.get(), &p, where(object));
}

void H5File::set_attr(const std::string& object, const std::string& name, long long value) {
  H5Id s(H5Screate(H5S_SCALAR), H5Sclose);
  const std::int64_t v = value;
  write_attr_raw(file_.get(), object, name, H5T_NATIVE_INT64, s.get(), &v, where(object));
}

void H5File::set_attr(const std::string& object, const std::string& name, double value) {
  H5Id s(H5Screate(H5S_SCALAR), H5Sclose);
  write_attr_raw(file_.get(), object, name, H5T_NATIVE_DOUBLE, s.get(), &value, where(object));
}

void H5File::set_attr(const std::string& object, const std::string& name, const std::vector<double>& values) {
  const hsize_t n = values.size();
  H5Id s(H5Screate_simple(1, &n, nullptr), H5Sclose);
  write_attr_raw(file_.get(), object, name, H5T_NATIVE_DOUBLE, s.get(), values.data(), where(object));
}

bool H5File::has_attr(const std::string& object, const std::string& name) const {
  if (!exists(object)) return false;
  const htri_t e = H5Aexists_by_name(file_.get(), object.c_str(), name.c_str(), H5P_DEFAULT);
  H5Eclear2(H5E_DEFAULT);
  return e > 0;
}

std::optional<std::string> H5File::attr_string(const std::string& object, const std::string& name) const {
  if (!has_attr(object, name)) return std::nullopt;
  H5Id a(H5Aopen_by_name(file_.get(), object.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  H5Id ft(H5Aget_type(a.get()), H5Tclose);
  if (H5Tget_class(ft.get()) != H5T_STRING) return std::nullopt;
  // H5Aread writes every element: an array of strings would overrun the one string read here.
  H5Id sp(H5Aget_space(a.get()), H5Sclose);
  const hssize_t count = H5Sget_simple_extent_npoints(sp.get());
  if (count != 1)
    throw DataError(fmt::format("{}: attribute '{}' holds {} strings where one is expected; the file is damaged, "
                                "rewrite it with the tool that made it", where(object), name, count));
  if (H5Tis_variable_str(ft.get()) > 0) {
    H5Id t = string_type();
    char* p = nullptr;
    if (H5Aread(a.get(), t.get(), &p) < 0) throw DataError(where(object) + ": cannot read attribute '" + name + "'" + hdf5_detail());
    std::string s = p ? p : "";
    H5free_memory(p);
    return s;
  }
  const std::size_t n = H5Tget_size(ft.get());
  std::string s(n, '\0');
  H5Id t(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(t.get(), n);
  if (H5Aread(a.get(), t.get(), s.data()) < 0) throw DataError(where(object) + ": cannot read attribute '" + name + "'" + hdf5_detail());
  s.erase(std::find(s.begin(), s.end(), '\0'), s.end());
  return s;
}

std::vector<double> H5File::attr_doubles(const std::string& object, const std::string& name) const {
  if (!has_attr(object, name)) return {};
  H5Id a(H5Aopen_by_name(file_.get(), object.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  H5Id ft(H5Aget_type(a.get()), H5Tclose);
  const H5T_class_t c = H5Tget_class(ft.get());
  if (c != H5T_INTEGER && c != H5T_FLOAT) return {};
  H5Id sp(H5Aget_space(a.get()), H5Sclose);
  const hssize_t n = H5Sget_simple_extent_npoints(sp.get());
  std::vector<double> v(static_cast<std::size_t>(std::max<hssize_t>(n, 0)));
  if (!v.empty() && H5Aread(a.get(), H5T_NATIVE_DOUBLE, v.data()) < 0)
    throw DataError(where(object) + ": cannot read attribute '" + name + "'" + hdf5_detail());
  return v;
}

std::optional<long long> H5File::attr_int(const std::string& object, const std::string& name) const {
  const auto v = attr_doubles(object, name);
  if (v.size() != 1) return std::nullopt;
  // Casting NaN or a value beyond long long is undefined behaviour; a fraction is not a count either.
  if (!(v[0] >= -9.2e18 && v[0] <= 9.2e18) || v[0] != std::floor(v[0]))
    throw DataError(fmt::format("{}: attribute '{}' is {:g}, not a whole number; the file is damaged, rewrite it with the tool that made it",
                                where(object), name, v[0]));
  return static_cast<long long>(v[0]);
}

double H5File::attr_double(const std::string& object, const std::string& name) const {
  const auto v = attr_doubles(object, name);
  if (v.size() != 1)
    throw DataError(where(object) + ": attribute '" + name + "' is missing or not one number; the file is damaged, rewrite it with the tool that made it");
  return v[0];
}

template <class T>
void H5File::write(const std::string& path, const T* data, const std::vector<hsize_t>& dims,
                   const DatasetOptions& opt) {
  ensure_group(parent_of(path));
  if (exists(path)) H5Ldelete(file_.get(), path.c_str(), H5P_DEFAULT);
  H5Id space(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr), H5Sclose);
  H5Id dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  H5Pset_obj_track_times(dcpl.get(), false);  // same data, same bytes: no modification times
  const hsize_t n = std::accumulate(dims.begin(), dims.end(), hsize_t{1}, std::multiplies<>());
  if (opt.compress && n >= 1024 && H5Zfilter_avail(H5Z_FILTER_DEFLATE) > 0) {
    const auto chunk = opt.chunk.empty() ? auto_chunk(dims, sizeof(T)) : opt.chunk;
    H5Pset_chunk(dcpl.get(), static_cast<int>(chunk.size()), chunk.data());
    H5Pset_shuffle(dcpl.get());
    H5Pset_deflate(dcpl.get(), static_cast<unsigned>(opt.gzip_level));
  }
  H5Id ds(H5Dcreate2(file_.get(), path.c_str(), native_type<T>(), space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT), H5Dclose);
  if (!ds.valid()) throw DataError(where(path) + ": cannot create dataset" + hdf5_detail());
  if (n > 0 && H5Dwrite(ds.get(), native_type<T>(), H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
    throw DataError(where(path) + ": cannot write dataset" + hdf5_detail() + "; is the disk full?");
  if (!opt.units.empty()) set_attr(path, schema::attr::units, opt.units);
}

void H5File::write_strings(const std::string& path, const std::vector<std::string>& lines) {
  ensure_group(parent_of(path));
  if (exists(path)) H5Ldelete(file_.get(), path.c_str(), H5P_DEFAULT);
  const hsize_t n = lines.size();
  H5Id space(H5Screate_simple(1, &n, nullptr), H5Sclose);
  H5Id t = string_type();
  H5Id dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  H5Pset_obj_track_times(dcpl.get(), false);
  H5Id ds(H5Dcreate2(file_.get(), path.c_str(), t.get(), space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT), H5Dclose);
  if (!ds.valid()) throw DataError(where(path) + ": cannot create dataset" + hdf5_detail());
  std::vector<const char*> ptrs;
  for (const auto& l : lines) ptrs.push_back(l.c_str());
  if (n > 0 && H5Dwrite(ds.get(), t.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, ptrs.data()) < 0)
    throw DataError(where(path) + ": cannot write strings" + hdf5_detail());
}

DatasetInfo H5File::info(const std::string& path) const {
  if (!exists(path)) throw DataError(where(path) + ": no such dataset");
  H5Id ds(H5Dopen2(file_.get(), path.c_str(), H5P_DEFAULT), H5Dclose);
  if (!ds.valid()) throw DataError(where(path) + ": not a dataset" + hdf5_detail());
  H5Id sp(H5Dget_space(ds.get()), H5Sclose);
  DatasetInfo out;
  const int rank = H5Sget_simple_extent_ndims(sp.get());
  out.dims.resize(static_cast<std::size_t>(std::max(rank, 0)));
  if (rank > 0) H5Sget_simple_extent_dims(sp.get(), out.dims.data(), nullptr);
  H5Id t(H5Dget_type(ds.get()), H5Tclose);
  const std::size_t size = H5Tget_size(t.get());
  switch (H5Tget_class(t.get())) {
    case H5T_INTEGER:
      out.dtype = std::string(H5Tget_sign(t.get()) == H5T_SGN_NONE ? "uint" : "int") + std::to_string(size * 8);
      break;
    case H5T_FLOAT: out.dtype = "float" + std::to_string(size * 8); break;
    case H5T_STRING: out.dtype = "string"; break;
    default: out.dtype = "other"; break;
  }
  // HDF5 keeps a dataset's extent apart from its data: a chunked dataset may declare 2^60 values
  // and store none (chunks are allocated as they are written, reads return the fill value), and
  // readers allocate the declared extent. Compression (deflate at most ~1032:1) aside, a dataset
  // stores what it declares, so a declared size beyond 2048 times the stored bytes (above 1 MiB, so
  // small unwritten datasets still read as their fill value) is damage, not data.
  double elements = 1.0;
  bool overflow = false;
  hsize_t count = 1;
  for (hsize_t d : out.dims) {
    elements *= static_cast<double>(d);
    if (d != 0 && count > std::numeric_limits<hsize_t>::max() / d) overflow = true;
    count *= d;
  }
  const double bytes = elements * static_cast<double>(size);
  const double stored = static_cast<double>(H5Dget_storage_size(ds.get()));
  if ((overflow && count != 0) || (bytes > 1024.0 * 1024.0 && bytes > 2048.0 * stored)) {
    std::string shape;
    for (hsize_t d : out.dims) shape += (shape.empty() ? "" : " x ") + std::to_string(d);
    throw DataError(fmt::format("{}: the dataset declares {} values ({:.3g} bytes) but the file stores {:g} bytes of it; "
                                "the file is truncated or damaged, rewrite it with the tool that made it",
                                where(path), shape, bytes, stored));
  }
  return out;
}

template <class T>
std::vector<T> H5File::read(const std::string& path, std::vector<hsize_t>* dims) const {
  const DatasetInfo di = info(path);
  const hsize_t n = std::accumulate(di.dims.begin(), di.dims.end(), hsize_t{1}, std::multiplies<>());
  std::vector<T> out(n);
  H5Id ds(H5Dopen2(file_.get(), path.c_str(), H5P_DEFAULT), H5Dclose);
  if (n > 0 && H5Dread(ds.get(), native_type<T>(), H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0)
    throw DataError(where(path) + ": cannot read dataset" + hdf5_detail() + "; the file may be truncated or damaged");
  if (dims) *dims = di.dims;
  return out;
}

template <class T>
void H5File::read_box(const std::string& path, const std::vector<hsize_t>& offset,
                      const std::vector<hsize_t>& count, T* out) const {
  H5Id ds(H5Dopen2(file_.get(), path.c_str(), H5P_DEFAULT), H5Dclose);
  if (!ds.valid()) throw DataError(where(path) + ": no such dataset" + hdf5_detail());
  H5Id fs(H5Dget_space(ds.get()), H5Sclose);
  if (H5Sselect_hyperslab(fs.get(), H5S_SELECT_SET, offset.data(), nullptr, count.data(), nullptr) < 0)
    throw DataError(where(path) + ": box outside the dataset" + hdf5_detail());
  H5Id ms(H5Screate_simple(static_cast<int>(count.size()), count.data(), nullptr), H5Sclose);
  if (H5Dread(ds.get(), native_type<T>(), ms.get(), fs.get(), H5P_DEFAULT, out) < 0)
    throw DataError(where(path) + ": cannot read dataset" + hdf5_detail() + "; the file may be truncated or damaged");
}

std::vector<std::string> H5File::read_strings(const std::string& path) const {
  const DatasetInfo di = info(path);
  if (di.dtype != "string" || di.dims.size() != 1)
    throw DataError(where(path) + ": expected a 1-D string dataset");
  H5Id ds(H5Dopen2(file_.get(), path.c_str(), H5P_DEFAULT), H5Dclose);
  H5Id ft(H5Dget_type(ds.get()), H5Tclose);
  std::vector<std::string> lines;
  const std::size_t n = di.dims[0];
  if (n == 0) return lines;
  if (H5Tis_variable_str(ft.get()) > 0) {
    H5Id t = string_type();
    std::vector<char*> ptrs(n, nullptr);
    if (H5Dread(ds.get(), t.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, ptrs.data()) < 0)
      throw DataError(where(path) + ": cannot read strings" + hdf5_detail());
    for (char* p : ptrs) lines.emplace_back(p ? p : "");
    H5Id sp(H5Dget_space(ds.get()), H5Sclose);
    H5Dvlen_reclaim(t.get(), sp.get(), H5P_DEFAULT, ptrs.data());
  } else {
    const std::size_t w = H5Tget_size(ft.get());
    std::vector<char> buf(n * w);
    H5Id t(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(t.get(), w);
    if (H5Dread(ds.get(), t.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data()) < 0)
      throw DataError(where(path) + ": cannot read strings" + hdf5_detail());
    for (std::size_t i = 0; i < n; ++i) {
      std::string s(buf.data() + i * w, w);
      s.erase(std::find(s.begin(), s.end(), '\0'), s.end());
      lines.push_back(s);
    }
  }
  return lines;
}

template <class T>
T H5File::read_scalar(const std::string& path) const {
  const auto v = read<T>(path);
  if (v.size() != 1)
    throw DataError(where(path) + " holds " + std::to_string(v.size()) + " values where one is expected; the file is damaged, rewrite it with the tool that made it");
  return v[0];
}

std::string H5File::read_string(const std::string& path) const {
  auto lines = read_strings(path);
  if (lines.size() != 1)
    throw DataError(where(path) + " holds " + std::to_string(lines.size()) + " strings where one is expected; the file is damaged, rewrite it with the tool that made it");
  return std::move(lines[0]);
}

#define GRAINTWIN_H5_INSTANTIATE(T)                                                               \
  template void H5File::write<T>(const std::string&, const T*, const std::vector<hsize_t>&,       \
                                 const DatasetOptions&);                                          \
  template std::vector<T> H5File::read<T>(const std::string&, std::vector<hsize_t>*) const;       \
  template void H5File::read_box<T>(const std::string&, const std::vector<hsize_t>&,              \
                                    const std::vector<hsize_t>&, T*) const;                       \
  template T H5File::read_scalar<T>(const std::string&) const;
GRAINTWIN_H5_INSTANTIATE(std::uint8_t)
GRAINTWIN_H5_INSTANTIATE(std::int8_t)
GRAINTWIN_H5_INSTANTIATE(std::uint16_t)
GRAINTWIN_H5_INSTANTIATE(std::int16_t)
GRAINTWIN_H5_INSTANTIATE(std::uint32_t)
GRAINTWIN_H5_INSTANTIATE(std::int32_t)
GRAINTWIN_H5_INSTANTIATE(std::uint64_t)
GRAINTWIN_H5_INSTANTIATE(std::int64_t)
GRAINTWIN_H5_INSTANTIATE(float)
GRAINTWIN_H5_INSTANTIATE(double)
#undef GRAINTWIN_H5_INSTANTIATE

}  // namespace graintwin::io
