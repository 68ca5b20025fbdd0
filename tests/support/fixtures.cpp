#include "support/fixtures.hpp"

#include <fstream>

namespace graintwin::test {

template <class T>
Volume<T> ramp_volume(Shape3 shape, Vec3 voxel_size) {
  Volume<T> v(shape, voxel_size);
  for (std::size_t z = 0; z < shape[0]; ++z)
    for (std::size_t y = 0; y < shape[1]; ++y)
      for (std::size_t x = 0; x < shape[2]; ++x) {
        const double code = static_cast<double>((z * 131 + y * 17 + x * 3) % 251);
        if constexpr (std::is_floating_point_v<T>)
          v(z, y, x) = static_cast<T>(code * 0.37 - 20.0);
        else if constexpr (sizeof(T) >= 2)
          v(z, y, x) = static_cast<T>(code * 257 + z);
        else
          v(z, y, x) = static_cast<T>(code);
      }
  return v;
}
template Volume<std::uint8_t> ramp_volume(Shape3, Vec3);
template Volume<std::uint16_t> ramp_volume(Shape3, Vec3);
template Volume<std::uint32_t> ramp_volume(Shape3, Vec3);
template Volume<float> ramp_volume(Shape3, Vec3);

std::filesystem::path write_mhd(const std::filesystem::path& dir, const std::string& name, const AnyVolume& v) {
  const Shape3 s = shape_of_any(v);
  const DType t = dtype_of_any(v);
  const char* met = t == DType::uint8 ? "MET_UCHAR" : t == DType::uint16 ? "MET_USHORT" : t == DType::uint32 ? "MET_UINT" : "MET_FLOAT";
  std::visit([&](const auto& vol) {
    const Vec3 vs = vol.voxel_size();
    std::ofstream h(dir / (name + ".mhd"));
    h << "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
      << "CompressedData = False\nElementSpacing = " << vs[2] * 1e3 << " " << vs[1] * 1e3 << " " << vs[0] * 1e3
      << "\nDimSize = " << s[2] << " " << s[1] << " " << s[0] << "\nElementType = " << met
      << "\nElementDataFile = " << name << ".raw\n";
    std::ofstream r(dir / (name + ".raw"), std::ios::binary);
    r.write(reinterpret_cast<const char*>(vol.data()), static_cast<std::streamsize>(vol.size() * sizeof(vol.data()[0])));
  }, v);
  return dir / (name + ".mhd");
}

bool same_voxels(const AnyVolume& a, const AnyVolume& b) {
  if (a.index() != b.index() || shape_of_any(a) != shape_of_any(b)) return false;
  return std::visit([&](const auto& va) {
    using V = std::decay_t<decltype(va)>;
    const auto& vb = std::get<V>(b);
    return va.values() == vb.values();
  }, a);
}

}  // namespace graintwin::test
