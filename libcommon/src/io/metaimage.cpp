#include "graintwin/io/metaimage.hpp"

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>

#include "graintwin/core/error.hpp"
#include "graintwin/core/resources.hpp"
#include "graintwin/core/strings.hpp"

namespace graintwin::io {

namespace fs = std::filesystem;

namespace {

template <class T>
void byteswap_all(Volume<T>& v) {
  if constexpr (sizeof(T) > 1) {
    auto* p = reinterpret_cast<unsigned char*>(v.data());
    for (std::size_t i = 0; i < v.size(); ++i) std::reverse(p + i * sizeof(T), p + (i + 1) * sizeof(T));
  }
}

template <class T>
Volume<T> read_block(std::istream& in, const RawLayout& l, const std::string& what) {
  Volume<T> v(l.shape, l.voxel_size);
  in.read(reinterpret_cast<char*>(v.data()), static_cast<std::streamsize>(v.size() * sizeof(T)));
  if (static_cast<std::size_t>(in.gcount()) != v.size() * sizeof(T))
    throw DataError(what + " ends early: it holds " + std::to_string(in.gcount()) + " bytes of data, " +
                    std::to_string(v.size() * sizeof(T)) + " expected; check the dimensions and data type");
  if (l.big_endian != (std::endian::native == std::endian::big)) byteswap_all(v);
  return v;
}

AnyVolume read_stream(std::istream& in, const RawLayout& l, const std::string& what) {
  switch (l.dtype) {
    case DType::uint8: return read_block<std::uint8_t>(in, l, what);
    case DType::uint16: return read_block<std::uint16_t>(in, l, what);
    case DType::uint32: return read_block<std::uint32_t>(in, l, what);
    case DType::float32: return read_block<float>(in, l, what);
  }
  throw DataError("unreachable");
}

/// Bytes of data the layout describes; DataError when they do not fit in 64 bits (a product that
/// wrapped round could match a small file and make every later index run off the volume).
std::size_t expected_bytes(const RawLayout& l, const fs::path& path, const std::string& fix) {
  const auto bytes = checked_product({l.shape[0], l.shape[1], l.shape[2], dtype_bytes(l.dtype)});
  if (!bytes || *bytes > std::numeric_limits<std::uint64_t>::max() - l.header_bytes)
    throw DataError(path.string() + ": " + std::to_string(l.shape[0]) + " x " + std::to_string(l.shape[1]) + " x " +
                    std::to_string(l.shape[2]) + " " + dtype_name(l.dtype) + " voxels are more bytes than a 64-bit size counts; " + fix);
  return *bytes;
}

// Header numbers. std::stoull and std::stod throw exceptions that name no file or key, and stoull
// reads "-1" as 2^64 - 1.
std::vector<std::size_t> header_counts(const fs::path& path, const std::string& key, const std::string& text) {
  std::vector<std::size_t> out;
  for (const auto& word : split(text, ' ')) {
    const std::string w = trim(word);
    if (w.empty()) continue;
    errno = 0;
    char* end = nullptr;
    const unsigned long long v = std::strtoull(w.c_str(), &end, 10);
    if (w.find_first_not_of("0123456789") != std::string::npos || *end != '\0' || errno == ERANGE)
      throw DataError(path.string() + ": " + key + " = " + excerpt(text) + " is not a list of whole numbers; fix the header");
    out.push_back(static_cast<std::size_t>(v));
  }
  return out;
}

std::vector<double> header_numbers(const fs::path& path, const std::string& key, const std::string& text) {
  std::vector<double> out;
  for (const auto& word : split(text, ' ')) {
    const std::string w = trim(word);
    if (w.empty()) continue;
    char* end = nullptr;
    const double v = std::strtod(w.c_str(), &end);
    if (end == w.c_str() || *end != '\0' || !std::isfinite(v))
      throw DataError(path.string() + ": " + key + " = " + excerpt(text) + " is not a list of finite numbers; fix the header");
    out.push_back(v);
  }
  return out;
}

}  // namespace

namespace {
AnyVolume read_raw_checked(const fs::path& path, const RawLayout& layout, const std::string& fix) {
  std::error_code ec;
  const auto size = fs::file_size(path, ec);
  if (ec) throw UsageError(path.string() + ": cannot read (" + ec.message() + ")");
  const std::size_t data = expected_bytes(layout, path, fix);
  const std::size_t want = layout.header_bytes + data;
  if (size != want)
    throw DataError(path.string() + " has " + std::to_string(size) + " bytes but " +
                    std::to_string(layout.shape[0]) + " x " + std::to_string(layout.shape[1]) + " x " +
                    std::to_string(layout.shape[2]) + " " + dtype_name(layout.dtype) +
                    (layout.header_bytes ? " after a " + std::to_string(layout.header_bytes) + "-byte header" : "") +
                    " needs " + std::to_string(want) + "; " + fix);
  check_memory(static_cast<double>(data), "reading " + path.string(),
               std::to_string(layout.shape[0]) + " x " + std::to_string(layout.shape[1]) + " x " +
                   std::to_string(layout.shape[2]) + " " + dtype_name(layout.dtype) + " voxels",
               "convert it on a machine with more memory");
  std::ifstream in(path, std::ios::binary);
  in.seekg(static_cast<std::streamoff>(layout.header_bytes));
  return read_stream(in, layout, path.string());
}
}  // namespace

AnyVolume read_raw(const fs::path& path, const RawLayout& layout) {
  return read_raw_checked(path, layout, "check --dims (z,y,x order), --dtype and --header-bytes");
}

AnyVolume read_metaimage(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw UsageError(path.string() + ": cannot open; check the path");
  std::map<std::string, std::string> keys;
  std::string line;
  bool local_data = false;
  while (std::getline(in, line)) {
    const auto eq = line.find('=');
    if (eq == std::string::npos) {
      if (!trim(line).empty())
        throw DataError(path.string() + ": header line '" + excerpt(trim(line)) + "' is not 'Key = Value'; is this a MetaImage header?");
      continue;
    }
    const std::string key = trim(line.substr(0, eq));
    keys[key] = trim(line.substr(eq + 1));
    if (key == "ElementDataFile") {
      local_data = keys[key] == "LOCAL";
      break;  // MetaImage puts ElementDataFile last; inline data follow it in .mha files
    }
  }
  auto need = [&](const std::string& k) {
    const auto it = keys.find(k);
    if (it == keys.end()) throw DataError(path.string() + ": MetaImage header lacks " + k + "; fix the header");
    return it->second;
  };
  const std::string ndims = need("NDims");
  if (ndims != "3")
    throw DataError(path.string() + ": NDims = " + excerpt(ndims) + "; GrainTwin reads 3-D MetaImage volumes only");
  const std::vector<std::size_t> d = header_counts(path, "DimSize", need("DimSize"));
  if (d.size() != 3) throw DataError(path.string() + ": DimSize must have 3 values (x y z)");
  const std::string type = need("ElementType");
  RawLayout l;
  l.shape = {d[2], d[1], d[0]};  // MetaImage lists x y z
  if (type == "MET_UCHAR") l.dtype = DType::uint8;
  else if (type == "MET_USHORT") l.dtype = DType::uint16;
  else if (type == "MET_UINT") l.dtype = DType::uint32;
  else if (type == "MET_FLOAT") l.dtype = DType::float32;
  else
    throw DataError(path.string() + ": ElementType " + excerpt(type) +
                    " is not supported; use MET_UCHAR, MET_USHORT, MET_UINT or MET_FLOAT");
  if (keys.count("ElementNumberOfChannels") && keys["ElementNumberOfChannels"] != "1")
    throw DataError(path.string() + ": multi-channel MetaImage is not a grey volume");
  const std::string msb = lower(keys.count("BinaryDataByteOrderMSB") ? keys["BinaryDataByteOrderMSB"]
                                                                     : keys["ElementByteOrderMSB"]);
  l.big_endian = msb == "true";
  if (lower(keys["CompressedData"]) == "true")
    throw DataError(path.string() + ": compressed MetaImage data are not supported; re-save it uncompressed");
  const std::string spacing = keys.count("ElementSpacing") ? keys["ElementSpacing"] : keys["ElementSize"];
  Vec3 origin{0.0, 0.0, 0.0};
  if (!spacing.empty()) {
    const std::vector<double> sp = header_numbers(path, "ElementSpacing", spacing);
    if (sp.size() != 3) throw DataError(path.string() + ": ElementSpacing must have 3 values");
    if (!(sp[0] > 0 && sp[1] > 0 && sp[2] > 0))
      throw DataError(path.string() + ": ElementSpacing = " + excerpt(spacing) + " must be positive; fix the header");
    l.voxel_size = {sp[2] * 1e-3, sp[1] * 1e-3, sp[0] * 1e-3};  // ITK writes millimetres
  } else {
    l.voxel_size = {0.0, 0.0, 0.0};
  }
  const std::string off = keys.count("Offset") ? keys["Offset"] : keys["Position"];
  if (!off.empty()) {
    const std::vector<double> o = header_numbers(path, "Offset", off);
    if (o.size() == 3) origin = {o[2] * 1e-3, o[1] * 1e-3, o[0] * 1e-3};
  }
  const std::string data_file = need("ElementDataFile");
  AnyVolume v;
  if (local_data) {
    // Compare with the bytes that follow the header before allocating: DimSize is only a claim.
    const std::streamoff at = in.tellg();
    std::error_code ec;
    const auto size = fs::file_size(path, ec);
    const std::size_t want = expected_bytes(l, path, "check DimSize and ElementType");
    if (at < 0 || ec || size - static_cast<std::uintmax_t>(at) != want)
      throw DataError(path.string() + " holds " + std::to_string(at < 0 || ec ? 0 : size - static_cast<std::uintmax_t>(at)) +
                      " bytes of data after its header but DimSize x ElementType needs " + std::to_string(want) +
                      "; check the header");
    v = read_stream(in, l, path.string());
  } else {
    if (data_file == "LIST" || data_file.find('%') != std::string::npos)
      throw DataError(path.string() + ": multi-file MetaImage (ElementDataFile = " + excerpt(data_file) +
                      ") is not supported; give the slices as a folder instead");
    const fs::path raw = path.parent_path() / data_file;
    if (!fs::exists(raw))
      throw UsageError(path.string() + " points to data file " + excerpt(data_file) + ", which does not exist beside it");
    // HeaderSize = -1 means the data are the last bytes of the file (the MetaImage convention).
    const std::string header = keys.count("HeaderSize") ? keys["HeaderSize"] : "0";
    if (header == "-1") {
      std::error_code ec;
      const auto size = fs::file_size(raw, ec);
      const std::size_t data = expected_bytes(l, path, "check DimSize and ElementType");
      l.header_bytes = !ec && size >= data ? size - data : 0;
    } else {
      const auto h = header_counts(path, "HeaderSize", header);
      if (h.size() != 1) throw DataError(path.string() + ": HeaderSize = " + excerpt(header) + " must be one whole number or -1; fix the header");
      l.header_bytes = h[0];
    }
    v = read_raw_checked(raw, l, "check DimSize, ElementType and HeaderSize in " + path.string());
  }
  std::visit([&](auto& vol) { vol.set_origin(origin); }, v);
  return v;
}

}  // namespace graintwin::io
