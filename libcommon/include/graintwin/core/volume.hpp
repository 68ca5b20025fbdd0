#pragma once
// Volume<T>: a dense 3-D image indexed (z, y, x), z slowest, with voxel size and origin in metres.
// Voxel (z, y, x) is the cube centred at origin + (z, y, x) * voxel_size (all three in zyx order).
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace graintwin {

using Shape3 = std::array<std::size_t, 3>;  ///< (nz, ny, nx)
using Vec3 = std::array<double, 3>;

/// Element types a volume file may hold.
enum class DType { uint8, uint16, uint32, float32 };

template <class T>
struct dtype_of;
template <>
struct dtype_of<std::uint8_t> {
  static constexpr DType value = DType::uint8;
};
template <>
struct dtype_of<std::uint16_t> {
  static constexpr DType value = DType::uint16;
};
template <>
struct dtype_of<std::uint32_t> {
  static constexpr DType value = DType::uint32;
};
template <>
struct dtype_of<float> {
  static constexpr DType value = DType::float32;
};

/// "uint8", "uint16", "uint32", "float32": the names files (HDF5 element types) and messages use.
std::string dtype_name(DType t);
/// The type of exactly that name, or nothing (a file's element type is checked by its reader).
std::optional<DType> dtype_named(const std::string& name);
/// Parses a dtype name as a user types it (any case; also u8/u16/u32/f32/float); throws
/// UsageError naming the choices.
DType parse_dtype(const std::string& name);
std::size_t dtype_bytes(DType t);

template <class T>
class Volume {
 public:
  using value_type = T;

  Volume() = default;
  explicit Volume(Shape3 shape, Vec3 voxel_size = {1.0, 1.0, 1.0}, Vec3 origin = {0.0, 0.0, 0.0},
                  T fill = T{})
      : shape_(shape),
        voxel_size_(voxel_size),
        origin_(origin),
        data_(shape[0] * shape[1] * shape[2], fill) {}

  const Shape3& shape() const { return shape_; }
  std::size_t nz() const { return shape_[0]; }
  std::size_t ny() const { return shape_[1]; }
  std::size_t nx() const { return shape_[2]; }
  std::size_t size() const { return data_.size(); }
  bool empty() const { return data_.empty(); }

  /// Voxel size in metres, (dz, dy, dx).
  const Vec3& voxel_size() const { return voxel_size_; }
  void set_voxel_size(const Vec3& v) { voxel_size_ = v; }
  /// Centre of voxel (0,0,0) in metres, (z0, y0, x0).
  const Vec3& origin() const { return origin_; }
  void set_origin(const Vec3& o) { origin_ = o; }

  std::size_t index(std::size_t z, std::size_t y, std::size_t x) const {
    return (z * shape_[1] + y) * shape_[2] + x;
  }
  T& operator()(std::size_t z, std::size_t y, std::size_t x) { return data_[index(z, y, x)]; }
  const T& operator()(std::size_t z, std::size_t y, std::size_t x) const {
    return data_[index(z, y, x)];
  }
  T* data() { return data_.data(); }
  const T* data() const { return data_.data(); }
  std::vector<T>& values() { return data_; }
  const std::vector<T>& values() const { return data_; }

  /// Physical position (x, y, z) in metres of the centre of voxel (z, y, x).
  Vec3 position_xyz(double z, double y, double x) const {
    return {origin_[2] + x * voxel_size_[2], origin_[1] + y * voxel_size_[1],
            origin_[0] + z * voxel_size_[0]};
  }

 private:
  Shape3 shape_{0, 0, 0};
  Vec3 voxel_size_{1.0, 1.0, 1.0};
  Vec3 origin_{0.0, 0.0, 0.0};
  std::vector<T> data_;
};

/// A volume whose element type is known only at run time (file conversion, volinfo).
using AnyVolume = std::variant<Volume<std::uint8_t>, Volume<std::uint16_t>, Volume<std::uint32_t>,
                               Volume<float>>;

DType dtype_of_any(const AnyVolume& v);
const Shape3& shape_of_any(const AnyVolume& v);

}  // namespace graintwin
