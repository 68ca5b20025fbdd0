#pragma once
// shapes2mesh's stage (docs/shapes2mesh.md): the FDEM twin of a scan from the grains of its shapes
// file, or a statistically equivalent sample packed from them. Which grains are meshed (those the
// scan's inscribed cylinder holds whole), the equivalent sample's solid fraction and aspect taken
// from the scan, every grain meshed in parallel, the model assembled with its sample cylinder, and
// the per-grain figures written under /mesh of the model file.
#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <unordered_map>
#include <vector>

#include "graintwin/core/volume.hpp"
#include "graintwin/fdem/model.hpp"
#include "graintwin/fdem/model_file.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/mesh/equivalent_packing.hpp"
#include "graintwin/mesh/grain_mesher.hpp"

namespace graintwin::mesh {

/// ct2labels' sample cylinder as its labels file records it (m): none when the radius is not finite
/// and positive; a z range that is infinite spans the scan's height.
struct ScanCylinder {
  Eigen::Vector2d axis_xy = Eigen::Vector2d::Zero();
  double radius = 0.0;
  double z_min = -std::numeric_limits<double>::infinity(), z_max = std::numeric_limits<double>::infinity();
  bool bounded() const;
};

/// What the twin takes from the scan's labels (ct2labels).
struct ScanLabels {
  const Volume<std::uint32_t>* image = nullptr;  ///< the label image
  /// Each grain's half-open box in the image (z0, y0, x0, z1, y1, x1), by label.
  std::unordered_map<std::uint32_t, std::array<std::size_t, 6>> bbox;
  ScanCylinder region;
};

/// The largest vertical cylinder inside the scan's box (inscribed_cylinder) and the grains of
/// `grains` it holds whole, with a voxel to spare.
struct InscribedGrains {
  fdem::SampleCylinder cylinder;
  std::vector<const shape::GrainShape*> grains;
};
InscribedGrains inscribed_grains(const std::vector<shape::GrainShape>& grains, const Volume<std::uint32_t>& labels,
                                 double membrane_thickness);

/// The height (m) of `region` within the scan `labels`: its z range clipped to the image's voxel faces.
double height_in_scan(const ScanCylinder& region, const Volume<std::uint32_t>& labels);

/// The volume of `grains` over that of a cylinder of this radius and height (m).
double solid_fraction(const std::vector<shape::GrainShape>& grains, double radius, double height);

/// `options` with what is left at 0 taken from the scan: the solid fraction of `grains` (all of the
/// shapes file's) in the scan's sample cylinder, the aspect of that cylinder (1 without one).
/// UsageError naming `labels_name` when the solid fraction is to come from a scan without a bounded
/// cylinder (or without labels: `scan` null); DataError when it comes out above what packs.
EquivalentPackingOptions scan_packing_options(EquivalentPackingOptions options, const std::vector<shape::GrainShape>& grains,
                                              const ScanLabels* scan, const std::string& labels_name);

/// An equivalent sample (pack_equivalent_sample) and its grains: copies of the library grains it
/// drew, centred on their body origin, to be meshed there and placed at the sample's poses.
struct EquivalentTwin {
  EquivalentSample sample;
  std::vector<shape::GrainShape> grains;
};
/// Packs the sample from `library` (SH degree `degree`); DataError with the fixes when it does not
/// pack; InterruptedError when interrupted. `observe` gets the packing's status after every sweep.
EquivalentTwin pack_equivalent_twin(const std::vector<const shape::GrainShape*>& library, int degree,
                                    const EquivalentPackingOptions& options, const synth::PackingObserver& observe = {});

/// What the twin meshes, in model order.
struct TwinGrains {
  std::vector<const shape::GrainShape*> shapes;
  std::vector<std::uint32_t> label;         ///< in the model: the scan's labels, or 1..N in an equivalent sample
  std::vector<std::uint32_t> source_label;  ///< in the shapes file
  std::vector<synth::PackedGrain> poses;    ///< an equivalent sample's: where each mesh goes; empty for the scan
  std::size_t size() const { return shapes.size(); }
};
/// The scan's grains where they lie.
TwinGrains grains_in_place(const std::vector<const shape::GrainShape*>& grains);
/// The grains of an equivalent sample drawn from `library` (which must outlive the result, as `twin` must).
TwinGrains grains_of_sample(const EquivalentTwin& twin, const std::vector<const shape::GrainShape*>& library);

/// Meshes every grain (mesh_grain), in parallel on OpenMP's threads, largest first so that no
/// thread idles at the end on a long grain; an equivalent sample's meshes are placed at their poses.
/// `scan` (may be null) gives voxel surfaces and the cut at the neighbours to grains in place.
/// `grain_done` is called from the meshing thread after each grain. InterruptedError when
/// interrupted; DataError naming the first grain (by its label in the shapes file) that could not
/// be meshed.
std::vector<GrainMeshResult> mesh_twin_grains(const TwinGrains& grains, const ShSurfaceBasis& basis, const ScanLabels* scan,
                                              const GrainMeshOptions& options, const std::function<void()>& grain_done = {});

/// Per-grain figures of the twin (one row per grain, model order), written under /mesh.
struct MeshTable {
  std::vector<std::uint32_t> label, source_label;
  std::vector<std::uint8_t> origin, path, overran, kind, optimized, remeshed;
  std::vector<std::uint64_t> elements, nodes, surface_nodes, inverted_after_curving, inverted;
  std::vector<double> size, min_gamma, mean_gamma, min_jacobian, volume, surface_volume, volume_error, cut_share, gmsh_seconds,
      seconds;
  std::vector<std::string> note;
  void add(std::uint32_t label, std::uint32_t source_label, const GrainMeshResult& result);
};

/// The meshed grains counted for the run's summary.
struct TwinCounts {
  std::array<std::size_t, 3> origin{};  ///< per SurfaceOrigin
  std::array<std::size_t, 3> path{};    ///< per MeshPath
  std::size_t overran = 0, rigid = 0, remeshed = 0, optimized = 0;
  std::size_t curving_inverted = 0;     ///< grains with elements inverted by curving
  std::size_t below_floor = 0;          ///< grains still below the gamma floor or inverted
  std::size_t below_thresholds = 0;     ///< deformable grains with elements still below the sliver thresholds
  std::size_t sliver_elements = 0;      ///< their elements below the thresholds
  std::size_t slivers_before = 0;       ///< elements below the thresholds before the sliver pass, all grains
  std::size_t slid = 0;                 ///< boundary nodes the sliver pass slid along the surface, all grains
  double slid_volume = 0.0;             ///< m^3, the volume those slides added (signed), all grains
  std::size_t peeled = 0;               ///< boundary elements the sliver pass took out, all grains
  double peeled_volume = 0.0;           ///< m^3, their volume
  double gmsh_seconds = 0.0, seconds = 0.0;  ///< s, summed over the grains
  double sliver_seconds = 0.0;          ///< s in the sliver pass, summed over the grains
};

/// The twin's model (its grains, not yet its sample and platens) and figures.
struct TwinModel {
  fdem::Model model;
  MeshTable table;
  fdem::MeshQualityTable quality;  ///< each grain's worst element, by model element index
  TwinCounts counts;
};
/// Joins the meshes of `grains` (results in the same order) into one model; `slivers` are the
/// thresholds the grains were meshed to (recorded with the quality table).
TwinModel assemble_twin(const TwinGrains& grains, const std::vector<GrainMeshResult>& results, const SliverThresholds& slivers = {});

/// The twin's sample cylinder and where it came from.
struct TwinSample {
  fdem::SampleCylinder cylinder;
  std::string source;  ///< "equivalent packing", "inscribed in the scan", "labels" or "grains"
};
/// The sample of `model`: an equivalent packing's `container` when given, else the `inscribed`
/// cylinder when given, else the scan's `region` when bounded (its z range where that is finite,
/// the grains' otherwise), else the cylinder around the grains; with this membrane thickness (m).
TwinSample twin_sample(const fdem::Model& model, double membrane_thickness, const synth::Container* container,
                       const fdem::SampleCylinder* inscribed, const ScanCylinder* region);

/// Writes the twin's per-grain table and quality table and the run's `parameters` (JSON) under
/// /mesh of an open model file.
void write_mesh_table(io::H5File& file, const TwinModel& twin, const std::string& parameters);

}  // namespace graintwin::mesh
