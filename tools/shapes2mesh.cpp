// shapes2mesh: the FDEM twin of the reference scan (docs/shapes2mesh.md; docs/methods.md).
//   shapes2mesh scan_000/shapes.h5 scan_000/labels.h5 model.h5 --vtu model.vtu --msh model.msh
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <cmath>
#include <numeric>
#include <optional>
#include <set>
#include <unordered_map>

#include "graintwin/cli/option_checks.hpp"
#include "graintwin/cli/tool.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/interrupt.hpp"
#include "graintwin/core/strings.hpp"
#include "graintwin/fdem/model_file.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/mesh/equivalent_packing.hpp"
#include "graintwin/mesh/grain_mesher.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "graintwin/shape/shapes_file.hpp"
#include "graintwin/track/tracks_file.hpp"

namespace fs = std::filesystem;
using namespace graintwin;

namespace {

/// Labels of the reference scan's grains that are tracked from the first scan to the last.
std::set<std::uint32_t> tracked_labels(const fs::path& tracks) {
  const track::TracksTable t = track::read_tracks_file(tracks);
  std::set<std::uint32_t> out;
  for (std::size_t i = 0; i < t.tracks; ++i)
    if (t.label[i * t.scans] > 0 && t.label[i * t.scans + t.scans - 1] > 0) out.insert(t.label[i * t.scans]);
  return out;
}

/// Per-grain figures of the run, written under /mesh.
struct Report {
  std::vector<std::uint32_t> label, source_label;
  std::vector<std::uint8_t> origin, path, overran, kind, optimized, remeshed;
  std::vector<std::uint64_t> elements, nodes, surface_nodes, inverted_after_curving, inverted;
  std::vector<double> size, min_gamma, mean_gamma, min_jacobian, volume, surface_volume, volume_error, cut_share, seconds, grain_seconds;
  std::vector<std::string> note;

