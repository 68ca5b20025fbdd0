#pragma once
// `kind=fdem_model` files (docs/formats.md): the FDEM model of fdem/model.hpp on disk (nodes,
// mixed 4/10-node tetrahedra, grain ranges, surfaces, materials, platens, sample cylinder), plus
// the viewing exports: gmsh .msh (format 2.2, ASCII) and VTK .vtu. Written by shapes2mesh (and
// fdemrun for its scenes), read by fdemrun.
#include <filesystem>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "graintwin/fdem/model.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/vtk.hpp"

namespace graintwin::fdem {

/// The first numeric material value outside its physical range, as "young must lie in [1000,
/// 1e+13] Pa (got 0 Pa)", or empty when every value is in range (and finite). The one check of
/// material values for scene [[materials]] tables and model files alike (ranges: docs/formats.md).
std::string material_range_problem(const Material& material);

/// Checks the model's values (finite node coordinates, materials in range, platens with a unit
/// normal, a sample cylinder of positive size) and its internal consistency (ranges contiguous and
/// grain-owned, 4 or 10 nodes per element, indices in range, one grain per element and triangle,
/// materials referenced exist); throws DataError naming `what` (a file or "model") and the first
/// problem found.
void validate_model(const Model& model, const std::string& what);

/// Writes `model` (validated first) with `history` as /provenance/history. `extra` (optional)
/// adds datasets of the writing tool (e.g. shapes2mesh's /mesh report) before the file closes.
void write_model_file(const std::filesystem::path& path, const Model& model, const std::vector<std::string>& history,
                      const std::function<void(io::H5File&)>& extra = {});

/// Reads a `kind=fdem_model` file; UsageError in one sentence if it is another kind, DataError if
/// its tables disagree.
Model read_model_file(const std::filesystem::path& path);

/// shapes2mesh's element quality of each grain (/mesh/quality, one row per grain in model order):
/// what sets the grain's explicit element step (fdemrun's limit is k h_min / c_d, h_min the
/// smallest altitude of an element's corner tetrahedron) and its worst element.
struct MeshQualityTable {
  std::vector<std::uint32_t> label;          ///< the grain's label in the model
  std::vector<double> min_dihedral;          ///< smallest dihedral angle over its elements, degrees
  std::vector<double> min_altitude;          ///< smallest element altitude, m
  std::vector<double> median_altitude;       ///< median element altitude, m
  std::vector<std::uint64_t> worst_element;  ///< the element (model index) with the smallest altitude
  /// min_altitude / median_altitude: the worst element's stable step over the step the grain's
  /// element size promises (same material, same k).
  std::vector<double> step_ratio;
  std::vector<std::uint64_t> below_thresholds;  ///< elements still below the run's thresholds
  double min_dihedral_threshold = 0.0;          ///< the run's thresholds (0: not asked), degrees
  double min_altitude_ratio_threshold = 0.0;    ///< of the grain's median altitude
};

/// Writes `table` under /mesh/quality of an open model file (a write_model_file `extra`).
/// UsageError when its columns differ in length.
void write_mesh_quality(io::H5File& file, const MeshQualityTable& table);

/// The /mesh/quality table of a model file; none when the file has none (models not made by
/// shapes2mesh, or made before it wrote one). DataError when its columns disagree in length.
std::optional<MeshQualityTable> read_mesh_quality(const std::filesystem::path& path);

/// The model as a VTK unstructured grid (VTK_TETRA / VTK_QUADRATIC_TETRA, gmsh node order mapped
/// to VTK's) at node positions `positions` (empty: the reference positions); point data `grain`,
/// cell data `grain` and `label`. Callers may append arrays before io::write_vtu.
io::VtkUnstructuredGrid model_grid(const Model& model, std::span<const Eigen::Vector3d> positions = {});

/// gmsh MSH 2.2 ASCII: nodes, then the tetrahedra (type 4 or 11) with physical tag = grain label
/// and elementary tag = grain index + 1, then the surface triangles (type 2) with the same tags.
void write_model_msh(const std::filesystem::path& path, const Model& model);

}  // namespace graintwin::fdem
