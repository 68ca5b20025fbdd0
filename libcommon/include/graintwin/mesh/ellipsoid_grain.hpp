#pragma once
// Sphere and ellipsoid grains of fdemrun scenes, meshed by gmsh: the mesher fdem::build_model and
// fdem::run_impact take, kept in mesh (which builds on fdem's model) so that fdem never includes
// mesh. Header-only: only programs that link graintwin_mesh (fdemrun, its tests and benches) use it.
#include "graintwin/fdem/scene.hpp"
#include "graintwin/fdem/size_grading.hpp"
#include "graintwin/mesh/gmsh_adapter.hpp"
#include "graintwin/mesh/tet_mesh.hpp"

namespace graintwin::mesh {

/// The gmsh options of a primitive grain: its element size, order 2 (curved) for tet10.
inline TetOptions ellipsoid_mesh_options(const fdem::GrainSpec& spec) {
  TetOptions options;
  options.size = spec.element_size;
  options.order = spec.kind == fdem::GrainKind::tet10 ? 2 : 1;
  return options;
}

/// Appends the ellipsoid of `spec` with its element size graded by `grading` (world coordinates;
/// its coarse size replaces the spec's element size): a mesh fine only where the grain will touch. UsageError for a bad
/// grading, before gmsh runs.
inline void append_graded_ellipsoid_grain(fdem::Model& model, const fdem::GrainSpec& spec, const fdem::SizeGrading& grading) {
  fdem::check_size_grading(grading);
  TetOptions options = ellipsoid_mesh_options(spec);
  options.size = grading.coarse;
  options.size_at = [&grading](const Eigen::Vector3d& x) { return fdem::graded_element_size(grading, x); };
  append_grain(model, mesh_ellipsoid(spec.position, spec.size, spec.orientation, options), spec.label,
                     spec.kind, spec.material);
}

/// Appends the ellipsoid of `spec` (semi-axes `size`, centre, orientation) meshed at its element
/// size, or graded by spec.grading when it has one: 10-node elements curved onto the surface for
/// tet10, 4-node ones for tet4 and rigid.
inline void append_ellipsoid_grain(fdem::Model& model, const fdem::GrainSpec& spec) {
  if (spec.grading) return append_graded_ellipsoid_grain(model, spec, *spec.grading);
  append_grain(model, mesh_ellipsoid(spec.position, spec.size, spec.orientation, ellipsoid_mesh_options(spec)),
                     spec.label, spec.kind, spec.material);
}

}  // namespace graintwin::mesh