  void add(std::uint32_t l, std::uint32_t source, const mesh::GrainMeshResult& r) {
    label.push_back(l);
    source_label.push_back(source);
    origin.push_back(static_cast<std::uint8_t>(r.origin));
    path.push_back(static_cast<std::uint8_t>(r.path));
    overran.push_back(r.overran);
    kind.push_back(static_cast<std::uint8_t>(r.kind));
    optimized.push_back(r.gmsh.optimized);
    remeshed.push_back(r.remeshed);
    elements.push_back(r.quality.elements);
    nodes.push_back(r.quality.nodes);
    surface_nodes.push_back(r.quality.surface_nodes);
    inverted_after_curving.push_back(r.gmsh.inverted_after_curving);
    inverted.push_back(r.quality.inverted);
    size.push_back(r.size.h);
    min_gamma.push_back(r.quality.min_gamma);
    mean_gamma.push_back(r.quality.mean_gamma);
    min_jacobian.push_back(r.quality.min_jacobian_ratio);
    volume.push_back(r.quality.volume);
    surface_volume.push_back(r.surface_volume);
    volume_error.push_back(r.quality.volume / r.surface_volume - 1.0);
    cut_share.push_back(r.cut_share);
    seconds.push_back(r.gmsh.seconds);
    grain_seconds.push_back(r.seconds);
    note.push_back(r.note);
  }
  void write(io::H5File& f, const std::string& parameters) const {
    using io::units;
    f.write("/mesh/label", label);
    f.write("/mesh/source_label", source_label);
    f.write("/mesh/surface_origin", origin);
    f.set_attr("/mesh/surface_origin", "codes", std::string("0 SH fit, 1 smoothed voxels, 2 inertia ellipsoid"));
    f.write("/mesh/path", path);
    f.set_attr("/mesh/path", "codes",
               std::string("0 gmsh remeshes the surface, 1 surface remeshed to the element size and kept as the boundary, 2 ellipsoid"));
    f.write("/mesh/overran_budget", overran);
    f.write("/mesh/kind", kind);
    f.write("/mesh/element_size", size, units("m"));
    f.write("/mesh/elements", elements);
    f.write("/mesh/nodes", nodes);
    f.write("/mesh/surface_nodes", surface_nodes);
    f.write("/mesh/min_gamma", min_gamma, units("1"));
    f.write("/mesh/mean_gamma", mean_gamma, units("1"));
    f.write("/mesh/min_jacobian_ratio", min_jacobian, units("1"));
    f.write("/mesh/inverted_after_curving", inverted_after_curving);
    f.write("/mesh/optimized", optimized);
    f.write("/mesh/inverted", inverted);
    f.write("/mesh/remeshed", remeshed);
    f.write("/mesh/volume", volume, units("m^3"));
    f.write("/mesh/surface_volume", surface_volume, units("m^3"));
    f.write("/mesh/volume_error", volume_error, units("1"));
    f.write("/mesh/cut_share", cut_share, units("1"));
    f.write("/mesh/gmsh_seconds", seconds, units("s"));
    f.write("/mesh/seconds", grain_seconds, units("s"));
    f.write_strings("/mesh/note", note);
    f.write_strings("/mesh/parameters", {parameters});
  }
};

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool(
      "shapes2mesh",
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
      "a grain with elements below --gamma-floor is remeshed once at 0.7 h. Grains smaller than --rigid-below d50 get "
      "a coarse linear mesh and are marked rigid. LABELS also gives the sample cylinder (ct2labels' region) when it "
      "is bounded; otherwise the cylinder encloses the meshed grains. Grains run in parallel: -j threads, each "
      "handing its gmsh work to its own gmsh worker process (gmsh is not thread-safe), largest grains first; with "
      "--curving snap the model does not depend on -j "
      "(gmsh's optimize(HighOrder) is not reproducible run to run), "
      "and a worker that crashes is reported for its grain, which falls back as above. --packing equivalent builds a "
      "statistically equivalent sample instead of the twin: the grains of SHAPES (the shape library; each once, or "
      "--grains drawn with replacement) packed at random positions and orientations into a cylinder (height / diameter "
      "--aspect) at --solid-fraction, by ctsynth's packer; the PSD is the library's (exactly, or in expectation) and "
      "the solid fraction holds by construction of the cylinder.");
  fs::path shapes_path, labels_path, model_path, vtu_path, msh_path, tracks_path;
  mesh::GrainMeshOptions mo;
  mo.budget_seconds = 5.0;
  int subdivisions = 4;
  double rigid_below_d50 = 0.3, platen_friction = 0.0, size_cap_d50 = 2.0;
  std::string membrane_thickness = "0.3mm", curving = "snap", packing = "scan", sh_meshing = "kept", sample_choice = "auto";
  mesh::EquivalentPackingOptions po;
  po.aspect = 0.0;  // the scan's unless given
  tool.add_input("SHAPES", shapes_path, "Shapes of the reference scan (.h5, kind=shapes)");
  tool.add_optional_input("LABELS", labels_path,
                          "Labels of the same scan (.h5, kind=labels): voxel surfaces for unreliable SH fits, the sample cylinder");
  tool.add_output("MODEL", model_path, "The model to write (.h5, kind=fdem_model)");
  auto& app = tool.cli();
  using cli::closed, cli::number_in, cli::whole_number_in;
  app.add_option("--order", mo.order, "Element order: 1 (4-node) or 2 (10-node, the CT-FDEM paper's)")
      ->check(CLI::IsMember({1, 2}))->capture_default_str();
  app.add_option("--elements-per-diameter", mo.size.elements_per_diameter,
                 "Element size = equivalent diameter / this, for every grain (0: automatic)")
      ->check(number_in(closed(0, 100)))->capture_default_str();
  app.add_option("--surface-nodes", mo.size.surface_nodes, "Automatic size: surface nodes per grain that contact needs")
      ->check(number_in(closed(20, 1e5)))->capture_default_str();
  app.add_option("--size-cap", size_cap_d50,
                 "Automatic size: no element coarser than this many times a d50 grain's size, so that grains larger than "
                 "this many d50 resolve their contacts with d50 grains as those do (0: each grain by its own size only)")
      ->check(number_in(closed(0, 100)))->capture_default_str();
  app.add_option("--volume-tol", mo.size.volume_tolerance, "Automatic size, 4-node: largest relative volume error of the facets")
      ->check(number_in(closed(1e-4, 0.5)))->capture_default_str();
  app.add_option("--gamma-floor", mo.gamma_floor, "Elements below this quality make a grain remeshed (and reported)")
      ->check(number_in(closed(0, 0.9)))->capture_default_str();
  app.add_option("--rigid-below", rigid_below_d50, "Grains with equivalent diameter below this many d50 are rigid, coarse, linear")
      ->check(number_in(closed(0, 10, "d50")))->capture_default_str();
  app.add_option("--surface-subdivisions", subdivisions, "Icosphere level of the SH surfaces handed to gmsh (4: 5120 triangles)")
      ->check(whole_number_in(2, 6))->capture_default_str();
  app.add_option("--smooth", mo.smooth_vox, "Gaussian sigma (voxels) of the voxel surfaces")
      ->check(number_in(closed(0, 5, "voxels")))->capture_default_str();
  app.add_option("--cut-at-neighbours", mo.cut_at_neighbours,
                 "With LABELS: cut each grain's surface where it reaches into a neighbour's labelled voxels (an SH fit or "
                 "the smoothed voxels overshoot flat contacts by a voxel or two), so that neighbours touch at the "
                 "interface segmentation found instead of overlapping by twice that; the share of each grain's volume "
                 "cut off is /mesh/cut_share (false: surfaces as fitted)")
      ->capture_default_str();
  app.add_option("--sh-meshing", sh_meshing,
                 "Grains with a usable SH surface: kept (the surface remeshed to the element size and kept as the mesh "
                 "boundary, gmsh fills it; fast on rough grains) or gmsh (gmsh reparametrises and remeshes the surface, "
                 "within --grain-budget)")
      ->check(CLI::IsMember({"kept", "gmsh"}))->capture_default_str();
  app.add_option("--grain-budget", mo.budget_seconds,
                 "Seconds gmsh may spend on one grain (0: no limit); on overrun its gmsh worker is stopped and the grain "
                 "falls back (gmsh remeshing to the kept surface, which then gets at least 10 s; the kept surface to the "
                 "inertia ellipsoid), counted in the summary and noted in /mesh/note")
      ->check(number_in(closed(0, 3600, "s")))->capture_default_str();
  app.add_option("--curving", curving,
                 "10-node grains on the gmsh path (--sh-meshing gmsh; kept surfaces are always snapped): snap (boundary "
                 "nodes moved onto the exact SH surface, inverted "
                 "elements pulled back) or gmsh (gmsh curves onto the triangulated surface, optimize(HighOrder) when "
                 "an element is inverted; slower)")
      ->check(CLI::IsMember({"snap", "gmsh"}))->capture_default_str();
  app.add_option("--membrane-thickness", membrane_thickness, "Latex membrane thickness")
      ->check(cli::length_in(1e-6, 0.01))->capture_default_str();
  app.add_option("--platen-friction", platen_friction, "Coulomb friction of the platens (smooth: 0)")
      ->check(number_in(closed(0, 2)))->capture_default_str();
  app.add_option("--sample-cylinder", sample_choice,
                 "The twin's sample: auto (ct2labels' cylinder from LABELS when it is bounded, else the cylinder around "
                 "the meshed grains) or inscribed (for a crop from inside a sample: the largest vertical cylinder inside "
                 "the scan's box, with only the grains it holds whole, a voxel to spare; needs LABELS)")
      ->check(CLI::IsMember({"auto", "inscribed"}))->capture_default_str();
  app.add_option("--tracked-only", tracks_path, "Keep only grains tracked from the first scan to the last in this kind=tracks file")
      ->check(CLI::ExistingFile);
  app.add_option("--packing", packing,
                 "scan: every grain at its CT position (the twin); equivalent: a statistically equivalent sample packed "
                 "from the grains of SHAPES")
      ->check(CLI::IsMember({"scan", "equivalent"}))->capture_default_str();
  app.add_option("--grains", po.grains,
                 "--packing equivalent: grains drawn from the library with replacement (0: every library grain once)")
      ->check(whole_number_in(0, 50000))->capture_default_str();
  app.add_option("--solid-fraction", po.solid_fraction,
                 "--packing equivalent: grain volume / cylinder volume (0: the scan's, from LABELS' sample cylinder)")
      ->check(number_in(closed(0, synth::kDensestPacking)))->capture_default_str();
  app.add_option("--aspect", po.aspect, "--packing equivalent: cylinder height / diameter (0: the scan's, from LABELS, else 1)")
      ->check(number_in(closed(0, 10)))->capture_default_str();
  app.add_option("--seed", po.seed, "--packing equivalent: seed of the draw and the packing")->capture_default_str();
  app.add_option("--vtu", vtu_path, "Also write the model for ParaView (.vtu)");
  app.add_option("--msh", msh_path, "Also write the model for gmsh (.msh, format 2.2)");
  tool.set_examples({"shapes2mesh scan_000/shapes.h5 scan_000/labels.h5 model.h5 --vtu model.vtu --msh model.msh",
                     "shapes2mesh shapes.h5 model.h5 --order 1 --elements-per-diameter 6",
                     "shapes2mesh shapes.h5 labels.h5 model.h5 --tracked-only tracks.h5",
                     "shapes2mesh shapes.h5 labels.h5 sample.h5 --packing equivalent --grains 500 --seed 2"});

