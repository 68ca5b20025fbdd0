// shapes2mesh: the FDEM twin of the reference scan (docs/shapes2mesh.md; docs/methods.md).
//   shapes2mesh scan_000/shapes.h5 scan_000/labels.h5 model.h5 --vtu model.vtu --msh model.msh
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <optional>

#include "graintwin/cli/option_checks.hpp"
#include "graintwin/cli/tool.hpp"
#include "graintwin/core/enum_names.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/strings.hpp"
#include "graintwin/fdem/model_file.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/mesh/twin.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "graintwin/shape/shapes_file.hpp"
#include "graintwin/track/tracks_file.hpp"

namespace fs = std::filesystem;
using namespace graintwin;

namespace {

constexpr const char* kDescription =
    "Build the FDEM twin of a reference scan: every grain of SHAPES (kind=shapes, from labels2shapes) as a "
    "tetrahedral mesh at its CT position (kind=fdem_model), with the sample cylinder, rigid platens top and bottom, "
    "the membrane geometry and the default materials of docs/methods.md. Each grain's surface is its SH fit (an "
    "icosphere displaced to r(direction)); where labels2shapes flagged the fit unreliable (e.g. a grain that is not "
    "star-shaped), or the SH surface fails the checks (closed, manifold, one piece, outward, no self-intersection), "
    "the grain's smoothed voxels from LABELS are used (their largest piece, of any genus), and without LABELS (or if "
    "those fail too) its inertia ellipsoid, with a note. By default (--sh-meshing kept) every surface is remeshed "
    "to triangles of the element size (CGAL's isotropic remeshing) that gmsh keeps as the boundary while it fills "
    "the volume: cheap and robust on rough, angular and non-star grains; --sh-meshing gmsh has gmsh reparametrise "
    "and remesh SH surfaces instead. 10-node elements get straight mid-edge nodes, then every boundary node is "
    "moved onto the exact SH surface or the smoothed voxel surface (--curving gmsh: gmsh's own curving with "
    "optimize(HighOrder) on the gmsh path); every element's Jacobian is checked and distorted ones have their "
    "mid-edge nodes pulled back; 4-node meshes get their boundary nodes snapped too. gmsh's work on a grain is "
    "bounded by --grain-budget: an overrun stops that gmsh worker and the grain falls back, with a warning. The element size follows what contact needs (about "
    "--surface-nodes nodes on each grain's surface) and, for 4-node meshes, the volume target --volume-tol from the "
    "grain's measured total mean curvature; "
    "--elements-per-diameter overrides both. Quality (gamma = 3 inradius / circumradius) is measured per element; "
    "a grain with elements below --gamma-floor is remeshed once at 0.7 h. Slivers, which set fdemrun's element step "
    "(its smallest element altitude), are then removed within each grain to --min-dihedral and --min-altitude by "
    "moving interior nodes, flipping elements and splitting interior edges; where nothing inside lifts an element on "
    "the boundary (a boundary triangle with a small height bounds it), its boundary nodes slide along the exact "
    "surface, and what still stays is taken out, its volume lost; each "
    "grain's worst element is written to /mesh/quality, and grains that cannot reach the thresholds are named. Grains smaller than --rigid-below d50 get "
    "a coarse linear mesh and are marked rigid. LABELS also gives the sample cylinder (ct2labels' region) when it "
    "is bounded; otherwise the cylinder encloses the meshed grains. Grains run in parallel: -j threads, each "
    "handing its gmsh work to its own gmsh worker process (gmsh is not thread-safe), largest grains first; with "
    "--curving snap the model does not depend on -j "
    "(gmsh's optimize(HighOrder) is not reproducible run to run), "
    "and a worker that crashes is reported for its grain, which falls back as above. --packing equivalent builds a "
    "statistically equivalent sample instead of the twin: the grains of SHAPES (the shape library; each once, or "
    "--grains drawn with replacement) packed at random positions and orientations into a cylinder (height / diameter "
    "--aspect) at --solid-fraction, by ctsynth's packer; the PSD is the library's (exactly, or in expectation) and "
    "the solid fraction holds by construction of the cylinder.";

/// --curving: whether 10-node grains on the gmsh path are snapped onto the SH surface
/// (GrainMeshOptions::snap_to_sh) or curved by gmsh.
constexpr std::array<EnumName<bool>, 2> kCurvingNames{{{true, "snap"}, {false, "gmsh"}}};
/// --packing: the scan's grains where they are (the twin), or a statistically equivalent sample.
enum class Packing { scan, equivalent };
constexpr std::array<EnumName<Packing>, 2> kPackingNames{{{Packing::scan, "scan"}, {Packing::equivalent, "equivalent"}}};
/// --sample-cylinder: ct2labels' cylinder or the one around the grains, or the scan's inscribed one.
enum class SampleChoice { automatic, inscribed };
constexpr std::array<EnumName<SampleChoice>, 2> kSampleChoiceNames{
    {{SampleChoice::automatic, "auto"}, {SampleChoice::inscribed, "inscribed"}}};

/// The command line: the files, the meshing options and the equivalent packing's; the names of the
/// choices as given (the run's parameters record them) and as parsed.
struct Options {
  fs::path shapes, labels, model, vtu, msh, tracks;
  mesh::GrainMeshOptions mesh;
  int subdivisions = 4;
  double rigid_below_d50 = 0.3, platen_friction = 0.0, size_cap_d50 = 2.0;
  std::string membrane_thickness = "0.3mm", curving = "snap", packing = "scan", sh_meshing = "kept", sample_choice = "auto";
  Packing packing_choice = Packing::scan;
  SampleChoice sample_cylinder = SampleChoice::automatic;
  mesh::EquivalentPackingOptions equivalent;
};

void add_options(cli::Tool& tool, Options& o) {
  o.mesh.budget_seconds = 5.0;
  o.mesh.slivers = {12.0, 0.35};
  o.equivalent.aspect = 0.0;  // the scan's unless given
  tool.add_input("SHAPES", o.shapes, "Shapes of the reference scan (.h5, kind=shapes)");
  tool.add_optional_input("LABELS", o.labels,
                          "Labels of the same scan (.h5, kind=labels): voxel surfaces for unreliable SH fits, the sample cylinder");
  tool.add_output("MODEL", o.model, "The model to write (.h5, kind=fdem_model)");
  auto& app = tool.cli();
  using cli::closed, cli::number_in, cli::whole_number_in;
  app.add_option("--order", o.mesh.order, "Element order: 1 (4-node) or 2 (10-node, the CT-FDEM paper's)")
      ->check(CLI::IsMember({1, 2}))->capture_default_str();
  app.add_option("--elements-per-diameter", o.mesh.size.elements_per_diameter,
                 "Element size = equivalent diameter / this, for every grain (0: automatic)")
      ->check(number_in(closed(0, 100)))->capture_default_str();
  app.add_option("--surface-nodes", o.mesh.size.surface_nodes, "Automatic size: surface nodes per grain that contact needs")
      ->check(number_in(closed(20, 1e5)))->capture_default_str();
  app.add_option("--size-cap", o.size_cap_d50,
                 "Automatic size: no element coarser than this many times a d50 grain's size, so that grains larger than "
                 "this many d50 resolve their contacts with d50 grains as those do (0: each grain by its own size only)")
      ->check(number_in(closed(0, 100)))->capture_default_str();
  app.add_option("--volume-tol", o.mesh.size.volume_tolerance, "Automatic size, 4-node: largest relative volume error of the facets")
      ->check(number_in(closed(1e-4, 0.5)))->capture_default_str();
  app.add_option("--gamma-floor", o.mesh.gamma_floor, "Elements below this quality make a grain remeshed (and reported)")
      ->check(number_in(closed(0, 0.9)))->capture_default_str();
  app.add_option("--min-dihedral", o.mesh.slivers.min_dihedral_degrees,
                 "Sliver removal: every element's smallest dihedral angle at least this (degrees; 0: not checked). Interior "
                 "nodes are moved, elements flipped and interior edges split; then boundary nodes slide along the exact surface "
                 "(a boundary element nothing lifts is taken out); a grain that cannot reach it is named in a warning and recorded in /mesh/quality")
      ->check(number_in(closed(0, 60, "degrees")))->capture_default_str();
  app.add_option("--min-altitude", o.mesh.slivers.min_altitude_ratio,
                 "Sliver removal: every element's smallest altitude at least this share of the grain's median element "
                 "altitude (fdemrun's element step follows the smallest altitude; 0: not checked)")
      ->check(number_in(closed(0, 0.9)))->capture_default_str();
  app.add_option("--rigid-below", o.rigid_below_d50, "Grains with equivalent diameter below this many d50 are rigid, coarse, linear")
      ->check(number_in(closed(0, 10, "d50")))->capture_default_str();
  app.add_option("--surface-subdivisions", o.subdivisions, "Icosphere level of the SH surfaces handed to gmsh (4: 5120 triangles)")
      ->check(whole_number_in(2, 6))->capture_default_str();
  app.add_option("--smooth", o.mesh.smooth_vox, "Gaussian sigma (voxels) of the voxel surfaces")
      ->check(number_in(closed(0, 5, "voxels")))->capture_default_str();
  app.add_option("--cut-at-neighbours", o.mesh.cut_at_neighbours,
                 "With LABELS: cut each grain's surface where it reaches into a neighbour's labelled voxels (an SH fit or "
                 "the smoothed voxels overshoot flat contacts by a voxel or two), so that neighbours touch at the "
                 "interface segmentation found instead of overlapping by twice that; the share of each grain's volume "
                 "cut off is /mesh/cut_share (false: surfaces as fitted)")
      ->capture_default_str();
  app.add_option("--sh-meshing", o.sh_meshing,
                 "Grains with a usable SH surface: kept (the surface remeshed to the element size and kept as the mesh "
                 "boundary, gmsh fills it; fast on rough grains) or gmsh (gmsh reparametrises and remeshes the surface, "
                 "within --grain-budget)")
      ->check(CLI::IsMember(enum_names(mesh::kShMeshingNames)))->capture_default_str();
  app.add_option("--grain-budget", o.mesh.budget_seconds,
                 "Seconds gmsh may spend on one grain (0: no limit); on overrun its gmsh worker is stopped and the grain "
                 "falls back (gmsh remeshing to the kept surface, which then gets at least 10 s; the kept surface to the "
                 "inertia ellipsoid), counted in the summary and noted in /mesh/note")
      ->check(number_in(closed(0, 3600, "s")))->capture_default_str();
  app.add_option("--curving", o.curving,
                 "10-node grains on the gmsh path (--sh-meshing gmsh; kept surfaces are always snapped): snap (boundary "
                 "nodes moved onto the exact SH surface, inverted "
                 "elements pulled back) or gmsh (gmsh curves onto the triangulated surface, optimize(HighOrder) when "
                 "an element is inverted; slower)")
      ->check(CLI::IsMember(enum_names(kCurvingNames)))->capture_default_str();
  app.add_option("--membrane-thickness", o.membrane_thickness, "Latex membrane thickness")
      ->check(cli::length_in(1e-6, 0.01))->capture_default_str();
  app.add_option("--platen-friction", o.platen_friction, "Coulomb friction of the platens (smooth: 0)")
      ->check(number_in(closed(0, 2)))->capture_default_str();
  app.add_option("--sample-cylinder", o.sample_choice,
                 "The twin's sample: auto (ct2labels' cylinder from LABELS when it is bounded, else the cylinder around "
                 "the meshed grains) or inscribed (for a crop from inside a sample: the largest vertical cylinder inside "
                 "the scan's box, with only the grains it holds whole, a voxel to spare; needs LABELS)")
      ->check(CLI::IsMember(enum_names(kSampleChoiceNames)))->capture_default_str();
  app.add_option("--tracked-only", o.tracks, "Keep only grains tracked from the first scan to the last in this kind=tracks file")
      ->check(CLI::ExistingFile);
  app.add_option("--packing", o.packing,
                 "scan: every grain at its CT position (the twin); equivalent: a statistically equivalent sample packed "
                 "from the grains of SHAPES")
      ->check(CLI::IsMember(enum_names(kPackingNames)))->capture_default_str();
  app.add_option("--grains", o.equivalent.grains,
                 "--packing equivalent: grains drawn from the library with replacement (0: every library grain once)")
      ->check(whole_number_in(0, 50000))->capture_default_str();
  app.add_option("--solid-fraction", o.equivalent.solid_fraction,
                 "--packing equivalent: grain volume / cylinder volume (0: the scan's, from LABELS' sample cylinder)")
      ->check(number_in(closed(0, synth::kDensestPacking)))->capture_default_str();
  app.add_option("--aspect", o.equivalent.aspect, "--packing equivalent: cylinder height / diameter (0: the scan's, from LABELS, else 1)")
      ->check(number_in(closed(0, 10)))->capture_default_str();
  app.add_option("--seed", o.equivalent.seed, "--packing equivalent: seed of the draw and the packing")->capture_default_str();
  app.add_option("--vtu", o.vtu, "Also write the model for ParaView (.vtu)");
  app.add_option("--msh", o.msh, "Also write the model for gmsh (.msh, format 2.2)");
  tool.set_examples({"shapes2mesh scan_000/shapes.h5 scan_000/labels.h5 model.h5 --vtu model.vtu --msh model.msh",
                     "shapes2mesh shapes.h5 model.h5 --order 1 --elements-per-diameter 6",
                     "shapes2mesh shapes.h5 labels.h5 model.h5 --tracked-only tracks.h5",
                     "shapes2mesh shapes.h5 labels.h5 sample.h5 --packing equivalent --grains 500 --seed 2"});
}

/// Checks the file names and the options that go together, before any input is read; completes
/// the meshing options from the choices. The membrane thickness, m.
double check_options(Options& o) {
  if (o.model.extension() != ".h5") throw UsageError("the model " + o.model.string() + " must end in .h5");
  if (!o.vtu.empty() && o.vtu.extension() != ".vtu") throw UsageError("--vtu " + o.vtu.string() + " must end in .vtu");
  if (!o.msh.empty() && o.msh.extension() != ".msh") throw UsageError("--msh " + o.msh.string() + " must end in .msh");
  const double thickness = parse_length_m(o.membrane_thickness, "--membrane-thickness");
  o.mesh.snap_to_sh = parse_enum(kCurvingNames, o.curving, "--curving");
  o.mesh.sh_path = parse_enum(mesh::kShMeshingNames, o.sh_meshing, "--sh-meshing");
  o.packing_choice = parse_enum(kPackingNames, o.packing, "--packing");
  o.sample_cylinder = parse_enum(kSampleChoiceNames, o.sample_choice, "--sample-cylinder");
  if (o.packing_choice == Packing::equivalent && o.equivalent.solid_fraction == 0.0 && o.labels.empty())
    throw UsageError("--packing equivalent needs --solid-fraction, or LABELS whose sample cylinder gives the scan's");
  return thickness;
}

/// Takes the inputs' histories and checks their kinds; the most grains the run may mesh (those of
/// SHAPES, or the equivalent sample's draws).
std::size_t open_inputs(cli::RunContext& ctx, const Options& o) {
  const io::H5File sf = io::open_kind(o.shapes, schema::kind::shapes, "pass the output of labels2shapes");
  ctx.add_input_history(sf);
  std::size_t meshes = shape::shapes_grain_count(sf);
  if (o.packing_choice == Packing::equivalent) meshes = std::max<std::size_t>(meshes, o.equivalent.grains);
  if (!o.labels.empty()) ctx.add_input_history(io::open_kind(o.labels, schema::kind::labels, "pass the output of ct2labels"));
  if (!o.tracks.empty()) io::open_kind(o.tracks, schema::kind::tracks, "pass the output of shapes2tracks");
  return meshes;
}

/// The scan's labels as the twin uses them; UsageError when a grain of SHAPES has no labels.
mesh::ScanLabels scan_labels(const segment::LabelsFile& labels, const shape::ShapesFile& shapes, const Options& o) {
  mesh::ScanLabels scan;
  scan.image = &labels.labels;
  for (const auto& g : labels.grains) scan.bbox[g.label] = g.bbox;
  for (const auto& g : shapes.grains)
    if (!scan.bbox.count(g.label))
      throw UsageError("grain " + std::to_string(g.label) + " of " + o.shapes.string() + " is not in " + o.labels.string() +
                       "; pass the labels file the shapes were measured from");
  const segment::Cylinder& c = labels.sample.region;
  scan.region = {{c.centre_x, c.centre_y}, c.radius, c.z_min, c.z_max};
  return scan;
}

/// The grains meshed: those the inscribed cylinder holds whole (--sample-cylinder inscribed, which
/// is then set), of them those tracked through the series (--tracked-only).
std::vector<const shape::GrainShape*> selected_grains(const shape::ShapesFile& shapes, const segment::LabelsFile* labels,
                                                      const Options& o, double thickness,
                                                      std::optional<fdem::SampleCylinder>& inscribed) {
  std::vector<const shape::GrainShape*> grains;
  if (o.sample_cylinder == SampleChoice::inscribed) {
    mesh::InscribedGrains in = mesh::inscribed_grains(shapes.grains, labels->labels, thickness);
    inscribed = in.cylinder;
    grains = std::move(in.grains);
    spdlog::info("inscribed cylinder: radius {:.3f} mm, axis ({:.3f}, {:.3f}) mm; {} of {} grains lie whole inside it, the rest "
                 "are left out",
                 inscribed->radius * 1e3, inscribed->axis_xy.x() * 1e3, inscribed->axis_xy.y() * 1e3, grains.size(), shapes.grains.size());
    if (grains.empty()) throw DataError("no grain of " + o.shapes.string() + " lies whole inside the scan's inscribed cylinder; leave --sample-cylinder at auto");
  } else {
    for (const auto& g : shapes.grains) grains.push_back(&g);
  }
  if (!o.tracks.empty()) {
    const auto keep = track::labels_tracked_throughout(track::read_tracks_file(o.tracks));
    const std::size_t before = grains.size();
    std::erase_if(grains, [&](const shape::GrainShape* g) { return !keep.count(g->label); });
    spdlog::info("{} of {} grains are tracked through {}", grains.size(), before, o.tracks.string());
    if (grains.empty()) throw DataError(o.tracks.string() + " tracks none of the grains of " + o.shapes.string() + "; pass the tracks of this scan series");
  }
  return grains;
}

void log_equivalent_sample(const mesh::EquivalentTwin& twin, std::size_t library, double library_d50) {
  const mesh::EquivalentSample& s = twin.sample;
  spdlog::info("equivalent sample: {} grains drawn from {} ({} unusable), d50 {:.3f} mm (library {:.3f} mm); packed at solid "
               "fraction {:.4f} (core {:.4f}) into a cylinder of radius {:.3f} mm, height {:.3f} mm; max overlap {:.3g} um, "
               "{} sweeps, {:.1f} s",
               twin.grains.size(), library, s.unusable, s.psd.d50 * 1e3, library_d50 * 1e3, s.report.solid_fraction,
               s.report.core_solid_fraction, s.container.radius * 1e3, s.container.height * 1e3, s.report.max_overlap * 1e6,
               s.report.sweeps, s.report.seconds);
}

/// Each grain's fallbacks (and with -v -v its path, time and quality), then the cut at the neighbours.
void log_grains(const mesh::TwinGrains& grains, const std::vector<mesh::GrainMeshResult>& results, const mesh::TwinModel& twin,
                const Options& o, bool cut) {
  const mesh::MeshTable& table = twin.table;
  for (std::size_t i = 0; i < grains.size(); ++i) {
    const auto& r = results[i];
    const std::uint32_t label = grains.label[i];
    if (r.overran) spdlog::warn("grain {}: gmsh overran --grain-budget {:g} s; meshed by the {} path from its {} instead", label,
                                o.mesh.budget_seconds, mesh::mesh_path_name(r.path), mesh::surface_origin_name(r.origin));
    spdlog::debug("grain {}: {} from {}, {:.3f} s ({:.3f} s in gmsh), {} elements, {} surface nodes, volume {:+.2f} %, min gamma "
                  "{:.2f}{}{}",
                  label, mesh::mesh_path_name(r.path), mesh::surface_origin_name(r.origin), r.seconds, r.gmsh.seconds, r.quality.elements,
                  r.quality.surface_nodes, 100.0 * (r.quality.volume / r.surface_volume - 1.0), r.quality.min_gamma,
                  r.note.empty() ? "" : "; ", r.note);
  }
  // Grains whose elements stay below the sliver thresholds: named, the first ones one by one.
  constexpr std::size_t kNamed = 20;
  std::size_t short_of = 0;
  for (std::size_t i = 0; i < grains.size(); ++i) {
    const auto& q = results[i].quality;
    if (q.below_thresholds == 0 || results[i].kind == fdem::GrainKind::rigid) continue;
    if (++short_of <= kNamed)
      spdlog::warn("grain {}: {} of {} elements stay below --min-dihedral {:g} / --min-altitude {:g} (worst: element {}, min "
                   "dihedral {:.1f} deg over the grain, min altitude {:.2f} of the median)",
                   grains.label[i], q.below_thresholds, q.elements, o.mesh.slivers.min_dihedral_degrees,
                   o.mesh.slivers.min_altitude_ratio, twin.quality.worst_element[i], q.min_dihedral, q.min_altitude / q.median_altitude);
  }
  if (short_of > kNamed) spdlog::warn("{} more grains stay below the sliver thresholds (/mesh/quality names them)", short_of - kNamed);
  if (!cut || table.cut_share.empty()) return;
  std::vector<double> shares(table.cut_share);
  std::sort(shares.begin(), shares.end());
  const auto count = static_cast<std::size_t>(std::count_if(shares.begin(), shares.end(), [](double v) { return v > 0.0; }));
  spdlog::info("cut at the neighbours' voxels: {} of {} grains, {:.2f} % of a grain's volume at the median, {:.1f} % at most",
               count, shares.size(), 100.0 * shares[shares.size() / 2], 100.0 * shares.back());
}

void log_summary(const mesh::TwinModel& twin, const mesh::TwinSample& sample, const Options& o) {
  const mesh::TwinCounts& c = twin.counts;
  const fdem::Model& model = twin.model;
  const std::size_t n = model.grains.size();
  spdlog::info("{} grains: {} from SH, {} from voxels, {} as ellipsoids; {} rigid (below {:.3g} mm)", n, c.origin[0],
               c.origin[1], c.origin[2], c.rigid, o.mesh.rigid_diameter * 1e3);
  spdlog::info("meshing paths: {} gmsh remeshed the surface, {} surface remeshed and kept as the boundary, {} ellipsoid; {} "
               "overran --grain-budget {:g} s",
               c.path[0], c.path[1], c.path[2], c.overran, o.mesh.budget_seconds);
  spdlog::info("{} nodes, {} elements ({:.0f} per grain), {} surface triangles; {:.2f} s in gmsh ({:.3f} s per grain), {:.3f} s "
               "per grain in all (summed over threads)",
               model.nodes.size(), model.element_count(), static_cast<double>(model.element_count()) / n, model.triangles.size(),
               c.gmsh_seconds, c.gmsh_seconds / n, c.seconds / n);
  spdlog::info("quality: {} grains had elements inverted by curving ({} through optimize(HighOrder), the others' mid-edge "
               "nodes pulled back); {} grains remeshed, {} still below the gamma floor {} or inverted",
               c.curving_inverted, c.optimized, c.remeshed, c.below_floor, o.mesh.gamma_floor);
  // What sets the element step: each grain's worst element against its median altitude.
  const fdem::MeshQualityTable& q = twin.quality;
  if (n > 0) {
    std::vector<double> ratios(q.step_ratio);
    std::sort(ratios.begin(), ratios.end());
    const auto worst = static_cast<std::size_t>(std::min_element(q.step_ratio.begin(), q.step_ratio.end()) - q.step_ratio.begin());
    double volume = 0.0;
    for (const double v : twin.table.volume) volume += v;
    spdlog::info("slivers (--min-dihedral {:g}, --min-altitude {:g}): {} elements below before the pass, {:.2f} s in it; {} "
                 "boundary nodes slid along the surface ({:+.2g} % of the grains' volume), {} boundary elements taken out "
                 "({:.2g} %); {} deformable grains still below ({} elements); smallest altitude over the grain's median: "
                 "{:.2f} at the median grain, {:.2f} at worst (grain {}, element {}, min dihedral {:.1f} deg)",
                 o.mesh.slivers.min_dihedral_degrees, o.mesh.slivers.min_altitude_ratio, c.slivers_before, c.sliver_seconds,
                 c.slid, volume > 0 ? 100 * c.slid_volume / volume : 0.0, c.peeled, volume > 0 ? 100 * c.peeled_volume / volume : 0.0,
                 c.below_thresholds, c.sliver_elements, ratios[ratios.size() / 2], ratios.front(), q.label[worst], q.worst_element[worst],
                 q.min_dihedral[worst]);
  }
  const fdem::SampleCylinder& s = sample.cylinder;
  spdlog::info("sample cylinder ({}): axis ({:.4g}, {:.4g}) mm, radius {:.4g} mm, z {:.4g} .. {:.4g} mm", sample.source,
               s.axis_xy.x() * 1e3, s.axis_xy.y() * 1e3, s.radius * 1e3, s.z_min * 1e3, s.z_max * 1e3);
}

/// The run's parameters as /mesh/parameters records them.
nlohmann::json parameters_json(const Options& o, double thickness, bool cut, const std::string& sample_source, std::size_t workers,
                               const mesh::EquivalentSample* sample, double library_d50) {
  const mesh::GrainMeshOptions& mo = o.mesh;
  nlohmann::json parameters = {
      {"order", mo.order}, {"elements_per_diameter", mo.size.elements_per_diameter}, {"surface_nodes", mo.size.surface_nodes},
      {"size_cap_d50", o.size_cap_d50},
      {"volume_tolerance", mo.size.volume_tolerance}, {"gamma_floor", mo.gamma_floor}, {"rigid_below_d50", o.rigid_below_d50},
      {"rigid_diameter_m", mo.rigid_diameter}, {"surface_subdivisions", o.subdivisions}, {"smooth_vox", mo.smooth_vox}, {"curving", o.curving},
      {"cut_at_neighbours", cut},
      {"membrane_thickness_m", thickness}, {"platen_friction", o.platen_friction}, {"sample_source", sample_source},
      {"tracked_only", o.tracks.string()}, {"gmsh_processes", workers}, {"packing", o.packing},
      {"grain_budget_s", mo.budget_seconds}, {"sh_meshing", o.sh_meshing},
      {"min_dihedral_degrees", mo.slivers.min_dihedral_degrees}, {"min_altitude_ratio", mo.slivers.min_altitude_ratio}};
  parameters["sample_cylinder"] = o.sample_choice;
  const mesh::EquivalentPackingOptions& po = o.equivalent;
  if (sample)
    parameters["equivalent_packing"] = {{"grains", po.grains}, {"solid_fraction", po.solid_fraction}, {"aspect", po.aspect},
                                        {"seed", po.seed}, {"packed_solid_fraction", sample->report.solid_fraction},
                                        {"core_solid_fraction", sample->report.core_solid_fraction},
                                        {"d50_m", sample->psd.d50}, {"library_d50_m", library_d50}};
  return parameters;
}

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool("shapes2mesh", kDescription);
  Options o;
  add_options(tool, o);

