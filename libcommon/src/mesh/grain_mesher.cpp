#include "graintwin/mesh/grain_mesher.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <optional>

#include <fmt/format.h>

#include <Eigen/Geometry>

#include "graintwin/core/error.hpp"
#include "graintwin/core/resources.hpp"
#include "graintwin/mesh/grain_surface.hpp"
#include "graintwin/mesh/neighbour_cut.hpp"
#include "graintwin/mesh/surface_remesh.hpp"
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

/// Edge of the remeshed boundary for element size h: gmsh's surface meshes at h carry 1.64 A / h^2
/// corner nodes, equilateral triangles of edge a carry 1.155 A / a^2, so a = sqrt(1.155 / 1.64) h
/// gives the kept boundary the surface nodes of a gmsh_surface mesh of the same h.
constexpr double kRemeshEdgePerSize = 0.84;

/// The kept-surface path's time cap as the fallback of an overrun: the budget, but never less than
/// this (s).
constexpr double kKeptPathMinSeconds = 10.0;
/// A 10-node kept-surface mesh whose volume misses its surface's by more than this is meshed again at
/// 0.7 h (coarse 10-node meshes of irregular voxel grains lost up to 20 %, where snapping bent
/// thin elements and their mid-edge nodes were pulled back straight).
constexpr double kRemeshVolumeError = 0.05;
/// Spacing of the voxel surface's samples for element size h (voxel_surface's stride), in voxels
/// at most kMaxSourceStride: sampled coarser, the smoothed voxels of a large non-star grain cut
/// across the concavities where its small neighbours sit, and its mesh reached three voxels into
/// them on the soil crop (at most 2, one voxel or so like the SH grains, once sampled every 2).
constexpr double kSourceSpacingPerSize = 0.4;
constexpr int kMaxSourceStride = 2;

constexpr std::array<EnumName<SizeRule>, 6> kSizeRuleNames{{{SizeRule::contact, "contact"},
                                                             {SizeRule::accuracy, "accuracy"},
                                                             {SizeRule::coarsest, "coarsest"},
                                                             {SizeRule::finest, "finest"},
                                                             {SizeRule::given, "given"},
                                                             {SizeRule::neighbours, "neighbours"}}};
constexpr std::array<EnumName<SurfaceOrigin>, 3> kSurfaceOriginNames{
    {{SurfaceOrigin::sh, "sh"}, {SurfaceOrigin::voxels, "voxels"}, {SurfaceOrigin::ellipsoid, "ellipsoid"}}};
constexpr std::array<EnumName<MeshPath>, 3> kMeshPathNames{
    {{MeshPath::gmsh_surface, "gmsh surface"}, {MeshPath::kept_surface, "kept surface"}, {MeshPath::ellipsoid, "ellipsoid"}}};

/// Elements that fail a requirement: inverted, under the gamma floor, or slivers the pass could
/// not lift (kept meshes are compared by these first: on the soil crop, a grain's finer remesh
/// kept for its volume had a sliver at 0.18 of the median altitude where the first had none).
std::size_t failing(const MeshQuality& q) { return q.inverted + q.below_floor + q.below_thresholds; }

bool worse(const MeshQuality& a, const MeshQuality& b) { return failing(a) > failing(b); }

}  // namespace

const char* size_rule_name(SizeRule rule) { return enum_name(kSizeRuleNames, rule); }
const char* surface_origin_name(SurfaceOrigin origin) { return enum_name(kSurfaceOriginNames, origin); }
const char* mesh_path_name(MeshPath path) { return enum_name(kMeshPathNames, path); }