  return tool.run(argc, argv, [&](cli::RunContext& ctx) {
    if (model_path.extension() != ".h5") throw UsageError("the model " + model_path.string() + " must end in .h5");
    if (!vtu_path.empty() && vtu_path.extension() != ".vtu") throw UsageError("--vtu " + vtu_path.string() + " must end in .vtu");
    if (!msh_path.empty() && msh_path.extension() != ".msh") throw UsageError("--msh " + msh_path.string() + " must end in .msh");
    const double thickness = parse_length_m(membrane_thickness, "--membrane-thickness");
    mo.snap_to_sh = curving == "snap";
    mo.sh_path = sh_meshing == "gmsh" ? mesh::MeshPath::gmsh_surface : mesh::MeshPath::kept_surface;
    const bool equivalent = packing == "equivalent";
    if (equivalent && po.solid_fraction == 0.0 && labels_path.empty())
      throw UsageError("--packing equivalent needs --solid-fraction, or LABELS whose sample cylinder gives the scan's");
    io::AtomicOutput out(model_path, ctx.force());
    std::optional<io::AtomicOutput> vtu_out, msh_out;
    if (!vtu_path.empty()) vtu_out.emplace(vtu_path, ctx.force());
    if (!msh_path.empty()) msh_out.emplace(msh_path, ctx.force());
    std::size_t meshes = 0;  // at most: the grains of SHAPES, or the equivalent sample's draws
    {
      const io::H5File sf = io::open_kind(shapes_path, schema::kind::shapes, "pass the output of labels2shapes");
      ctx.add_input_history(sf);
      const auto dims = sf.info("/grains/label").dims;
      meshes = dims.empty() ? 0 : dims[0];
      if (equivalent) meshes = std::max<std::size_t>(meshes, po.grains);
    }
    if (!labels_path.empty()) ctx.add_input_history(io::open_kind(labels_path, schema::kind::labels, "pass the output of ct2labels"));
    if (!tracks_path.empty()) io::open_kind(tracks_path, schema::kind::tracks, "pass the output of shapes2tracks");

    // Forked now, while the process is small and has no threads running.
    mesh::GmshWorkers workers(mesh::GmshWorkers::useful_count(ctx.threads(), meshes));
    mo.workers = &workers;
    shape::ShapesFile shapes = shape::read_shapes_file(shapes_path);
    if (shapes.grains.empty()) throw DataError(shapes_path.string() + " holds no grain; check the segmentation and labels2shapes run");
    std::optional<segment::LabelsFile> labels;
    std::unordered_map<std::uint32_t, std::array<std::size_t, 6>> bbox;
    if (!labels_path.empty()) {
      labels = segment::read_labels_file(labels_path);
      for (const auto& g : labels->grains) bbox[g.label] = g.bbox;
      for (const auto& g : shapes.grains)
        if (!bbox.count(g.label))
          throw UsageError("grain " + std::to_string(g.label) + " of " + shapes_path.string() + " is not in " + labels_path.string() +
                           "; pass the labels file the shapes were measured from");
    }
    if (sample_choice == "inscribed" && (!labels || equivalent))
      throw UsageError("--sample-cylinder inscribed needs LABELS and the scan's packing; pass the labels file, or leave it at auto");
    std::optional<fdem::SampleCylinder> inscribed;
    std::unordered_set<std::uint32_t> held;
    if (sample_choice == "inscribed") {
      inscribed = mesh::inscribed_cylinder(labels->labels, thickness);
      held = mesh::labels_within(labels->labels, inscribed->axis_xy, inscribed->radius, labels->labels.voxel_size()[2]);
    }
    // The grains meshed: those the inscribed cylinder holds whole (--sample-cylinder inscribed),
    // of them those tracked through the series (--tracked-only).
    std::vector<const shape::GrainShape*> grains;
    for (const auto& g : shapes.grains)
      if (!inscribed || held.count(g.label)) grains.push_back(&g);
    if (inscribed) {
      spdlog::info("inscribed cylinder: radius {:.3f} mm, axis ({:.3f}, {:.3f}) mm; {} of {} grains lie whole inside it, the rest "
                   "are left out",
                   inscribed->radius * 1e3, inscribed->axis_xy.x() * 1e3, inscribed->axis_xy.y() * 1e3, grains.size(), shapes.grains.size());
      if (grains.empty()) throw DataError("no grain of " + shapes_path.string() + " lies whole inside the scan's inscribed cylinder; leave --sample-cylinder at auto");
    }
    if (!tracks_path.empty()) {
      const auto keep = tracked_labels(tracks_path);
      const std::size_t before = grains.size();
      std::erase_if(grains, [&](const shape::GrainShape* g) { return !keep.count(g->label); });
      spdlog::info("{} of {} grains are tracked through {}", grains.size(), before, tracks_path.string());
      if (grains.empty()) throw DataError(tracks_path.string() + " tracks none of the grains of " + shapes_path.string() + "; pass the tracks of this scan series");
    }
    mo.rigid_diameter = rigid_below_d50 * shapes.psd.d50;
    mo.size.coarsest_size = mesh::neighbour_size_cap(shapes.psd.d50, size_cap_d50, mo.order, mo.size);

    // What is meshed: the scan's grains where they are, or an equivalent sample drawn from them
    // (copies centred on their body origin, meshed there and then placed).
    std::optional<mesh::EquivalentSample> sample;
    std::vector<shape::GrainShape> members;
    if (equivalent) {
      // The scan's sample: ct2labels' cylinder, over the whole scan height unless bounded in z.
      const segment::Cylinder region = labels ? labels->sample.region : segment::Cylinder{};
      const bool bounded = labels && std::isfinite(region.radius) && region.radius > 0;
      double height = 0.0;
      if (bounded) {
        const auto& v = labels->labels;
        const double z0 = v.position_xyz(0, 0, 0)[2], z1 = v.position_xyz(static_cast<double>(v.shape()[0] - 1), 0, 0)[2];
        const double half = 0.5 * v.voxel_size()[0];
        height = std::min(region.z_max, std::max(z0, z1) + half) - std::max(region.z_min, std::min(z0, z1) - half);
      }
      if (!bounded && po.solid_fraction == 0.0)
        throw UsageError(labels_path.string() + " has no bounded sample cylinder to take the solid fraction from; give --solid-fraction");
      if (po.solid_fraction == 0.0) {
        double solid = 0.0;
        for (const auto& g : shapes.grains) solid += g.volume;
        po.solid_fraction = solid / (M_PI * region.radius * region.radius * height);
        if (po.solid_fraction > synth::kDensestPacking)
          throw DataError(fmt::format("the scan's solid fraction comes out at {:.3f} from {}, above what packs; give --solid-fraction",
                                      po.solid_fraction, labels_path.string()));
      }
      if (po.aspect == 0.0) po.aspect = bounded ? height / (2.0 * region.radius) : 1.0;
      try {
        sample = mesh::pack_equivalent_sample(grains, shapes.degree, po, ctx.progress_callback("packing"));
      } catch (const DataError& e) {
        throw DataError(fmt::format("the equivalent sample did not pack at solid fraction {:.3f} ({}); lower --solid-fraction, "
                                    "draw more grains with --grains for a wider cylinder (rough grains jam near 0.58 in "
                                    "cylinders a few d50 across), or try another --seed or --aspect: near jamming, "
                                    "whether a draw packs depends on the draw",
                                    po.solid_fraction, e.message()));
      }
      throw_if_interrupted();
      for (std::size_t i = 0; i < sample->source.size(); ++i) {
        members.push_back(*grains[sample->source[i]]);
        members.back().centroid.setZero();
      }
      spdlog::info("equivalent sample: {} grains drawn from {} ({} unusable), d50 {:.3f} mm (library {:.3f} mm); packed at solid "
                   "fraction {:.4f} (core {:.4f}) into a cylinder of radius {:.3f} mm, height {:.3f} mm; max overlap {:.3g} um, "
                   "{} sweeps, {:.1f} s",
                   members.size(), grains.size(), sample->unusable, sample->psd.d50 * 1e3, shapes.psd.d50 * 1e3,
                   sample->report.solid_fraction, sample->report.core_solid_fraction, sample->container.radius * 1e3,
                   sample->container.height * 1e3, sample->report.max_overlap * 1e6, sample->report.sweeps, sample->report.seconds);
    }
    const std::size_t count = sample ? members.size() : grains.size();
    const auto grain = [&](std::size_t i) -> const shape::GrainShape& { return sample ? members[i] : *grains[i]; };
    const auto source_label = [&](std::size_t i) { return sample ? grains[sample->source[i]]->label : grains[i]->label; };

    mesh::check_meshing_memory(count, std::min<int>(ctx.threads(), static_cast<int>(count)), mo.order, mo.size);
    const mesh::ShSurfaceBasis basis(subdivisions, shapes.degree);
    std::vector<mesh::GrainMeshResult> results(count);
    std::vector<std::string> failures(count);
    auto progress = ctx.progress("meshing", count);
    // Voxel surfaces exist only where the grains are, in the scan.
    const Volume<std::uint32_t>* label_volume = labels && !sample ? &labels->labels : nullptr;
    // Largest grains first, one at a time to whichever thread is free: the costly ones (big voxel
    // surfaces, rough SH surfaces) start early and the small ones fill in, so no worker idles at
    // the end while another still has a long grain (a grain is bounded by --grain-budget).
    std::vector<std::size_t> order(count);
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return grain(a).equivalent_diameter > grain(b).equivalent_diameter; });
#pragma omp parallel for schedule(dynamic, 1)
    for (std::size_t k = 0; k < count; ++k) {
      const std::size_t i = order[k];
      if (interrupted()) continue;
      const auto box = label_volume ? bbox.at(grain(i).label) : std::array<std::size_t, 6>{};
      try {
        results[i] = mesh::mesh_grain(grain(i), basis, label_volume, box, mo);
        if (sample) mesh::place_mesh(results[i].mesh, sample->poses[i]);
      } catch (const Error& e) {
        failures[i] = e.message();
      }
      progress->advance(1);
    }
    progress.reset();
    throw_if_interrupted();
    for (std::size_t i = 0; i < count; ++i)
      if (!failures[i].empty())
        throw DataError("grain " + std::to_string(source_label(i)) + " could not be meshed: " + failures[i]);

