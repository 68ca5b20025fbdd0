#include "graintwin/core/volume.hpp"

#include "graintwin/core/error.hpp"
#include "graintwin/core/strings.hpp"

namespace graintwin {

std::string dtype_name(DType t) {
  switch (t) {
    case DType::uint8: return "uint8";
    case DType::uint16: return "uint16";
    case DType::uint32: return "uint32";
    case DType::float32: return "float32";
  }
  return "unknown";
}

DType parse_dtype(const std::string& name) {
  const std::string n = lower(trim(name));
  if (n == "uint8" || n == "u8") return DType::uint8;
  if (n == "uint16" || n == "u16") return DType::uint16;
  if (n == "uint32" || n == "u32") return DType::uint32;
  if (n == "float32" || n == "f32" || n == "float") return DType::float32;
  throw UsageError("unknown data type '" + name + "'; use uint8, uint16, uint32 or float32");
}

std::size_t dtype_bytes(DType t) {
  switch (t) {
    case DType::uint8: return 1;
    case DType::uint16: return 2;
    case DType::uint32: return 4;
    case DType::float32: return 4;
  }
  return 0;
}

DType dtype_of_any(const AnyVolume& v) {
  return std::visit([](const auto& vol) { return dtype_of<typename std::decay_t<decltype(vol)>::value_type>::value; }, v);
}

const Shape3& shape_of_any(const AnyVolume& v) {
  return std::visit([](const auto& vol) -> const Shape3& { return vol.shape(); }, v);
}

}  // namespace graintwin