ElementSize choose_element_size(double area, double diameter, double curvature_per_volume, int order, const SizeTargets& t) {
  if (!(diameter > 0.0)) throw DataError("choose_element_size: a grain without a positive diameter");
  if (t.elements_per_diameter > 0.0) return {diameter / t.elements_per_diameter, SizeRule::given};
  ElementSize s{std::sqrt(kSurfaceNodesPerArea[order == 2] * area / t.surface_nodes), SizeRule::contact};
  if (order == 1 && curvature_per_volume > 0.0) {
    const double h_accuracy = std::sqrt(t.volume_tolerance / (kFacetVolumeLoss * curvature_per_volume));
    if (h_accuracy < s.h) s = {h_accuracy, SizeRule::accuracy};
  }
  if (s.h > diameter / t.min_per_diameter) s = {diameter / t.min_per_diameter, SizeRule::coarsest};
  if (t.coarsest_size > 0.0 && s.h > t.coarsest_size) s = {t.coarsest_size, SizeRule::neighbours};
  if (s.h < diameter / t.max_per_diameter) s = {diameter / t.max_per_diameter, SizeRule::finest};
  return s;
}

double neighbour_size_cap(double d50, double factor, int order, const SizeTargets& targets) {
  if (!(factor > 0.0)) return 0.0;
  SizeTargets own = targets;
  own.coarsest_size = 0.0;
  return factor * choose_element_size(M_PI * d50 * d50, d50, 12.0 / (d50 * d50), order, own).h;
}

double expected_elements_per_grain(int order, const SizeTargets& targets) {
  // Every rule but the cap scales with the diameter: d / h does not depend on it (the cap binds
  // only on grains a few times the typical one).
  const double d = 1.0;
  SizeTargets typical = targets;
  typical.coarsest_size = 0.0;
  const double per_diameter = d / choose_element_size(M_PI * d * d, d, 12.0 / (d * d), order, typical).h;
  return 3.0 * per_diameter * per_diameter * per_diameter;
}

void check_meshing_memory(std::size_t grains, int workers, int order, const SizeTargets& targets) {
  // Measured bytes per element: the model with its per-grain tables (about 80 B for 4-node
  // elements, twice that for 10-node ones, with margin), and gmsh's own structures in a worker.
  const double model_bytes = order == 2 ? 300.0 : 150.0, gmsh_bytes = 2000.0;
  const double per_grain = expected_elements_per_grain(order, targets);
  const double elements = static_cast<double>(grains) * per_grain;
  check_memory(elements * model_bytes + static_cast<double>(std::max(workers, 1)) * 2.5 * per_grain * gmsh_bytes, "shapes2mesh",
               fmt::format("about {:.3g} elements ({} grains of about {:.3g} elements, {:.3g} per diameter)", elements, grains,
                           per_grain, std::cbrt(per_grain / 3.0)),
               "give a smaller --elements-per-diameter, or fewer --surface-nodes");
}

ShSurfaceBasis::ShSurfaceBasis(int subdivisions, int degree)
    : sphere(shape::icosphere(subdivisions)), basis(shape::sh_design_matrix(degree, sphere.directions)) {}

