#pragma once
// Sphere and ellipsoid grains of fdemrun scenes, meshed by gmsh. Header-only on purpose: gmsh lives
// in graintwin_mesh, so only programs that link it (fdemrun, its tests and benches) include this.
#include "graintwin/fdem/scene.hpp"
#include "graintwin/mesh/gmsh_adapter.hpp"
#include "graintwin/mesh/tet_mesh.hpp"

namespace graintwin::fdem {

/// Appends the ellipsoid of `spec` (semi-axes `size`, centre, orientation) meshed at its element
/// size: 10-node elements curved onto the surface for tet10, 4-node ones for tet4 and rigid.
inline void append_ellipsoid_grain(Model& model, const GrainSpec& spec) {
  mesh::TetOptions options;
  options.size = spec.element_size;
  options.order = spec.kind == GrainKind::tet10 ? 2 : 1;
  mesh::append_grain(model, mesh::mesh_ellipsoid(spec.position, spec.size, spec.orientation, options), spec.label,
                     spec.kind, spec.material);
}

}  // namespace graintwin::fdem