    fdem::Model model;
    Report report;
    std::size_t origin_count[3] = {0, 0, 0}, path_count[3] = {0, 0, 0}, overran = 0, rigid = 0, remeshed = 0, optimized = 0, below = 0, curving_inverted = 0;
    double seconds = 0.0, grain_seconds = 0.0;
    for (std::size_t i = 0; i < count; ++i) {
      const auto& r = results[i];
      const std::uint32_t label = sample ? static_cast<std::uint32_t>(i + 1) : grains[i]->label;
      mesh::append_grain(model, r.mesh, label, r.kind);
      report.add(label, source_label(i), r);
      ++origin_count[static_cast<int>(r.origin)];
      ++path_count[static_cast<int>(r.path)];
      overran += r.overran;
      grain_seconds += r.seconds;
      if (r.overran) spdlog::warn("grain {}: gmsh overran --grain-budget {:g} s; meshed by the {} path from its {} instead", label,
                                  mo.budget_seconds, mesh::mesh_path_name(r.path), mesh::surface_origin_name(r.origin));
      rigid += r.kind == fdem::GrainKind::rigid;
      remeshed += r.remeshed;
      optimized += r.gmsh.optimized;
      curving_inverted += r.gmsh.inverted_after_curving > 0;
      below += r.quality.below_floor > 0 || r.quality.inverted > 0;
      seconds += r.gmsh.seconds;
      spdlog::debug("grain {}: {} from {}, {:.3f} s ({:.3f} s in gmsh), {} elements, {} surface nodes, volume {:+.2f} %, min gamma "
                    "{:.2f}{}{}",
                    label, mesh::mesh_path_name(r.path), mesh::surface_origin_name(r.origin), r.seconds, r.gmsh.seconds, r.quality.elements,
                    r.quality.surface_nodes, 100.0 * (r.quality.volume / r.surface_volume - 1.0), r.quality.min_gamma,
                    r.note.empty() ? "" : "; ", r.note);
    }
    if (label_volume && mo.cut_at_neighbours) {
      std::vector<double> shares(report.cut_share);
      std::sort(shares.begin(), shares.end());
      const auto cut = static_cast<std::size_t>(std::count_if(shares.begin(), shares.end(), [](double v) { return v > 0.0; }));
      if (!shares.empty())
        spdlog::info("cut at the neighbours' voxels: {} of {} grains, {:.2f} % of a grain's volume at the median, {:.1f} % at most",
                     cut, shares.size(), 100.0 * shares[shares.size() / 2], 100.0 * shares.back());
    }
    // The sample: the equivalent packing's cylinder, ct2labels' region when it is bounded, else
    // the cylinder around the grains.
    fdem::SampleCylinder cylinder = mesh::enclosing_cylinder(model, thickness);
    std::string sample_source = "grains";
    if (sample) {
      cylinder.axis_xy.setZero();
      cylinder.radius = sample->container.radius;
      cylinder.z_min = 0.0, cylinder.z_max = sample->container.height;
      sample_source = "equivalent packing";
    } else if (inscribed) {
      cylinder = *inscribed;
      sample_source = "inscribed in the scan";
    } else if (labels && std::isfinite(labels->sample.region.radius) && labels->sample.region.radius > 0) {
      const auto& c = labels->sample.region;
      cylinder.axis_xy = {c.centre_x, c.centre_y};
      cylinder.radius = c.radius;
      if (std::isfinite(c.z_min) && std::isfinite(c.z_max)) cylinder.z_min = c.z_min, cylinder.z_max = c.z_max;
      sample_source = "labels";
    }
    model.sample = cylinder;
    model.platens = mesh::end_platens(cylinder, platen_friction);
    const fdem::SampleCylinder& sample_cylinder = cylinder;

