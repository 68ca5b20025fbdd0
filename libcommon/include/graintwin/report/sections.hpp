#pragma once
// The report's pictures of the sample itself (docs/report.md, "Sections"): a horizontal and a
// vertical plane through each scan, the scan's labels over its grey values, beside the same planes
// through the FDEM twin's grains at the matching frame; and D2min and eps_q of every grain painted
// on the vertical plane for each strain increment, scans beside simulation on one colour scale.
// The experiment's section is a slice of the label image (the chart script reads it); the twin's is
// where the plane cuts its grains' surfaces, each the model's reference surface turned and moved
// to the frame's rotation and centroid (cut_surface, twin_section), computed here.
#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "graintwin/fdem/model.hpp"
#include "graintwin/fdem/results_file.hpp"
#include "graintwin/report/panels.hpp"
#include "graintwin/report/run_data.hpp"

namespace graintwin::report {

namespace fs = std::filesystem;

/// The coordinates (u, v) of a section plane: x and z on the vertical plane y = offset ("xz"),
/// x and y on the horizontal plane z = offset ("xy").
enum class SectionPlane { xz, xy };
/// The axis normal to a plane (1 = y, 2 = z) and the two in it, in (u, v) order.
int normal_axis(SectionPlane plane);
std::array<int, 2> plane_axes(SectionPlane plane);

/// The closed outlines where the plane cuts a closed triangle surface, (u, v) in the plane's
/// coordinates. A vertex on the plane counts as above it, so every outline is closed; an open
/// surface gives open polylines. Each crossing point is computed from its edge's two vertices in
/// index order, so the two triangles sharing an edge agree exactly.
std::vector<std::vector<Eigen::Vector2d>> cut_surface(std::span<const Eigen::Vector3d> vertices,
                                                      std::span<const std::array<std::uint32_t, 3>> triangles, SectionPlane plane,
                                                      double offset);

/// The grains of a model as the twin's sections need them: each grain's reference centroid (the
/// solver's, fdem::body_properties, computed for a grain only once a plane comes near it: exact for
/// curved elements, it costs milliseconds a grain) and a bound on the distance of its surface
/// from it (the diagonal of its nodes' box, which holds the centroid).
class TwinSurfaces {
 public:
  explicit TwinSurfaces(const fdem::Model& model);
  const fdem::Model& model() const { return model_; }
  double reach(std::size_t grain) const { return reach_[grain]; }
  /// The reference centroids of `grains` (computed in parallel for those not known yet).
  void prepare(const std::vector<std::size_t>& grains);
  /// Grain g's reference centroid; prepare() it first.
  const Eigen::Vector3d& reference_centroid(std::size_t grain) const { return centroid_[grain]; }

 private:
  const fdem::Model& model_;
  std::vector<double> reach_;  ///< m
  std::vector<Eigen::Vector3d> centroid_;
  std::vector<char> known_;
};

/// One grain's outlines on a section plane.
struct GrainOutline {
  std::uint32_t label = 0;
  std::vector<std::vector<Eigen::Vector2d>> loops;  ///< m
};
/// The outlines where the plane cuts the grains posed at a frame: grain g's reference surface X
/// placed at centroid[g] + R(rotation[g]) (X - reference_centroid[g]) (exact for rigid grains; a
/// deformable grain's own strain is left out). `centroid` and `rotation` (w, x, y, z) are per model
/// grain; grains whose reach does not reach the plane are skipped.
std::vector<GrainOutline> twin_section(TwinSurfaces& surfaces, std::span<const Eigen::Vector3d> centroid,
                                       std::span<const Eigen::Vector4d> rotation, SectionPlane plane, double offset);

/// Grain g's reference surface X posed at `centroid` + R(`rotation`) (X - `reference_centroid`), R
/// the quaternion (w, x, y, z): its vertices, and its triangles over them (indices from 0).
void pose_grain(const fdem::Model& model, std::size_t g, const Eigen::Vector3d& reference_centroid, const Eigen::Vector3d& centroid,
                const Eigen::Vector4d& rotation, std::vector<Eigen::Vector3d>& vertices, std::vector<std::array<std::uint32_t, 3>>& triangles);

/// The row of each model grain (by label) in the simulation's per-grain tables; DataError naming
/// both files when they are not of one run (other grain counts, a label the simulation lacks).
std::vector<std::size_t> model_rows(const fdem::Model& model, const fs::path& model_file, const fs::path& simulation_file);

/// Each model grain's centroid and rotation (w, x, y, z) at a frame, `rows` from model_rows.
struct FramePose {
  std::vector<Eigen::Vector3d> centroid;
  std::vector<Eigen::Vector4d> rotation;
};
FramePose frame_pose(const fdem::ResultsFrame& frame, const std::vector<std::size_t>& rows);

/// The colour scale of a quantity over every grain shown: its 1st to 99th percentile of the finite
/// values (positive ones when `log`), so a few extreme grains do not wash the others out. {NaN,
/// NaN} when no value qualifies; a single value gives a range around it.
std::array<double, 2> colour_range(const std::vector<double>& values, bool log);

/// The plane offsets of one labels file: y of the vertical plane through the sample's axis (the
/// cylinder ct2labels measured in, else the image's middle) and z of the horizontal plane at mid
/// height (of that cylinder, else of the image); the slice indices of both, and the image's
/// extent in x, y and z (m, voxel edges).
struct ScanPlanes {
  double axis_y = 0, mid_z = 0;
  std::size_t y_index = 0, z_index = 0;
  std::array<double, 6> extent{};  ///< x0, x1, y0, y1, z0, z1
};
ScanPlanes scan_planes(const fs::path& labels_file);

/// The index of the slice of an image axis (`count` voxels of `size` from `origin`, voxel centres)
/// holding `position`, clamped into the image.
std::size_t slice_index(double position, double origin, double size, std::size_t count);

/// The section panels of a run, in page order: one per scan shown (its horizontal and vertical
/// sections beside the twin's at the frame of the same order), then D2min and eps_q on the vertical
/// section for each increment shown, scans beside simulation. The scans' grey images (files.volumes)
/// lie under the labels when given. Reads the labels files' geometry, the model and the frames
/// shown; DataError when the model and the simulation are not of one run.
std::vector<Panel> section_panels(const RunFiles& files, const ExperimentData& experiment, const SimulationData& simulation,
                                  const PanelOptions& options);

}  // namespace graintwin::report
