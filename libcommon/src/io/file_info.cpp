#include "graintwin/io/file_info.hpp"

#include <algorithm>
#include <sstream>

#include "graintwin/core/error.hpp"
#include "graintwin/core/interrupt.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/io/schema.hpp"

namespace graintwin::io {

namespace {

using nlohmann::json;

template <class T>
ValueRange slab_range(const H5File& f, const std::string& path, const ImageHeader& h, const std::function<void(double)>& progress) {
  const std::size_t slab = std::max<std::size_t>(1, (64u << 20) / std::max<std::size_t>(1, h.shape[1] * h.shape[2] * sizeof(T)));
  std::vector<T> buf;
  ValueRange total;
  double sum = 0.0;
  std::size_t finite = 0;
  bool first = true;
  for (std::size_t z = 0; z < h.shape[0]; z += slab) {
    const std::size_t nz = std::min(slab, h.shape[0] - z);
    buf.resize(nz * h.shape[1] * h.shape[2]);
    f.read_box(path, {z, 0, 0}, {nz, h.shape[1], h.shape[2]}, buf.data());
    const ValueRange r = value_range(buf.data(), buf.size());
    const std::size_t n = buf.size() - r.non_finite;
    if (n > 0) {
      total.min = first ? r.min : std::min(total.min, r.min);
      total.max = first ? r.max : std::max(total.max, r.max);
      first = false;
    }
    sum += r.mean * static_cast<double>(n);
    finite += n;
    total.non_finite += r.non_finite;
    if (progress) progress(static_cast<double>(z + nz) / static_cast<double>(h.shape[0]));
    throw_if_interrupted();
  }
  total.mean = finite ? sum / static_cast<double>(finite) : 0.0;
  return total;
}

void list_datasets(const H5File& f, const std::string& group, json& out) {
  for (const auto& name : f.list(group)) {
    const std::string p = (group == "/" ? "" : group) + "/" + name;
    if (f.is_group(p)) {
      list_datasets(f, p, out);
    } else {
      const DatasetInfo di = f.info(p);
      json d = {{"path", p}, {"shape", di.dims}, {"dtype", di.dtype}};
      if (auto u = f.attr_string(p, schema::attr::units)) d["units"] = *u;
      out.push_back(d);
    }
  }
}

}  // namespace

ValueRange image_value_range(const H5File& f, const std::string& path, const ImageHeader& header,
                             const std::function<void(double)>& progress) {
  switch (header.dtype) {
    case DType::uint8: return slab_range<std::uint8_t>(f, path, header, progress);
    case DType::uint16: return slab_range<std::uint16_t>(f, path, header, progress);
    case DType::uint32: return slab_range<std::uint32_t>(f, path, header, progress);
    case DType::float32: return slab_range<float>(f, path, header, progress);
  }
  return {};
}

json describe_file(const std::filesystem::path& path, bool value_range,
                   const std::function<std::function<void(double)>(const std::string&)>& progress) {
  const H5File f = H5File::open(path);
  json info;
  info["file"] = path.string();
  const std::string kind = file_kind(f);
  if (kind.empty())
    throw UsageError(path.string() + " is an HDF5 file without a GrainTwin 'kind' attribute; import images with volconvert");
  info["kind"] = kind;
  info["schema_version"] = f.attr_int(schema::path::root, schema::attr::schema_version).value_or(0);
  info["creator"] = f.attr_string(schema::path::root, schema::attr::creator).value_or("");
  info["datasets"] = json::array();
  list_datasets(f, "/", info["datasets"]);
  info["images"] = json::array();
  for (const char* p : {schema::path::volume, schema::path::labels}) {
    if (!f.exists(p)) continue;
    const ImageHeader h = read_image_header(f, p);
    json im = {{"path", p},
               {"shape_zyx", h.shape},
               {"dtype", dtype_name(h.dtype)},
               {"voxel_size_m_zyx", h.voxel_size},
               {"origin_m_zyx", h.origin},
               {"units", h.units}};
    if (value_range) {
      const ValueRange r = image_value_range(f, p, h, progress ? progress("value range " + std::string(p)) : nullptr);
      im["min"] = r.min;
      im["max"] = r.max;
      im["mean"] = r.mean;
      im["non_finite"] = r.non_finite;
    }
    info["images"].push_back(im);
  }
  info["history"] = read_history(f);
  return info;
}

std::string describe_text(const json& info) {
  std::ostringstream out;
  out << "file:            " << info["file"].get<std::string>() << "\n"
      << "kind:            " << info["kind"].get<std::string>() << " (schema " << info["schema_version"] << ", "
      << info["creator"].get<std::string>() << ")\n";
  for (const auto& im : info["images"]) {
    const auto s = im["shape_zyx"];
    const auto vs = im["voxel_size_m_zyx"];
    out << "image " << im["path"].get<std::string>() << ":\n"
        << "  shape (z,y,x):   " << s[0] << " x " << s[1] << " x " << s[2] << "\n"
        << "  dtype:           " << im["dtype"].get<std::string>() << "\n"
        << "  voxel size:      " << vs[0].get<double>() * 1e6 << " x " << vs[1].get<double>() * 1e6 << " x "
        << vs[2].get<double>() * 1e6 << " um (z,y,x)\n"
        << "  origin (z,y,x):  " << im["origin_m_zyx"].dump() << " m\n";
    if (im.contains("min"))
      out << "  values:          " << im["min"].get<double>() << " .. " << im["max"].get<double>() << ", mean "
          << im["mean"].get<double>()
          << (im["non_finite"].get<std::size_t>() ? ", " + std::to_string(im["non_finite"].get<std::size_t>()) + " NaN/Inf" : "")
          << "\n";
  }
  out << "datasets:\n";
  for (const auto& d : info["datasets"]) {
    out << "  " << d["path"].get<std::string>() << "  " << d["dtype"].get<std::string>() << " " << d["shape"].dump();
    if (d.contains("units")) out << "  [" << d["units"].get<std::string>() << "]";
    out << "\n";
  }
  out << "history:\n";
  for (const auto& l : info["history"]) out << "  " << l.get<std::string>() << "\n";
  return out.str();
}

}  // namespace graintwin::io
