#include "graintwin/core/volume.hpp"

#include <array>

#include "graintwin/core/enum_names.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/strings.hpp"

namespace graintwin {

namespace {

constexpr std::array<EnumName<DType>, 4> kDTypeNames{
    {{DType::uint8, "uint8"}, {DType::uint16, "uint16"}, {DType::uint32, "uint32"}, {DType::float32, "float32"}}};
/// Short spellings a user may type (--dtype u16); files and messages use the names above.
constexpr std::array<EnumName<DType>, 5> kDTypeShortNames{
    {{DType::uint8, "u8"}, {DType::uint16, "u16"}, {DType::uint32, "u32"}, {DType::float32, "f32"}, {DType::float32, "float"}}};

}  // namespace

std::string dtype_name(DType t) { return enum_name(kDTypeNames, t); }

std::optional<DType> dtype_named(const std::string& name) { return find_enum(kDTypeNames, name); }

DType parse_dtype(const std::string& name) {
  const std::string n = lower(trim(name));
  if (const std::optional<DType> t = find_enum(kDTypeShortNames, n)) return *t;
  return parse_enum(kDTypeNames, n, "unknown data type");
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
