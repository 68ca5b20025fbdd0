#include "h5_mutator.hpp"

#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

#include "fuzz_support.hpp"

namespace graintwin::fuzz {

namespace fs = std::filesystem;

namespace {

/// One HDF5 identifier, closed when it goes out of scope.
class Id {
 public:
  Id(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  Id(Id&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = -1; }
  Id(const Id&) = delete;
  Id& operator=(const Id&) = delete;
  ~Id() {
    if (id_ >= 0) close_(id_);
  }
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

enum class Kind { group, dataset, attribute };
struct Object {
  std::string path;  ///< the group or dataset, or the object holding the attribute
  std::string attr;  ///< attribute name (Kind::attribute only)
  Kind kind;
};

std::vector<Object> enumerate(hid_t file) {
  std::vector<Object> objects{{"/", "", Kind::group}};
  H5Lvisit(
      file, H5_INDEX_NAME, H5_ITER_INC,
      [](hid_t group, const char* name, const H5L_info_t* info, void* out) -> herr_t {
        if (info->type != H5L_TYPE_HARD) return 0;
        H5O_info_t oi;
        if (H5Oget_info_by_name(group, name, &oi, H5P_DEFAULT) < 0) return 0;
        auto* list = static_cast<std::vector<Object>*>(out);
        if (oi.type == H5O_TYPE_GROUP) list->push_back({std::string("/") + name, "", Kind::group});
        if (oi.type == H5O_TYPE_DATASET) list->push_back({std::string("/") + name, "", Kind::dataset});
        return 0;
      },
      &objects);
  const std::size_t holders = objects.size();
  for (std::size_t i = 0; i < holders; ++i) {
    std::vector<std::string> names;
    H5Aiterate_by_name(
        file, objects[i].path.c_str(), H5_INDEX_NAME, H5_ITER_INC, nullptr,
        [](hid_t, const char* name, const H5A_info_t*, void* out) -> herr_t {
          static_cast<std::vector<std::string>*>(out)->push_back(name);
          return 0;
        },
        &names, H5P_DEFAULT);
    for (const std::string& n : names) objects.push_back({objects[i].path, n, Kind::attribute});
  }
  return objects;
}

const double kSpecialValues[] = {std::numeric_limits<double>::quiet_NaN(),
                                 std::numeric_limits<double>::infinity(),
                                 -std::numeric_limits<double>::infinity(),
                                 1e308,
                                 -1e308,
                                 -1.0,
                                 0.0,
                                 1.0,
                                 0.5,
                                 2.0,
                                 255.0,
                                 65536.0,
                                 1e6,
                                 4294967295.0,
                                 4294967296.0,
                                 9007199254740993.0,
                                 9.3e18,
                                 -9.3e18,
                                 1.8446744073709552e19,
                                 1e-310,
                                 -0.0};

const char* const kSpecialStrings[] = {"", "{", "not json", "null", "[]", "{\"source\": 7}", "\xff\xfe\xfd", "nan",
                                       "1e999", "-1", "volume", "labels", "contacts", "shapes", "tracks",
                                       "fdem_model", "fdem_results", "fdem_checkpoint", "ground_truth", "micro",
                                       "forces", "zyx", "xyz"};

double special_value(std::uint64_t p) { return kSpecialValues[p % std::size(kSpecialValues)]; }
std::string special_string(std::uint64_t p) {
  if (p % 41 == 40) return std::string(5000, 'x');
  return kSpecialStrings[p % std::size(kSpecialStrings)];
}

Id vlen_string_type() {
  Id t(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(t.get(), H5T_VARIABLE);
  H5Tset_cset(t.get(), H5T_CSET_UTF8);
  return t;
}

/// The values of a dataset or attribute, as numbers or as strings, with its shape and file type.
struct Content {
  bool is_string = false;
  bool scalar = false;  ///< rank 0 (H5S_SCALAR)
  std::vector<double> num;
  std::vector<std::string> str;
  std::vector<hsize_t> dims;
  hid_t type = -1;  ///< a copy of the stored type (numeric only); owned
  Content() = default;
  Content(const Content&) = delete;
  Content& operator=(const Content&) = delete;
  ~Content() {
    if (type >= 0) H5Tclose(type);
  }
  std::size_t count() const { return is_string ? str.size() : num.size(); }
  void resize(std::size_t n, double pad_num, const std::string& pad_str) {
    if (is_string) str.resize(n, pad_str);
    else num.resize(n, pad_num);
  }
};

/// Reads an open dataset (read_fn = H5Dread-like) or attribute into `c`; false if its type is not one we write.
template <class Read>
bool read_content(hid_t obj, hid_t space, hid_t ftype, Content& c, Read&& read) {
  const int rank = H5Sget_simple_extent_ndims(space);
  if (rank < 0) return false;
  c.scalar = H5Sget_simple_extent_type(space) == H5S_SCALAR;
  c.dims.resize(static_cast<std::size_t>(rank));
  if (rank > 0) H5Sget_simple_extent_dims(space, c.dims.data(), nullptr);
  const hssize_t n = H5Sget_simple_extent_npoints(space);
  if (n < 0 || n > 1000000) return false;
  const H5T_class_t cls = H5Tget_class(ftype);
  if (cls == H5T_STRING) {
    c.is_string = true;
    if (H5Tis_variable_str(ftype) > 0) {
      Id t = vlen_string_type();
      std::vector<char*> p(static_cast<std::size_t>(n), nullptr);
      if (n > 0 && read(obj, t.get(), p.data()) < 0) return false;
      for (char* s : p) c.str.emplace_back(s ? s : "");
      if (n > 0) H5Dvlen_reclaim(t.get(), space, H5P_DEFAULT, p.data());
    } else {
      const std::size_t w = H5Tget_size(ftype);
      std::vector<char> buf(static_cast<std::size_t>(n) * w + 1, '\0');
      Id t(H5Tcopy(H5T_C_S1), H5Tclose);
      H5Tset_size(t.get(), w);
      if (n > 0 && read(obj, t.get(), buf.data()) < 0) return false;
      for (hssize_t i = 0; i < n; ++i) c.str.emplace_back(std::string(buf.data() + i * w, w).c_str());
    }
    return true;
  }
  if (cls != H5T_INTEGER && cls != H5T_FLOAT) return false;
  c.num.resize(static_cast<std::size_t>(n));
  if (n > 0 && read(obj, H5T_NATIVE_DOUBLE, c.num.data()) < 0) return false;
  c.type = H5Tcopy(ftype);
  return true;
}

bool read_dataset(hid_t file, const std::string& path, Content& c) {
  Id ds(H5Dopen2(file, path.c_str(), H5P_DEFAULT), H5Dclose);
  if (!ds.ok()) return false;
  Id space(H5Dget_space(ds.get()), H5Sclose);
  Id ftype(H5Dget_type(ds.get()), H5Tclose);
  return read_content(ds.get(), space.get(), ftype.get(), c, [](hid_t d, hid_t mem, void* buf) {
    return H5Dread(d, mem, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf);
  });
}

bool read_attribute(hid_t file, const std::string& object, const std::string& name, Content& c) {
  Id a(H5Aopen_by_name(file, object.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!a.ok()) return false;
  Id space(H5Aget_space(a.get()), H5Sclose);
  Id ftype(H5Aget_type(a.get()), H5Tclose);
  return read_content(a.get(), space.get(), ftype.get(), c, [](hid_t at, hid_t mem, void* buf) { return H5Aread(at, mem, buf); });
}

Id make_space(const Content& c) {
  if (c.scalar) return Id(H5Screate(H5S_SCALAR), H5Sclose);
  if (c.dims.size() == 1 && c.dims[0] == 0 && c.count() == 0) return Id(H5Screate_simple(1, c.dims.data(), nullptr), H5Sclose);
  return Id(H5Screate_simple(static_cast<int>(c.dims.size()), c.dims.data(), nullptr), H5Sclose);
}

/// Writes `c` as a new dataset at `path` (which must not exist). `unwritten`: chunked, no data, so
/// the extent may be far larger than what the file stores.
bool write_dataset(hid_t file, const std::string& path, const Content& c, bool unwritten) {
  Id space = make_space(c);
  if (!space.ok()) return false;
  Id dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  if (unwritten && !c.dims.empty()) {
    std::vector<hsize_t> chunk(c.dims.size());
    for (std::size_t i = 0; i < chunk.size(); ++i) chunk[i] = std::max<hsize_t>(1, std::min<hsize_t>(c.dims[i], 64));
    H5Pset_chunk(dcpl.get(), static_cast<int>(chunk.size()), chunk.data());
  }
  Id vlen = vlen_string_type();
  const hid_t ftype = c.is_string ? vlen.get() : c.type;
  Id ds(H5Dcreate2(file, path.c_str(), ftype, space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT), H5Dclose);
  if (!ds.ok()) return false;
  if (unwritten || c.count() == 0) return true;
  if (c.is_string) {
    std::vector<const char*> p;
    for (const std::string& s : c.str) p.push_back(s.c_str());
    return H5Dwrite(ds.get(), vlen.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, p.data()) >= 0;
  }
  return H5Dwrite(ds.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, c.num.data()) >= 0;
}

bool write_attribute(hid_t file, const std::string& object, const std::string& name, const Content& c) {
  if (H5Aexists_by_name(file, object.c_str(), name.c_str(), H5P_DEFAULT) > 0)
    H5Adelete_by_name(file, object.c_str(), name.c_str(), H5P_DEFAULT);
  Id space = c.count() == 0 && !c.scalar ? Id(H5Screate(H5S_NULL), H5Sclose) : make_space(c);
  Id vlen = vlen_string_type();
  const hid_t ftype = c.is_string ? vlen.get() : c.type;
  Id a(H5Acreate_by_name(file, object.c_str(), name.c_str(), ftype, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
       H5Aclose);
  if (!a.ok()) return false;
  if (c.count() == 0) return true;
  if (c.is_string) {
    std::vector<const char*> p;
    for (const std::string& s : c.str) p.push_back(s.c_str());
    return H5Awrite(a.get(), vlen.get(), p.data()) >= 0;
  }
  return H5Awrite(a.get(), H5T_NATIVE_DOUBLE, c.num.data()) >= 0;
}

/// The attributes of a dataset, to carry over when it is rewritten.
struct NamedContent {
  std::string name;
  Content content;
};
std::vector<NamedContent> read_attributes(hid_t file, const std::string& object) {
  std::vector<std::string> names;
  H5Aiterate_by_name(
      file, object.c_str(), H5_INDEX_NAME, H5_ITER_INC, nullptr,
      [](hid_t, const char* name, const H5A_info_t*, void* out) -> herr_t {
        static_cast<std::vector<std::string>*>(out)->push_back(name);
        return 0;
      },
      &names, H5P_DEFAULT);
  std::vector<NamedContent> out(names.size());
  for (std::size_t i = 0; i < names.size(); ++i) {
    out[i].name = names[i];
    if (!read_attribute(file, object, names[i], out[i].content)) out[i].name.clear();
  }
  return out;
}

/// Replaces the dataset at `path` by `c`, keeping its attributes.
void rewrite_dataset(hid_t file, const std::string& path, const Content& c, bool unwritten) {
  const auto attrs = read_attributes(file, path);
  if (H5Ldelete(file, path.c_str(), H5P_DEFAULT) < 0) return;
  if (!write_dataset(file, path, c, unwritten)) return;
  for (const NamedContent& a : attrs)
    if (!a.name.empty()) write_attribute(file, path, a.name, a.content);
}

hsize_t product(const std::vector<hsize_t>& d) {
  hsize_t n = 1;
  for (hsize_t v : d) n *= v;
  return n;
}

void reshape(hid_t file, const std::string& path, std::uint64_t p) {
  Content c;
  if (!read_dataset(file, path, c)) return;
  auto& d = c.dims;
  bool unwritten = false;
  const double pad = special_value(p >> 8);
  const std::string pad_str = special_string(p >> 8);
  switch (p % 9) {
    case 0:  // drop the last row of a table
      if (d.empty() || d[0] == 0) return;
      --d[0];
      break;
    case 1:  // one more row
      if (d.empty()) d = {2}, c.scalar = false;
      else ++d[0];
      break;
    case 2:  // no rows
      if (d.empty()) return;
      d[0] = 0;
      break;
    case 3:  // flattened
      d = {product(d)}, c.scalar = false;
      break;
    case 4:  // one more axis
      d.push_back(1 + (p >> 8) % 3), c.scalar = false;
      break;
    case 5:  // axes reversed
      std::reverse(d.begin(), d.end());
      break;
    case 6:  // a huge first axis that stores nothing
      if (d.empty()) d = {1}, c.scalar = false;
      d[0] = hsize_t{1} << (20 + (p >> 8) % 40);
      unwritten = true;
      break;
    case 7:  // every axis huge: the product overflows 64 bits
      if (d.empty()) d = {1, 1, 1}, c.scalar = false;
      for (hsize_t& v : d) v = hsize_t{1} << (16 + (p >> 8) % 40);
      unwritten = true;
      break;
    case 8:  // a scalar
      d.clear(), c.scalar = true;
      break;
  }
  if (!unwritten) {
    const hsize_t n = product(d);
    if (n > 1000000) return;
    c.resize(static_cast<std::size_t>(c.scalar ? 1 : n), pad, pad_str);
  }
  rewrite_dataset(file, path, c, unwritten);
}

void retype(hid_t file, const std::string& path, std::uint64_t p) {
  Content c;
  if (!read_dataset(file, path, c)) return;
  const hid_t types[] = {H5T_NATIVE_UINT8, H5T_NATIVE_INT8,  H5T_NATIVE_UINT16, H5T_NATIVE_INT16,
                         H5T_NATIVE_UINT32, H5T_NATIVE_INT32, H5T_NATIVE_UINT64, H5T_NATIVE_INT64,
                         H5T_NATIVE_FLOAT, H5T_NATIVE_DOUBLE, -1 /* strings */};
  const hid_t t = types[p % std::size(types)];
  if (t < 0) {
    if (c.is_string) return;
    for (double v : c.num) c.str.push_back(std::to_string(v));
    c.num.clear();
    c.is_string = true;
  } else {
    if (c.is_string) {
      for (const std::string& s : c.str) c.num.push_back(std::strtod(s.c_str(), nullptr));
      c.str.clear();
      c.is_string = false;
    }
    if (c.type >= 0) H5Tclose(c.type);
    c.type = H5Tcopy(t);
  }
  rewrite_dataset(file, path, c, false);
}

/// Which elements an edit of values touches: all, one, or every other one.
template <class V, class F>
void edit_elements(std::vector<V>& v, std::uint64_t p, F&& set) {
  if (v.empty()) return;
  switch (p % 3) {
    case 0: for (V& x : v) set(x); break;
    case 1: set(v[(p >> 2) % v.size()]); break;
    case 2: for (std::size_t i = 0; i < v.size(); i += 2) set(v[i]); break;
  }
}

void set_values(hid_t file, const std::string& path, std::uint64_t p) {
  Content c;
  if (!read_dataset(file, path, c)) return;
  if (c.is_string) edit_elements(c.str, p, [&](std::string& s) { s = special_string(p >> 24); });
  else edit_elements(c.num, p, [&](double& x) { x = special_value(p >> 24); });
  rewrite_dataset(file, path, c, false);
}

void set_attribute(hid_t file, const Object& o, std::uint64_t p) {
  Content c;
  if (!read_attribute(file, o.path, o.attr, c)) return;
  if (c.is_string) edit_elements(c.str, p, [&](std::string& s) { s = special_string(p >> 24); });
  else edit_elements(c.num, p, [&](double& x) { x = special_value(p >> 24); });
  write_attribute(file, o.path, o.attr, c);
}

void retype_attribute(hid_t file, const Object& o, std::uint64_t p) {
  Content c;
  if (!read_attribute(file, o.path, o.attr, c)) return;
  const std::size_t lengths[] = {0, 1, 2, 3, 4, 6};
  switch (p % 3) {
    case 0:  // strings become numbers and numbers strings
      if (c.is_string) {
        for (const std::string& s : c.str) c.num.push_back(std::strtod(s.c_str(), nullptr));
        c.str.clear();
        c.is_string = false;
        c.type = H5Tcopy(H5T_NATIVE_DOUBLE);
      } else {
        for (double v : c.num) c.str.push_back(std::to_string(v));
        c.num.clear();
        c.is_string = true;
      }
      break;
    case 1: {  // another length
      const std::size_t n = lengths[(p >> 2) % std::size(lengths)];
      c.resize(n, special_value(p >> 8), special_string(p >> 8));
      c.scalar = false;
      c.dims = {n};
      break;
    }
    case 2:  // an integer type
      if (c.is_string) return;
      H5Tclose(c.type);
      c.type = H5Tcopy((p >> 2) % 2 ? H5T_NATIVE_INT64 : H5T_NATIVE_UINT8);
      break;
  }
  if (!c.scalar) c.dims = {c.count()};
  write_attribute(file, o.path, o.attr, c);
}

/// A dataset becomes a group of the same name, or a group a scalar dataset.
void change_object_kind(hid_t file, const Object& o) {
  if (o.path == "/") return;
  if (H5Ldelete(file, o.path.c_str(), H5P_DEFAULT) < 0) return;
  if (o.kind == Kind::dataset) {
    Id g(H5Gcreate2(file, o.path.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
  } else {
    Content c;
    c.scalar = true;
    c.num = {1.0};
    c.type = H5Tcopy(H5T_NATIVE_DOUBLE);
    write_dataset(file, o.path, c, false);
  }
}

std::string name_of(const Object& o) { return o.kind == Kind::attribute ? o.path + "@" + o.attr : o.path; }

void apply(hid_t file, ByteReader& in) {
  const std::uint8_t op = in.u8() % 7;
  const std::vector<Object> objects = enumerate(file);
  // Objects are picked by position in the sorted listing, or by name after the selector 0xffff
  // (regression inputs name their object, so that they survive a regenerated base file).
  const std::uint16_t selector = in.u16();
  const Object* picked = &objects[selector % objects.size()];
  if (selector == 0xffff) {
    std::string name;
    for (std::uint8_t n = in.u8(); n > 0; --n) name += static_cast<char>(in.u8());
    picked = nullptr;
    for (const Object& c : objects)
      if (name_of(c) == name) picked = &c;
    if (!picked) {
      in.u64();
      return;
    }
  }
  const Object& o = *picked;
  const std::uint64_t p = in.u64();
  if (std::getenv("GRAINTWIN_FUZZ_TRACE"))
    std::fprintf(stderr, "edit: op %d on %s, parameter %llu\n", op, name_of(o).c_str(), static_cast<unsigned long long>(p));
  switch (op) {
    case 0:  // delete
      if (o.kind == Kind::attribute) H5Adelete_by_name(file, o.path.c_str(), o.attr.c_str(), H5P_DEFAULT);
      else if (o.path != "/") H5Ldelete(file, o.path.c_str(), H5P_DEFAULT);
      break;
    case 1: {  // swap two datasets or groups
      const Object& other = objects[p % objects.size()];
      if (o.kind == Kind::attribute || other.kind == Kind::attribute || o.path == "/" || other.path == "/" ||
          o.path == other.path || o.path.rfind(other.path + "/", 0) == 0 || other.path.rfind(o.path + "/", 0) == 0)
        break;
      const char* tmp = "/fuzz_swap";
      if (H5Lmove(file, o.path.c_str(), file, tmp, H5P_DEFAULT, H5P_DEFAULT) < 0) break;
      if (H5Lmove(file, other.path.c_str(), file, o.path.c_str(), H5P_DEFAULT, H5P_DEFAULT) < 0) break;
      H5Lmove(file, tmp, file, other.path.c_str(), H5P_DEFAULT, H5P_DEFAULT);
      break;
    }
    case 2:
      if (o.kind == Kind::dataset) reshape(file, o.path, p);
      break;
    case 3:
      if (o.kind == Kind::dataset) retype(file, o.path, p);
      else if (o.kind == Kind::attribute) retype_attribute(file, o, p);
      break;
    case 4:
      if (o.kind == Kind::dataset) set_values(file, o.path, p);
      else if (o.kind == Kind::attribute) set_attribute(file, o, p);
      break;
    case 5:
      if (o.kind != Kind::attribute) change_object_kind(file, o);
      else set_attribute(file, o, p);
      break;
    case 6:
      if (o.kind == Kind::attribute) retype_attribute(file, o, p);
      else if (o.kind == Kind::dataset) reshape(file, o.path, p);
      break;
  }
}

}  // namespace

void mutate_h5(const fs::path& base, const fs::path& out, const std::uint8_t* data, std::size_t size) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  // libFuzzer's timers interrupt system calls, and copy_file does not retry on EINTR: a copy cut
  // short at the end of a budget is the harness's, not the reader's, and is simply made again.
  for (;;) {
    std::error_code ec;
    fs::copy_file(base, out, fs::copy_options::overwrite_existing, ec);
    if (!ec) break;
    if (ec != std::errc::interrupted) throw fs::filesystem_error("cannot copy the base file", base, out, ec);
  }
  if (size == 0) return;
  Id file(H5Fopen(out.c_str(), H5F_ACC_RDWR, H5P_DEFAULT), H5Fclose);
  if (!file.ok()) defect("fuzz support", "cannot open the copy " + out.string() + " of the base file");
  ByteReader in(data, size);
  for (int edits = 0; edits < 4 && !in.empty(); ++edits) apply(file.get(), in);
  H5Eclear2(H5E_DEFAULT);
}

void fuzz_h5_reader(const std::string& reader, const std::filesystem::path& base, const std::uint8_t* data, std::size_t size,
                    void (*read)(const fs::path&)) {
  const fs::path path = scratch_dir() / ("mutated_" + base.filename().string());
  mutate_h5(base, path, data, size);
  if (size == 0) expect_success(reader, [&] { read(path); });
  else expect_clean(reader, [&] { read(path); });
}

}  // namespace graintwin::fuzz
