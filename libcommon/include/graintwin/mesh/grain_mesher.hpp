#pragma once
// One CT grain to a checked tetrahedral mesh: choose its surface (SH fit, else smoothed voxels,
// else the inertia ellipsoid), check it, choose the element size, mesh it with gmsh (within a time
// budget), measure the quality and remesh finer once when it misses the floor. Tiny grains get a coarse
// linear mesh and are marked rigid.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "graintwin/core/enum_names.hpp"
#include "graintwin/core/volume.hpp"
#include "graintwin/fdem/model.hpp"
#include "graintwin/mesh/gmsh_adapter.hpp"
#include "graintwin/mesh/tet_mesh.hpp"
#include "graintwin/shape/grain_measure.hpp"
#include "graintwin/shape/sh_surface.hpp"

namespace graintwin::mesh {

/// What sets a grain's element size h (m). gmsh's surface meshes of edge target h over area A
/// carry about 1.64 A / h^2 nodes (4-node) and 7.7 A / h^2 (10-node, with mid-edge nodes),
/// measured on spheres near 250 nodes. Linear facets with corners on the surface cut off a cap of
/// mean height a^2 H / 8 over mean curvature H for triangles of edge a, so a linear mesh loses
/// c h^2 (integral of H dA) of its volume V, c = 0.094 measured on average (gmsh's edges come out
/// near 0.87 h), at most 0.106: the size rule uses 0.11. Curved 10-node faces follow the surface
/// closely at any h used here.
struct SizeTargets {
  double surface_nodes = 250.0;     ///< what contact needs per grain (the performance reference)
  double volume_tolerance = 0.02;   ///< largest relative volume error of a linear mesh
  double elements_per_diameter = 0; ///< > 0: h = equivalent diameter / this, overriding the rules
  double min_per_diameter = 3.0;    ///< never coarser than this (gmsh needs a few elements across)
  double max_per_diameter = 40.0;   ///< never finer than this (no grain gets more than the scene needs)
  /// > 0: never coarser than this (m), whatever the grain's own size: a grain many times the d50
  /// meets grains of the d50 over patches their size, which 250 nodes spread over its whole surface
  /// do not resolve (neighbour_size_cap).
  double coarsest_size = 0.0;
};

enum class SizeRule : std::uint8_t { contact = 0, accuracy = 1, coarsest = 2, finest = 3, given = 4, neighbours = 5 };
const char* size_rule_name(SizeRule rule);

struct ElementSize {
  double h = 0.0;
  SizeRule rule = SizeRule::contact;
};
/// h for a grain of surface area `area` (m^2) and equivalent diameter `diameter` (m) whose total
/// mean curvature over volume, (integral of H dA) / V, is `curvature_per_volume` (1/m^2; 3 / R^2 for
/// a sphere; the volume rule is skipped when it is not positive).
ElementSize choose_element_size(double area, double diameter, double curvature_per_volume, int order, const SizeTargets& targets);

/// SizeTargets::coarsest_size for a sample of this `d50` (m): `factor` times the automatic element
/// size of a sphere of diameter d50, so that grains up to `factor` d50 keep their own size and larger
/// ones resolve their contacts with d50 grains about as those grains do. 0 for factor 0 (no cap).
double neighbour_size_cap(double d50, double factor, int order, const SizeTargets& targets);

/// Elements a typical grain gets at `targets`: a sphere's size rule gives d / h, and gmsh fills a
/// grain with about 3 (d / h)^3 elements (2.8 to 3.3 on sand_small at 8 and 16 per diameter).
double expected_elements_per_grain(int order, const SizeTargets& targets);

/// Refuses (UsageError, with the numbers) a run whose meshes would not fit in memory: the model's
/// `grains` x expected_elements_per_grain elements, and in each of `workers` gmsh processes the
/// largest grain's mesh (elongated grains get up to 2.5 times the typical count).
void check_meshing_memory(std::size_t grains, int workers, int order, const SizeTargets& targets);

/// Where the meshed surface came from.
enum class SurfaceOrigin : std::uint8_t { sh = 0, voxels = 1, ellipsoid = 2 };
const char* surface_origin_name(SurfaceOrigin origin);

/// How the grain was meshed. gmsh_surface: gmsh classifies and reparametrises the SH surface,
/// remeshes it at h and fills it (GrainMeshOptions::sh_path = gmsh_surface). kept_surface: the
/// surface is remeshed to triangles of about h first (remesh_isotropic) and gmsh only fills it,
/// keeping them (the default for SH and voxel surfaces, and the fallback of a gmsh_surface run that
/// overran the budget or failed): cheap and robust on rough, angular and non-star surfaces of any
/// genus. ellipsoid: the inertia ellipsoid from gmsh's exact sphere, where no usable surface remains.
enum class MeshPath : std::uint8_t { gmsh_surface = 0, kept_surface = 1, ellipsoid = 2 };
const char* mesh_path_name(MeshPath path);

/// shapes2mesh's --sh-meshing names of the two paths a usable SH surface can take (GrainMeshOptions::sh_path).
inline constexpr std::array<EnumName<MeshPath>, 2> kShMeshingNames{
    {{MeshPath::kept_surface, "kept"}, {MeshPath::gmsh_surface, "gmsh"}}};

struct GrainMeshOptions {
  int order = 2;
  SizeTargets size;
  double gamma_floor = 0.1;       ///< elements below this gamma make the grain remeshed once at 0.7 h
  /// Every mesh goes through remove_slivers to these; elements still below them (counted in
  /// MeshQuality::below_thresholds and noted) make the grain meshed again at 0.7 h, as the gamma
  /// floor does, and the mesh with fewer failing elements is kept.
  SliverThresholds slivers;
  double rigid_diameter = 0.0;    ///< grains smaller than this (m) get a coarse linear mesh and are rigid
  double smooth_vox = 0.7;        ///< Gaussian sigma of the voxel surface (voxels)
  /// With labels: every surface is cut where it reaches into a neighbour's labelled voxels
  /// (NeighbourCut), so that neighbours touch at their segmented interface instead of overlapping.
  bool cut_at_neighbours = true;
  /// Grains with an SH surface: boundary nodes moved onto the exact SH surface (TetOptions::project);
  /// for 10-node grains rather than gmsh's curving on the triangulated surface + optimize(HighOrder).
  bool snap_to_sh = true;
  /// How grains with a usable SH surface are meshed: kept_surface (remeshed by CGAL and kept, the
  /// default: about 3 times less CPU than gmsh's reparametrisation on sand-like grains and 5 times
  /// less on real rough ones, same volume error and quality) or gmsh_surface.
  MeshPath sh_path = MeshPath::kept_surface;
  /// > 0: seconds gmsh may take on the grain's first path (its first mesh and any remesh
  /// together); on overrun the worker is killed and the grain falls back: from gmsh_surface to
  /// kept_surface, which then gets the same time again but at least 10 s (it takes hundredths of a
  /// second; a fresh worker on a loaded machine must not fail it), from kept_surface to the
  /// ellipsoid. Enforced in worker processes; in-process runs (no workers) only refuse to start
  /// once it is spent.
  double budget_seconds = 0.0;
  /// gmsh runs in these worker processes (grains in parallel), else in this process under its lock.
  GmshWorkers* workers = nullptr;
};

/// The shared direction set of the SH surfaces: the sphere and its SH design matrix.
struct ShSurfaceBasis {
  shape::SphereMesh sphere;
  Eigen::MatrixXd basis;  ///< directions x (degree + 1)^2
  ShSurfaceBasis(int subdivisions, int degree);
};

struct GrainMeshResult {
  TetMesh mesh;
  fdem::GrainKind kind = fdem::GrainKind::tet4;
  SurfaceOrigin origin = SurfaceOrigin::sh;
  MeshPath path = MeshPath::gmsh_surface;
  bool overran = false;           ///< gmsh overran budget_seconds on a path, and the grain took the next
  double seconds = 0.0;           ///< wall time of mesh_grain for this grain, s
  ElementSize size;
  MeshQuality quality;
  TetReport gmsh;
  double surface_volume = 0.0;    ///< volume enclosed by the surface handed to gmsh, m^3
  /// Share of the surface's volume cut off where it reached into neighbours' labelled voxels
  /// (GrainMeshOptions::cut_at_neighbours; 0 without labels, or for the ellipsoid).
  double cut_share = 0.0;
  bool remeshed = false;          ///< meshed again at 0.7 h for quality
  std::string note;               ///< why the SH surface was not used, or what is wrong ("" = nothing)
};

/// Meshes one grain. `labels` (may be null) enables the voxel surface for grains whose SH fit is
/// flagged unreliable or whose SH surface fails check_surface, and the cut at the neighbours
/// (options.cut_at_neighbours); `bbox` is the grain's box in it. SH
/// surfaces take options.sh_path (gmsh_surface under budget_seconds, falling back to kept_surface),
/// voxel surfaces kept_surface; the inertia ellipsoid is the last resort.
/// Thread-safe (the gmsh part runs one grain at a time per worker process, or in this process).
GrainMeshResult mesh_grain(const shape::GrainShape& grain, const ShSurfaceBasis& sh, const Volume<std::uint32_t>* labels,
                           const std::array<std::size_t, 6>& bbox, const GrainMeshOptions& options);

}  // namespace graintwin::mesh