  return tool.run(argc, argv, [&](cli::RunContext& ctx) {
    const double thickness = check_options(o);
    const bool equivalent = o.packing_choice == Packing::equivalent;
    io::AtomicOutput out(o.model, ctx.force());
    std::optional<io::AtomicOutput> vtu_out, msh_out;
    if (!o.vtu.empty()) vtu_out.emplace(o.vtu, ctx.force());
    if (!o.msh.empty()) msh_out.emplace(o.msh, ctx.force());
    const std::size_t meshes = open_inputs(ctx, o);
    // Forked now, while the process is small and has no threads running.
    mesh::GmshWorkers workers(mesh::GmshWorkers::useful_count(ctx.threads(), meshes));
    o.mesh.workers = &workers;
    shape::ShapesFile shapes = shape::read_shapes_file(o.shapes);
    if (shapes.grains.empty()) throw DataError(o.shapes.string() + " holds no grain; check the segmentation and labels2shapes run");
    std::optional<segment::LabelsFile> labels;
    std::optional<mesh::ScanLabels> scan;
    if (!o.labels.empty()) scan = scan_labels(labels.emplace(segment::read_labels_file(o.labels)), shapes, o);
    if (o.sample_cylinder == SampleChoice::inscribed && (!labels || equivalent))
      throw UsageError("--sample-cylinder inscribed needs LABELS and the scan's packing; pass the labels file, or leave it at auto");
    std::optional<fdem::SampleCylinder> inscribed;
    const std::vector<const shape::GrainShape*> grains = selected_grains(shapes, labels ? &*labels : nullptr, o, thickness, inscribed);
    o.mesh.rigid_diameter = o.rigid_below_d50 * shapes.psd.d50;
    o.mesh.size.coarsest_size = mesh::neighbour_size_cap(shapes.psd.d50, o.size_cap_d50, o.mesh.order, o.mesh.size);

    // What is meshed: the scan's grains where they are, or an equivalent sample drawn from them
    // (copies centred on their body origin, meshed there and then placed).
    std::optional<mesh::EquivalentTwin> sample;
    if (equivalent) {
      o.equivalent = mesh::scan_packing_options(o.equivalent, shapes.grains, scan ? &*scan : nullptr, o.labels.string());
      sample = mesh::pack_equivalent_twin(grains, shapes.degree, o.equivalent, synth::log_packing_status("packing"));
      log_equivalent_sample(*sample, grains.size(), shapes.psd.d50);
    }
    const mesh::TwinGrains twin_grains = sample ? mesh::grains_of_sample(*sample, grains) : mesh::grains_in_place(grains);
    const std::size_t count = twin_grains.size();
    mesh::check_meshing_memory(count, std::min<int>(ctx.threads(), static_cast<int>(count)), o.mesh.order, o.mesh.size);
    const mesh::ShSurfaceBasis basis(o.subdivisions, shapes.degree);
    auto progress = ctx.progress("meshing", count);
    const auto results = mesh::mesh_twin_grains(twin_grains, basis, scan ? &*scan : nullptr, o.mesh, [&] { progress->advance(1); });
    progress.reset();

    mesh::TwinModel twin = mesh::assemble_twin(twin_grains, results, o.mesh.slivers);
    const bool cut = scan && !sample && o.mesh.cut_at_neighbours;
    log_grains(twin_grains, results, twin, o, cut);
    // The sample: the equivalent packing's cylinder, the inscribed one, ct2labels' region when it
    // is bounded, else the cylinder around the grains.
    const mesh::TwinSample twin_sample =
        mesh::twin_sample(twin.model, thickness, sample ? &sample->sample.container : nullptr, inscribed ? &*inscribed : nullptr,
                          scan ? &scan->region : nullptr);
    twin.model.sample = twin_sample.cylinder;
    twin.model.platens = mesh::end_platens(twin_sample.cylinder, o.platen_friction);
    log_summary(twin, twin_sample, o);

    const nlohmann::json parameters = parameters_json(o, thickness, cut, twin_sample.source, workers.size(),
                                                      sample ? &sample->sample : nullptr, shapes.psd.d50);
    fdem::write_model_file(out.temp_path(), twin.model, ctx.history(),
                           [&](io::H5File& f) { mesh::write_mesh_table(f, twin, parameters.dump()); });
    if (vtu_out) io::write_vtu(vtu_out->temp_path(), fdem::model_grid(twin.model));
    if (msh_out) fdem::write_model_msh(msh_out->temp_path(), twin.model);
    io::commit_outputs({&out, vtu_out ? &*vtu_out : nullptr, msh_out ? &*msh_out : nullptr});
  });
}
