#pragma once
// A thin RAII layer over the HDF5 C API. HDF5's own error printing is switched off; every failure
// becomes a graintwin::DataError naming the file and the object.
#include <hdf5.h>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "graintwin/core/volume.hpp"

namespace graintwin::io {

/// Owns one HDF5 identifier and closes it with the matching H5?close.
class H5Id {
 public:
  H5Id() = default;
  H5Id(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  H5Id(const H5Id&) = delete;
  H5Id& operator=(const H5Id&) = delete;
  H5Id(H5Id&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = -1; }
  H5Id& operator=(H5Id&& o) noexcept;
  ~H5Id();
  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }

 private:
  hid_t id_ = -1;
  herr_t (*close_)(hid_t) = nullptr;
};

/// How a dataset is stored.
struct DatasetOptions {
  std::string units;            ///< written as the `units` attribute when not empty
  bool compress = true;         ///< chunked + shuffle + gzip when the dataset is large enough
  int gzip_level = 4;
  std::vector<hsize_t> chunk;   ///< empty: chosen automatically
};

/// Options that only set the units attribute, e.g. f.write("/grains/volume", v, units("m^3")).
inline DatasetOptions units(std::string u) {
  DatasetOptions o;
  o.units = std::move(u);
  return o;
}

/// Shape and element type of a stored dataset.
struct DatasetInfo {
  std::vector<hsize_t> dims;
  std::string dtype;  ///< "uint8", "int32", "float64", "string", ... (numpy-like names)
};

class H5File {
 public:
  /// Creates (truncates) a file for writing.
  static H5File create(const std::filesystem::path& path);
  /// Opens an existing file read-only; a non-HDF5 file is a UsageError naming it.
  static H5File open(const std::filesystem::path& path);

  const std::filesystem::path& path() const { return path_; }
  hid_t id() const { return file_.get(); }

  bool exists(const std::string& object) const;
  /// Names of the members of a group ("/" for the root), sorted.
  std::vector<std::string> list(const std::string& group) const;
  bool is_group(const std::string& object) const;
  /// Creates every missing group along `group` ("/a/b/c").
  void ensure_group(const std::string& group);

  // Attributes on any object ("/" for the root).
  void set_attr(const std::string& object, const std::string& name, const std::string& value);
  void set_attr(const std::string& object, const std::string& name, long long value);
  void set_attr(const std::string& object, const std::string& name, double value);
  void set_attr(const std::string& object, const std::string& name,
                const std::vector<double>& values);
  bool has_attr(const std::string& object, const std::string& name) const;
  std::optional<std::string> attr_string(const std::string& object, const std::string& name) const;
  /// nullopt when absent or not one number; DataError when it is not a whole number in range (NaN, 1e300, 2.5).
  std::optional<long long> attr_int(const std::string& object, const std::string& name) const;
  std::vector<double> attr_doubles(const std::string& object, const std::string& name) const;
  /// The one number of an attribute; DataError naming it when it is absent or holds another count.
  double attr_double(const std::string& object, const std::string& name) const;

  /// Writes a row-major N-d array (dims slowest first). Parent groups are created.
  template <class T>
  void write(const std::string& path, const T* data, const std::vector<hsize_t>& dims,
             const DatasetOptions& opt = {});
  template <class T>
  void write(const std::string& path, const std::vector<T>& data, const DatasetOptions& opt = {}) {
    write(path, data.data(), {static_cast<hsize_t>(data.size())}, opt);
  }
  /// Writes a 1-D dataset of variable-length UTF-8 strings.
  void write_strings(const std::string& path, const std::vector<std::string>& lines);

  /// Shape and type. DataError when the shape declares more values than the file can hold: an
  /// element count that overflows 64 bits, or far more bytes than the dataset stores (a damaged
  /// file must not make a reader allocate its declared extent).
  DatasetInfo info(const std::string& path) const;
  /// Reads a whole dataset converted to T (HDF5 converts numeric types).
  template <class T>
  std::vector<T> read(const std::string& path, std::vector<hsize_t>* dims = nullptr) const;
  /// Reads a box [offset, offset + count) of an N-d dataset into `out` (row-major).
  template <class T>
  void read_box(const std::string& path, const std::vector<hsize_t>& offset,
                const std::vector<hsize_t>& count, T* out) const;
  std::vector<std::string> read_strings(const std::string& path) const;
  /// The one value of a dataset of one element (e.g. /sample/void_ratio); DataError naming it otherwise.
  template <class T>
  T read_scalar(const std::string& path) const;
  /// The one string of a 1-D string dataset of one element (e.g. a tool's parameters JSON).
  std::string read_string(const std::string& path) const;

 private:
  H5File(std::filesystem::path path, H5Id file) : path_(std::move(path)), file_(std::move(file)) {}
  std::string where(const std::string& object) const;
  std::filesystem::path path_;
  H5Id file_;
};

}  // namespace graintwin::io
