#pragma once
// The report's 3D pictures of the grains' own shapes (docs/report.md, "The grains in 3D"): the
// reference scan's grains (the model's reference surfaces, which shapes2mesh built from that scan)
// beside the FDEM twin's at its last frame, each grain's surface posed at the frame's centroid and
// rotation as the sections pose it, with the membrane's balls; a front quarter cut away so the
// interior and the shear band show; each grain in its reference colour. At 15 000 grains the
// model holds millions of surface triangles, so grains above a share of a triangle budget are
// simplified by vertex clustering (cluster_vertices).
#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

#include "graintwin/report/panels.hpp"
#include "graintwin/report/run_data.hpp"
#include "graintwin/report/sections.hpp"

namespace graintwin::report {

/// The part of the sample a cutaway removes: the quarter in front of the axis (x, y), x above it and
/// y below it. The report's camera looks along +y, so the two cut faces show the interior.
struct FrontQuarter {
  double x = 0.0, y = 0.0;
  bool holds(double px, double py) const { return px > x && py < y; }
};

/// A triangle surface.
struct TriangleSurface {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;
};

/// Vertex clustering (Rossignac and Borrel 1993): the vertices merged per cube of edge `cell` of a
/// grid anchored at the surface's lowest corner, each cluster at the mean of its vertices; the
/// triangles whose corners fall in fewer than three clusters dropped. Linear in the surface's size;
/// the result keeps the shape to within about a cell. Vertices no triangle uses are dropped too.
TriangleSurface cluster_vertices(std::span<const Eigen::Vector3d> vertices, std::span<const std::array<std::uint32_t, 3>> triangles,
                                 double cell);

/// The cell that brings a surface of `area` to about `target` triangles by cluster_vertices: a
/// closed surface of cell-sized triangles has about two per cell of its area.
double clustering_cell(double area, std::size_t target);

/// The total area of a triangle surface.
double surface_area(std::span<const Eigen::Vector3d> vertices, std::span<const std::array<std::uint32_t, 3>> triangles);

/// Triangles drawn per picture (about): a grain above its share (the budget over the grains drawn)
/// is clustered down to it. A picture of 1.1 million triangles took 7 s on one loaded core with
/// Mesa's software renderer; at 15 000 grains this leaves about 150 triangles to a grain that is
/// some 15 pixels across.
inline constexpr std::size_t kSurfaceTriangleBudget = 1'500'000;

/// The centroid of the solid a closed triangle surface encloses (divergence theorem over its
/// triangles). The grains' reference centroids for the 3D pictures: exact for straight-sided (4-node
/// and rigid) grains, and for a 10-node grain that of its surface split through the mid-edge nodes,
/// off the solver's curved-element centroid by a small fraction of the grain (docs/report.md), at a
/// thousandth of the cost (the 3D pictures pose every grain).
Eigen::Vector3d enclosed_centroid(std::span<const Eigen::Vector3d> vertices, std::span<const std::array<std::uint32_t, 3>> triangles);
/// enclosed_centroid of every grain of a model's reference surfaces (in parallel).
std::vector<Eigen::Vector3d> grain_surface_centroids(const fdem::Model& model);

/// The grains of `model` posed by `pose` (every grain's centroid and rotation about its
/// `reference_centroid`), without those whose posed centroid lies in `cut`, each grain of more
/// triangles than `budget` over the grains drawn clustered down to about that many. Triangles
/// carry their grain's label.
SurfacesView posed_surfaces(const fdem::Model& model, const std::vector<Eigen::Vector3d>& reference_centroid, const FramePose& pose,
                            const FrontQuarter& cut, std::size_t budget);

/// One panel: the reference scan's grains (the model's reference surfaces) beside the twin's at the
/// simulation's last frame with its membrane balls (radius from the results' /run/parameters), a
/// front quarter cut away about the model's sample axis (else the middle of its nodes), one camera
/// framing both. A side without its files says which stage makes them.
Panel grain_surface_panel(const RunFiles& files, const ExperimentData& experiment, const SimulationData& simulation);

/// The membrane balls' radius the results' run parameters record (a triaxial test), else 0.
double membrane_ball_radius(const std::filesystem::path& simulation);

/// Writes a picture's triangles for the chart script: HDF5 /vertices (V x 3 float32, m),
/// /triangles (T x 3 uint32) and /label (T uint32).
void write_surface_mesh(const SurfacesView& view, const std::filesystem::path& path);

}  // namespace graintwin::report
