#include "graintwin/mesh/grain_mesher.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "graintwin/core/error.hpp"
#include "graintwin/mesh/grain_surface.hpp"
#include "graintwin/shape/sh_basis.hpp"

namespace graintwin::mesh {
namespace {

/// Relative volume lost by linear facets of edge target h: c h^2 (integral of H dA) / V. Measured
/// on 36 gmsh meshes (9 SH grains from sphere-like to bumpy, targets 1-3 %): c = 0.094 on average,
/// 0.082 to 0.106; sized with the largest, rounded up, so that the target bounds a grain's error
/// instead of being met on average.
constexpr double kFacetVolumeLoss = 0.11;
/// Surface nodes of gmsh's meshes of edge target h over area A: k A / h^2, k measured on spheres at
/// about 250 nodes (gmsh's triangles come out smaller than equilateral ones of edge h, for which
/// k would be 2 / sqrt(3) = 1.15 at 4 nodes).
constexpr double kSurfaceNodesPerArea[2] = {1.64, 7.7};

bool worse(const MeshQuality& a, const MeshQuality& b) {
  return a.inverted + a.below_floor > b.inverted + b.below_floor;
}

}  // namespace

const char* size_rule_name(SizeRule rule) {
  switch (rule) {
    case SizeRule::contact: return "contact";
    case SizeRule::accuracy: return "accuracy";
    case SizeRule::coarsest: return "coarsest";
    case SizeRule::finest: return "finest";
    case SizeRule::given: return "given";
  }
  return "?";
}

const char* surface_origin_name(SurfaceOrigin origin) {
  switch (origin) {
    case SurfaceOrigin::sh: return "sh";
    case SurfaceOrigin::voxels: return "voxels";
    case SurfaceOrigin::ellipsoid: return "ellipsoid";
  }
  return "?";
}

ElementSize choose_element_size(double area, double diameter, double curvature_per_volume, int order, const SizeTargets& t) {
  if (!(diameter > 0.0)) throw DataError("choose_element_size: a grain without a positive diameter");
  if (t.elements_per_diameter > 0.0) return {diameter / t.elements_per_diameter, SizeRule::given};
  ElementSize s{std::sqrt(kSurfaceNodesPerArea[order == 2] * area / t.surface_nodes), SizeRule::contact};
  if (order == 1 && curvature_per_volume > 0.0) {
    const double h_accuracy = std::sqrt(t.volume_tolerance / (kFacetVolumeLoss * curvature_per_volume));
    if (h_accuracy < s.h) s = {h_accuracy, SizeRule::accuracy};
  }
  if (s.h > diameter / t.min_per_diameter) s = {diameter / t.min_per_diameter, SizeRule::coarsest};
  if (s.h < diameter / t.max_per_diameter) s = {diameter / t.max_per_diameter, SizeRule::finest};
  return s;
}

ShSurfaceBasis::ShSurfaceBasis(int subdivisions, int degree)
    : sphere(shape::icosphere(subdivisions)), basis(shape::sh_design_matrix(degree, sphere.directions)) {}

GrainMeshResult mesh_grain(const shape::GrainShape& grain, const ShSurfaceBasis& sh, const Volume<std::uint32_t>* labels,
                           const std::array<std::size_t, 6>& bbox, const GrainMeshOptions& options) {
  GrainMeshResult r;
  const bool tiny = grain.equivalent_diameter < options.rigid_diameter;
  const int order = tiny ? 1 : options.order;
  r.kind = tiny ? fdem::GrainKind::rigid : order == 2 ? fdem::GrainKind::tet10 : fdem::GrainKind::tet4;

  // The surface: SH fit, else smoothed voxels, else (no usable surface) the inertia ellipsoid.
  TriangleSurface surface;
  bool have_surface = false;
  const auto accept = [&](TriangleSurface candidate, SurfaceOrigin origin, const char* what) {
    const SurfaceCheck c = check_surface(candidate);
    if (c.ok()) {
      surface = std::move(candidate), r.origin = origin, have_surface = true;
      return;
    }
    r.note += std::string(r.note.empty() ? "" : "; ") + what + " surface has " + c.problems();
  };
  if (grain.flags & shape::shape_flag::unreliable_fit) r.note = "SH fit flagged unreliable";
  else accept(sh_surface(sh.sphere, sh.basis, grain.coeffs, grain.centroid), SurfaceOrigin::sh, "SH");
  if (!have_surface && labels) accept(voxel_surface(*labels, grain.label, bbox, options.smooth_vox), SurfaceOrigin::voxels, "voxel");
  if (!have_surface) r.origin = SurfaceOrigin::ellipsoid;

  SizeTargets targets = options.size;
  if (tiny) targets.elements_per_diameter = targets.min_per_diameter;
  r.surface_volume = have_surface ? enclosed_volume(surface) : 4.0 / 3.0 * M_PI * grain.semi_axes.prod();
  // Without a surface, the curvature of the sphere of the grain's diameter (3 / R^2).
  const double curvature_per_volume = have_surface ? total_mean_curvature(surface) / r.surface_volume
                                                   : 12.0 / (grain.equivalent_diameter * grain.equivalent_diameter);
  r.size = choose_element_size(have_surface ? surface_area(surface) : grain.surface_area, grain.equivalent_diameter,
                               curvature_per_volume, order, targets);
  const Eigen::Quaterniond axes(grain.axes);
  const int degree = static_cast<int>(std::lround(std::sqrt(static_cast<double>(grain.coeffs.size())))) - 1;
  const auto on_sh_surface = [&](const Eigen::Vector3d& p) -> Eigen::Vector3d {
    const Eigen::Vector3d d = (p - grain.centroid).normalized();
    return grain.centroid + shape::sh_radius(grain.coeffs, degree, d) * d;
  };
  const auto run = [&](double h) {
    TetOptions o;
    o.size = h, o.order = order;
    if (options.snap_to_sh && r.origin == SurfaceOrigin::sh) o.project = on_sh_surface;
    return r.origin == SurfaceOrigin::ellipsoid ? mesh_ellipsoid(grain.centroid, grain.semi_axes, axes, o, &r.gmsh, options.workers)
                                                : tetrahedralize(surface, o, &r.gmsh, options.workers);
  };
  try {
    r.mesh = run(r.size.h);
  } catch (DataError& e) {
    if (r.origin == SurfaceOrigin::ellipsoid) throw;
    r.note += std::string(r.note.empty() ? "" : "; ") + e.message();
    r.origin = SurfaceOrigin::ellipsoid;
    r.surface_volume = 4.0 / 3.0 * M_PI * grain.semi_axes.prod();
    r.mesh = run(r.size.h);
  }
  r.quality = mesh_quality(r.mesh, options.gamma_floor);
  if (r.quality.inverted > 0 || r.quality.below_floor > 0) {
    const TetReport first = r.gmsh;
    r.remeshed = true;
    try {
      TetMesh finer = run(0.7 * r.size.h);
      const MeshQuality q = mesh_quality(finer, options.gamma_floor);
      if (worse(r.quality, q)) {
        r.mesh = std::move(finer), r.quality = q, r.size.h *= 0.7;
      } else {
        r.gmsh = first;
      }
    } catch (const DataError& e) {  // the first mesh stays
      r.gmsh = first;
      r.note += std::string(r.note.empty() ? "" : "; ") + "remeshing at 0.7 h failed: " + e.message();
    }
    if (r.quality.inverted > 0 || r.quality.below_floor > 0)
      r.note += std::string(r.note.empty() ? "" : "; ") + std::to_string(r.quality.below_floor) + " elements below the gamma floor, " +
                std::to_string(r.quality.inverted) + " inverted";
  }
  return r;
}

}  // namespace graintwin::mesh