    const std::size_t n = count;
    spdlog::info("{} grains: {} from SH, {} from voxels, {} as ellipsoids; {} rigid (below {:.3g} mm)", n, origin_count[0],
                 origin_count[1], origin_count[2], rigid, mo.rigid_diameter * 1e3);
    spdlog::info("meshing paths: {} gmsh remeshed the surface, {} surface remeshed and kept as the boundary, {} ellipsoid; {} "
                 "overran --grain-budget {:g} s",
                 path_count[0], path_count[1], path_count[2], overran, mo.budget_seconds);
    spdlog::info("{} nodes, {} elements ({:.0f} per grain), {} surface triangles; {:.2f} s in gmsh ({:.3f} s per grain), {:.3f} s "
                 "per grain in all (summed over threads)",
                 model.nodes.size(), model.element_count(), static_cast<double>(model.element_count()) / n, model.triangles.size(),
                 seconds, seconds / n, grain_seconds / n);
    spdlog::info("quality: {} grains had elements inverted by curving ({} through optimize(HighOrder), the others' mid-edge "
                 "nodes pulled back); {} grains remeshed, {} still below the gamma floor {} or inverted",
                 curving_inverted, optimized, remeshed, below, mo.gamma_floor);
    spdlog::info("sample cylinder ({}): axis ({:.4g}, {:.4g}) mm, radius {:.4g} mm, z {:.4g} .. {:.4g} mm", sample_source,
                 sample_cylinder.axis_xy.x() * 1e3, sample_cylinder.axis_xy.y() * 1e3, sample_cylinder.radius * 1e3,
                 sample_cylinder.z_min * 1e3, sample_cylinder.z_max * 1e3);

