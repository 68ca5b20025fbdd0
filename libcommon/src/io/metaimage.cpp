#include "graintwin/io/metaimage.hpp"

#include <algorithm>
#include <bit>
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
        throw DataError(path.string() + ": header line '" + trim(line) + "' is not 'Key = Value'; is this a MetaImage header?");
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
    throw DataError(path.string() + ": NDims = " + ndims + "; GrainTwin reads 3-D MetaImage volumes only");
  const auto dims = split(need("DimSize"), ' ');
  std::vector<std::size_t> d;
  for (const auto& s : dims)
    if (!trim(s).empty()) d.push_back(std::stoull(s));
  if (d.size() != 3) throw DataError(path.string() + ": DimSize must have 3 values (x y z)");
  const std::string type = need("ElementType");
  RawLayout l;
  l.shape = {d[2], d[1], d[0]};  // MetaImage lists x y z
  if (type == "MET_UCHAR") l.dtype = DType::uint8;
  else if (type == "MET_USHORT") l.dtype = DType::uint16;
  else if (type == "MET_UINT") l.dtype = DType::uint32;
  else if (type == "MET_FLOAT") l.dtype = DType::float32;
  else
    throw DataError(path.string() + ": ElementType " + type +
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
    std::vector<double> sp;
    for (const auto& s : split(spacing, ' '))
      if (!trim(s).empty()) sp.push_back(std::stod(s));
    if (sp.size() != 3) throw DataError(path.string() + ": ElementSpacing must have 3 values");
    l.voxel_size = {sp[2] * 1e-3, sp[1] * 1e-3, sp[0] * 1e-3};  // ITK writes millimetres
  } else {
    l.voxel_size = {0.0, 0.0, 0.0};
  }
  const std::string off = keys.count("Offset") ? keys["Offset"] : keys["Position"];
  if (!off.empty()) {
    std::vector<double> o;
    for (const auto& s : split(off, ' '))
      if (!trim(s).empty()) o.push_back(std::stod(s));
    if (o.size() == 3) origin = {o[2] * 1e-3, o[1] * 1e-3, o[0] * 1e-3};
  }
  const std::string data_file = need("ElementDataFile");
  AnyVolume v;
  if (local_data) {
    expected_bytes(l, path, "check DimSize and ElementType");
    v = read_stream(in, l, path.string());
    if (in.peek() != std::char_traits<char>::eof())
      throw DataError(path.string() + " has more data than DimSize x ElementType says; check the header");
  } else {
    if (data_file == "LIST" || data_file.find('%') != std::string::npos)
      throw DataError(path.string() + ": multi-file MetaImage (ElementDataFile = " + data_file +
                      ") is not supported; give the slices as a folder instead");
    const fs::path raw = path.parent_path() / data_file;
    const std::size_t header = keys.count("HeaderSize") ? std::stoull(keys["HeaderSize"]) : 0;
    l.header_bytes = header;
    if (!fs::exists(raw))
      throw UsageError(path.string() + " points to data file " + raw.string() + ", which does not exist");
    v = read_raw_checked(raw, l, "check DimSize, ElementType and HeaderSize in " + path.string());
  }
  std::visit([&](auto& vol) { vol.set_origin(origin); }, v);
  return v;
}

}  // namespace graintwin::io
