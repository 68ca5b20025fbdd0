#pragma once
// Small synthetic inputs with known content, written in the foreign formats volconvert reads.
#include <filesystem>

#include "graintwin/core/volume.hpp"

namespace graintwin::test {

/// A volume whose every voxel value encodes its position (so any reordering is caught).
template <class T>
Volume<T> ramp_volume(Shape3 shape, Vec3 voxel_size = {2e-5, 2e-5, 2e-5});

/// Writes `v` as a MetaImage pair name.mhd + name.raw in `dir`; returns the .mhd path.
std::filesystem::path write_mhd(const std::filesystem::path& dir, const std::string& name, const AnyVolume& v);

/// Element-wise equality of two volumes of the same type (shape and values; geometry not compared).
bool same_voxels(const AnyVolume& a, const AnyVolume& b);

}  // namespace graintwin::test