    nlohmann::json parameters = {
        {"order", mo.order}, {"elements_per_diameter", mo.size.elements_per_diameter}, {"surface_nodes", mo.size.surface_nodes},
        {"size_cap_d50", size_cap_d50},
        {"volume_tolerance", mo.size.volume_tolerance}, {"gamma_floor", mo.gamma_floor}, {"rigid_below_d50", rigid_below_d50},
        {"rigid_diameter_m", mo.rigid_diameter}, {"surface_subdivisions", subdivisions}, {"smooth_vox", mo.smooth_vox}, {"curving", curving},
        {"cut_at_neighbours", mo.cut_at_neighbours && label_volume != nullptr},
        {"membrane_thickness_m", thickness}, {"platen_friction", platen_friction}, {"sample_source", sample_source},
        {"tracked_only", tracks_path.string()}, {"gmsh_processes", workers.size()}, {"packing", packing},
        {"grain_budget_s", mo.budget_seconds}, {"sh_meshing", sh_meshing}};
    parameters["sample_cylinder"] = sample_choice;
    if (sample)
      parameters["equivalent_packing"] = {{"grains", po.grains}, {"solid_fraction", po.solid_fraction}, {"aspect", po.aspect},
                                          {"seed", po.seed}, {"packed_solid_fraction", sample->report.solid_fraction},
                                          {"core_solid_fraction", sample->report.core_solid_fraction},
                                          {"d50_m", sample->psd.d50}, {"library_d50_m", shapes.psd.d50}};
    fdem::write_model_file(out.temp_path(), model, ctx.history(), [&](io::H5File& f) { report.write(f, parameters.dump()); });
    if (vtu_out) io::write_vtu(vtu_out->temp_path(), fdem::model_grid(model));
    if (msh_out) fdem::write_model_msh(msh_out->temp_path(), model);
    io::commit_outputs({&out, vtu_out ? &*vtu_out : nullptr, msh_out ? &*msh_out : nullptr});
  });
}