GrainMeshResult mesh_grain(const shape::GrainShape& grain, const ShSurfaceBasis& sh, const Volume<std::uint32_t>* labels,
                           const std::array<std::size_t, 6>& bbox, const GrainMeshOptions& options) {
  using Clock = std::chrono::steady_clock;
  const Clock::time_point started = Clock::now();
  const auto deadline_in = [](double seconds) {  // 0: none
    return seconds > 0.0 ? Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds))
                         : Clock::time_point::max();
  };
  GrainMeshResult r;
  const auto add_note = [&](const std::string& what) { r.note += std::string(r.note.empty() ? "" : "; ") + what; };
  const bool tiny = grain.equivalent_diameter < options.rigid_diameter;
  const int order = tiny ? 1 : options.order;
  r.kind = tiny ? fdem::GrainKind::rigid : order == 2 ? fdem::GrainKind::tet10 : fdem::GrainKind::tet4;
  SizeTargets targets = options.size;
  if (tiny) targets.elements_per_diameter = targets.min_per_diameter;
  const auto size_for = [&](const TriangleSurface& s, double volume) {
    return choose_element_size(surface_area(s), grain.equivalent_diameter, total_mean_curvature(s) / volume, order, targets);
  };
  // The boundary with the neighbours' voxels, out to where any of the grain's surfaces can reach
  // (the voxel surface's padding, 2 + 3 sigma voxels, and a voxel more for the SH fit's overshoot).
  std::optional<NeighbourCut> cut;
  if (labels && options.cut_at_neighbours) {
    cut.emplace(*labels, grain.label, bbox, static_cast<std::size_t>(3.0 + std::ceil(3.0 * options.smooth_vox)));
    if (!cut->any()) cut.reset();
  }
  const int degree = static_cast<int>(std::lround(std::sqrt(static_cast<double>(grain.coeffs.size())))) - 1;
  const auto on_sh_surface = [&](const Eigen::Vector3d& p) -> Eigen::Vector3d {
    const Eigen::Vector3d d = (p - grain.centroid).normalized();
    const double r = shape::sh_radius(grain.coeffs, degree, d);
    return grain.centroid + (cut ? cut->radial_limit(grain.centroid, d, r) : r) * d;
  };
  // Meshes with `run` at r.size.h, then once more at 0.7 h when elements miss the quality floor or
  // stay slivers (keeping the better mesh; a failed or overrun remesh keeps the first).
  // Kept surfaces, 10-node, automatic size: also when the mesh misses the surface's volume by more
  // than kRemeshVolumeError (4-node meshes have --volume-tol in their size rule; a given size is
  // the user's choice).
  const auto mesh_and_check = [&](const std::function<TetMesh(double)>& run) {
    r.mesh = run(r.size.h);
    r.quality = mesh_quality(r.mesh, options.gamma_floor, options.slivers);
    const auto off_volume = [&](const MeshQuality& q) {
      return r.path == MeshPath::kept_surface && order == 2 && r.size.rule != SizeRule::given &&
             std::abs(q.volume / r.surface_volume - 1.0) > kRemeshVolumeError;
    };
    const auto note_slivers = [&] {
      if (r.quality.below_thresholds > 0)
        add_note(fmt::format("{} elements below the sliver thresholds (worst: min dihedral {:.1f} deg, min altitude {:.2f} of the median)",
                             r.quality.below_thresholds, r.quality.min_dihedral, r.quality.min_altitude / r.quality.median_altitude));
    };
    if (failing(r.quality) == 0 && !off_volume(r.quality)) return note_slivers();
    const TetReport first = r.gmsh;
    r.remeshed = true;
    try {
      TetMesh finer = run(0.7 * r.size.h);
      const MeshQuality q = mesh_quality(finer, options.gamma_floor, options.slivers);
      if (worse(r.quality, q) || (!worse(q, r.quality) && off_volume(r.quality) &&
                                  std::abs(q.volume / r.surface_volume - 1.0) < std::abs(r.quality.volume / r.surface_volume - 1.0))) {
        r.mesh = std::move(finer), r.quality = q, r.size.h *= 0.7;
      } else {
        r.gmsh = first;
      }
    } catch (const DataError& e) {  // the first mesh stays (GmshOverrun included)
      r.gmsh = first;
      add_note("remeshing at 0.7 h failed: " + e.message());
    }
    if (r.quality.inverted > 0 || r.quality.below_floor > 0)
      add_note(std::to_string(r.quality.below_floor) + " elements below the gamma floor, " + std::to_string(r.quality.inverted) + " inverted");
    note_slivers();
  };

  // 1. The SH surface, remeshed by gmsh, within the budget.
  TriangleSurface sh_candidate;
  bool sh_ok = false;
  if (grain.flags & shape::shape_flag::unreliable_fit) {
    add_note("SH fit flagged unreliable");
  } else {
    sh_candidate = sh_surface(sh.sphere, sh.basis, grain.coeffs, grain.centroid);
    if (cut) {
      const double whole = enclosed_volume(sh_candidate);
      cut_radial_surface(sh_candidate, grain.centroid, *cut);
      r.cut_share = whole > 0.0 ? 1.0 - enclosed_volume(sh_candidate) / whole : 0.0;
    }
    const SurfaceCheck c = check_surface(sh_candidate);
    sh_ok = c.ok();
    if (!sh_ok) {
      add_note("SH surface has " + c.problems());
    } else if (options.sh_path == MeshPath::gmsh_surface) {
      r.origin = SurfaceOrigin::sh, r.path = MeshPath::gmsh_surface;
      r.surface_volume = enclosed_volume(sh_candidate);
      r.size = size_for(sh_candidate, r.surface_volume);
      const Clock::time_point deadline = deadline_in(options.budget_seconds);
      try {
        mesh_and_check([&](double h) {
          TetOptions o;
          o.size = h, o.order = order, o.slivers = options.slivers, o.deadline = deadline;
          if (options.snap_to_sh) o.project = on_sh_surface;
          return tetrahedralize(sh_candidate, o, &r.gmsh, options.workers);
        });
        r.seconds = std::chrono::duration<double>(Clock::now() - started).count();
        return r;
      } catch (const GmshOverrun&) {
        r.overran = true;
        add_note(fmt::format("gmsh overran the {:g} s budget on the SH surface", options.budget_seconds));
      } catch (const DataError& e) {
        add_note(e.message());
      }
    }
  }

  // 2. A surface remeshed to about h and kept as the boundary: the SH surface when it passed the
  // checks (the default for SH grains; or gmsh overran or failed on it), else the grain's smoothed
  // voxels (their main piece).
  TriangleSurface source;
  const bool sh_kept = sh_ok;
  if (sh_kept) {
    source = std::move(sh_candidate);
    r.origin = SurfaceOrigin::sh;
  } else if (labels) {
    // Sampled every 0.4 h or so (h estimated from the grain's measured area): about 25 times the
    // triangles of the remeshed boundary, which is then quick to make and still follows it.
    const double h_estimate = choose_element_size(grain.surface_area, grain.equivalent_diameter,
                                                  12.0 / (grain.equivalent_diameter * grain.equivalent_diameter), order, targets).h;
    const double voxel = labels->voxel_size()[0];
    const int stride = std::clamp(static_cast<int>(std::lround(kSourceSpacingPerSize * h_estimate / voxel)), 1, kMaxSourceStride);
    source = largest_piece(voxel_surface(*labels, grain.label, bbox, options.smooth_vox, stride, true));
    r.origin = SurfaceOrigin::voxels;
    if (cut) {
      // Vertex by vertex: cutting the field instead split thin parts of large grains (the coarse
      // samples fell in the neighbours). A cut that folds the surface is not kept.
      TriangleSurface cut_source = source;
      if (cut_surface(cut_source, *cut) > 0) {
        const SurfaceCheck c = check_surface(cut_source);
        if (c.embedded()) {
          const double whole = enclosed_volume(source);
          r.cut_share = whole > 0.0 ? 1.0 - enclosed_volume(cut_source) / whole : 0.0;
          source = std::move(cut_source);
        } else {
          add_note("the voxel surface cut at the neighbours has " + c.problems() + "; kept uncut");
        }
      }
    }
  }
  const SurfaceCheck source_check = sh_kept || source.triangles.empty() ? SurfaceCheck{} : check_surface(source);
  if (!sh_kept && !source.triangles.empty() && !source_check.embedded()) {
    add_note(std::string(surface_origin_name(r.origin)) + " surface has " + source_check.problems());
  } else if (!source.triangles.empty()) {
    r.path = MeshPath::kept_surface;
    r.surface_volume = enclosed_volume(source);
    if (r.origin == SurfaceOrigin::voxels) {
      // The smoothed voxels carry no detail finer than about two voxels; their edges' curvature
      // would otherwise drive the 4-node volume rule to elements under a voxel.
      targets.max_per_diameter = std::min(targets.max_per_diameter, grain.equivalent_diameter / (2.0 * labels->voxel_size()[0]));
      targets.max_per_diameter = std::max(targets.max_per_diameter, targets.min_per_diameter);
    }
    r.size = size_for(source, r.surface_volume);
    const std::function<Eigen::Vector3d(const Eigen::Vector3d&)> onto =
        r.origin == SurfaceOrigin::sh ? std::function<Eigen::Vector3d(const Eigen::Vector3d&)>(on_sh_surface) : closest_point_on(source);
    // The budget; as the fallback of an overrun, at least kKeptPathMinSeconds: this path is cheap
    // (hundredths of a second), and must not fail a grain whose first path just spent a short
    // budget (a freshly forked worker on a loaded machine).
    const double cap = r.overran ? std::max(options.budget_seconds, kKeptPathMinSeconds) : options.budget_seconds;
    const Clock::time_point deadline = deadline_in(options.budget_seconds > 0.0 ? cap : 0.0);
    try {
      mesh_and_check([&](double h) {
        // Finer until embedded: collapses in thin parts of a coarse remesh can cross the surface,
        // and gmsh can still refuse facets that nearly touch (a PLC error): finer once more then.
        for (double edge = kRemeshEdgePerSize * h, refused = 0;; edge *= 0.7) {
          const TriangleSurface boundary = remesh_isotropic(source, edge, 3);
          const SurfaceCheck c = check_surface(boundary);
          const bool last = edge < 0.3 * kRemeshEdgePerSize * h;
          if (!c.embedded()) {
            if (last) throw DataError("the surface remeshed at 0.34 h still has " + c.problems());
            continue;
          }
          TetOptions o;
          o.size = std::min(h, edge / kRemeshEdgePerSize), o.order = order, o.slivers = options.slivers, o.keep_surface = true, o.project = onto, o.deadline = deadline;
          try {
            return tetrahedralize(boundary, o, &r.gmsh, options.workers);
          } catch (const GmshOverrun&) {
            throw;
          } catch (const DataError&) {
            if (last || ++refused > 1) throw;
          }
        }
      });
      r.seconds = std::chrono::duration<double>(Clock::now() - started).count();
      return r;
    } catch (const GmshOverrun&) {
      r.overran = true;
      add_note(fmt::format("gmsh overran its {:g} s on the {} surface kept as the boundary", cap, surface_origin_name(r.origin)));
    } catch (const DataError& e) {
      add_note(std::string(surface_origin_name(r.origin)) + " surface kept as the boundary: " + e.message());
    }
  }

  // 3. The inertia ellipsoid (gmsh's exact sphere, scaled): no surface of the grain was usable.
  r.origin = SurfaceOrigin::ellipsoid, r.path = MeshPath::ellipsoid;
  r.cut_share = 0.0;
  r.surface_volume = 4.0 / 3.0 * M_PI * grain.semi_axes.prod();
  // Without a surface, the curvature of the sphere of the grain's diameter (3 / R^2).
  r.size = choose_element_size(grain.surface_area, grain.equivalent_diameter, 12.0 / (grain.equivalent_diameter * grain.equivalent_diameter),
                               order, targets);
  // At least two elements through its thinnest axis: gmsh makes no tetrahedra for a body thinner than h.
  if (r.size.h > grain.semi_axes.minCoeff()) r.size = {grain.semi_axes.minCoeff(), SizeRule::finest};
  r.remeshed = false;
  const Eigen::Quaterniond axes(grain.axes);
  try {
    mesh_and_check([&](double h) {
      TetOptions o;
      o.size = h, o.order = order, o.slivers = options.slivers;
      return mesh_ellipsoid(grain.centroid, grain.semi_axes, axes, o, &r.gmsh, options.workers);
    });
  } catch (const DataError& e) {
    throw DataError(e.message() + " (" + r.note + ")");
  }
  r.seconds = std::chrono::duration<double>(Clock::now() - started).count();
  return r;
}

}  // namespace graintwin::mesh
