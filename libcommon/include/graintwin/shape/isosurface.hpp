#pragma once
// Isosurfaces of a scalar field on a voxel grid by marching tetrahedra: each cube of 8 voxel
// centres is split into 6 tetrahedra around its main diagonal (Kuhn split, the same in every cube,
// so the surface has no cracks and needs no case tables or ambiguity rules), and each tetrahedron
// contributes 0, 1 or 2 triangles with vertices interpolated linearly on its edges. Used for the
// surface area of grains (docs/methods.md: from an isosurface, not from voxel faces).
#include <array>
#include <functional>

#include <Eigen/Core>

#include "graintwin/core/volume.hpp"

namespace graintwin::shape {

/// Area and enclosed volume of an isosurface (m^2, m^3).
struct IsoMeasures {
  double area = 0.0;
  double volume = 0.0;  ///< of the region where field >= iso (divergence theorem over the surface)
  std::size_t triangles = 0;
};

/// A triangle of the surface in physical coordinates (x, y, z), oriented with its normal
/// (b - a) x (c - a) pointing out of the region field >= iso.
using Triangle = std::array<Eigen::Vector3d, 3>;

/// Walks the isosurface field == iso of `field` (positions from its voxel size and origin) and
/// calls `emit` per triangle (optional). The region field >= iso must not touch the field's faces
/// for the volume to be that of a closed surface (pad the box by a voxel of low values).
IsoMeasures isosurface(const Volume<float>& field, float iso,
                       const std::function<void(const Triangle&)>& emit = nullptr);

}  // namespace graintwin::shape
