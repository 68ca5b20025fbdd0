// shapes2mesh: the FDEM twin of the reference scan (SPEC.md sections 5, 7, 8; issue 8).
//   shapes2mesh scan_000/shapes.h5 scan_000/labels.h5 model.h5 --vtu model.vtu --msh model.msh
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <cmath>
#include <optional>
#include <set>
#include <unordered_map>

#include "graintwin/cli/tool.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/strings.hpp"
#include "graintwin/fdem/model_file.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"
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
  std::vector<std::uint32_t> label;
  std::vector<std::uint8_t> origin, kind, optimized, remeshed;
  std::vector<std::uint64_t> elements, nodes, surface_nodes, inverted_after_curving, inverted;
  std::vector<double> size, min_gamma, mean_gamma, min_jacobian, volume, surface_volume, volume_error, seconds;
  std::vector<std::string> note;

  void add(std::uint32_t l, const mesh::GrainMeshResult& r) {
    label.push_back(l);
    origin.push_back(static_cast<std::uint8_t>(r.origin));
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
    seconds.push_back(r.gmsh.seconds);
    note.push_back(r.note);
  }
  void write(io::H5File& f, const std::string& parameters) const {
    using io::units;
    f.write("/mesh/label", label);
    f.write("/mesh/surface_origin", origin);
    f.set_attr("/mesh/surface_origin", "codes", std::string("0 SH fit, 1 smoothed voxels, 2 inertia ellipsoid"));
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
    f.write("/mesh/gmsh_seconds", seconds, units("s"));
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
      "the membrane geometry and the default materials of SPEC.md section 0. Each grain's surface is its SH fit (an "
      "icosphere displaced to r(direction)); where labels2shapes flagged the fit unreliable, or the SH surface fails "
      "the checks (closed, manifold, one piece, outward, no self-intersection), the grain's smoothed voxels from "
      "LABELS are used, and without LABELS (or if those fail too) its inertia ellipsoid, with a note. gmsh meshes the "
      "surface (4-node, or 10-node: by default with straight mid-edge nodes whose boundary nodes are then moved "
      "onto the exact SH surface, --curving gmsh for gmsh's own curving with optimize(HighOrder); either way every "
      "element's Jacobian is checked and inverted ones have their mid-edge nodes pulled back). The element size follows what contact needs (about "
      "--surface-nodes nodes on each grain's surface) and, for 4-node meshes, a volume accuracy target; "
      "--elements-per-diameter overrides both. Quality (gamma = 3 inradius / circumradius) is measured per element; "
      "a grain with elements below --gamma-floor is remeshed once at 0.7 h. Grains smaller than --rigid-below d50 get "
      "a coarse linear mesh and are marked rigid. LABELS also gives the sample cylinder (ct2labels' region) when it "
      "is bounded; otherwise the cylinder encloses the meshed grains. Grains run in parallel, but gmsh is not "
      "thread-safe, so the gmsh part of each grain runs one at a time (docs/shapes2mesh.md). Not yet: the "
      "statistically equivalent packing mode.");
  fs::path shapes_path, labels_path, model_path, vtu_path, msh_path, tracks_path;
  mesh::GrainMeshOptions mo;
  int subdivisions = 4;
  double rigid_below_d50 = 0.3, platen_friction = 0.0;
  std::string membrane_thickness = "0.3mm", curving = "snap";
  tool.add_input("SHAPES", shapes_path, "Shapes of the reference scan (.h5, kind=shapes)");
  tool.add_optional_input("LABELS", labels_path,
                          "Labels of the same scan (.h5, kind=labels): voxel surfaces for unreliable SH fits, the sample cylinder");
  tool.add_output("MODEL", model_path, "The model to write (.h5, kind=fdem_model)");
  auto& app = tool.cli();
  app.add_option("--order", mo.order, "Element order: 1 (4-node) or 2 (10-node, the CT-FDEM paper's)")
      ->check(CLI::IsMember({1, 2}))->capture_default_str();
  app.add_option("--elements-per-diameter", mo.size.elements_per_diameter,
                 "Element size = equivalent diameter / this, for every grain (0: automatic)")
      ->check(CLI::Range(0.0, 100.0))->capture_default_str();
  app.add_option("--surface-nodes", mo.size.surface_nodes, "Automatic size: surface nodes per grain that contact needs")
      ->check(CLI::Range(20.0, 1e5))->capture_default_str();
  app.add_option("--volume-tol", mo.size.volume_tolerance, "Automatic size, 4-node: largest relative volume error of the facets")
      ->check(CLI::Range(1e-4, 0.5))->capture_default_str();
  app.add_option("--gamma-floor", mo.gamma_floor, "Elements below this quality make a grain remeshed (and reported)")
      ->check(CLI::Range(0.0, 0.9))->capture_default_str();
  app.add_option("--rigid-below", rigid_below_d50, "Grains with equivalent diameter below this many d50 are rigid, coarse, linear")
      ->check(CLI::Range(0.0, 10.0))->capture_default_str();
  app.add_option("--surface-subdivisions", subdivisions, "Icosphere level of the SH surfaces handed to gmsh (4: 5120 triangles)")
      ->check(CLI::Range(2, 6))->capture_default_str();
  app.add_option("--smooth", mo.smooth_vox, "Gaussian sigma (voxels) of the voxel surfaces")
      ->check(CLI::Range(0.0, 5.0))->capture_default_str();
  app.add_option("--curving", curving,
                 "10-node grains with an SH surface: snap (boundary nodes moved onto the exact SH surface, inverted "
                 "elements pulled back) or gmsh (gmsh curves onto the triangulated surface, optimize(HighOrder) when "
                 "an element is inverted; slower)")
      ->check(CLI::IsMember({"snap", "gmsh"}))->capture_default_str();
  app.add_option("--membrane-thickness", membrane_thickness, "Latex membrane thickness (SPEC section 8)")->capture_default_str();
  app.add_option("--platen-friction", platen_friction, "Coulomb friction of the platens (smooth: 0)")
      ->check(CLI::Range(0.0, 2.0))->capture_default_str();
  app.add_option("--tracked-only", tracks_path, "Keep only grains tracked from the first scan to the last in this kind=tracks file")
      ->check(CLI::ExistingFile);
  app.add_option("--vtu", vtu_path, "Also write the model for ParaView (.vtu)");
  app.add_option("--msh", msh_path, "Also write the model for gmsh (.msh, format 2.2)");
  tool.set_examples({"shapes2mesh scan_000/shapes.h5 scan_000/labels.h5 model.h5 --vtu model.vtu --msh model.msh",
                     "shapes2mesh shapes.h5 model.h5 --order 1 --elements-per-diameter 6",
                     "shapes2mesh shapes.h5 labels.h5 model.h5 --tracked-only tracks.h5"});

  return tool.run(argc, argv, [&](cli::RunContext& ctx) {
    if (model_path.extension() != ".h5") throw UsageError("the model " + model_path.string() + " must end in .h5");
    if (!vtu_path.empty() && vtu_path.extension() != ".vtu") throw UsageError("--vtu " + vtu_path.string() + " must end in .vtu");
    if (!msh_path.empty() && msh_path.extension() != ".msh") throw UsageError("--msh " + msh_path.string() + " must end in .msh");
    const double thickness = parse_length_m(membrane_thickness, "--membrane-thickness");
    mo.snap_to_sh = curving == "snap";
    io::AtomicOutput out(model_path, ctx.force());
    std::optional<io::AtomicOutput> vtu_out, msh_out;
    if (!vtu_path.empty()) vtu_out.emplace(vtu_path, ctx.force());
    if (!msh_path.empty()) msh_out.emplace(msh_path, ctx.force());
    ctx.add_input_history(io::open_kind(shapes_path, schema::kind::shapes, "pass the output of labels2shapes"));
    if (!labels_path.empty()) ctx.add_input_history(io::open_kind(labels_path, schema::kind::labels, "pass the output of ct2labels"));
    if (!tracks_path.empty()) io::open_kind(tracks_path, schema::kind::tracks, "pass the output of shapes2tracks");

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
    std::vector<const shape::GrainShape*> grains;
    if (!tracks_path.empty()) {
      const auto keep = tracked_labels(tracks_path);
      for (const auto& g : shapes.grains)
        if (keep.count(g.label)) grains.push_back(&g);
      spdlog::info("{} of {} grains are tracked through {}", grains.size(), shapes.grains.size(), tracks_path.string());
      if (grains.empty()) throw DataError(tracks_path.string() + " tracks none of the grains of " + shapes_path.string() + "; pass the tracks of this scan series");
    } else {
      for (const auto& g : shapes.grains) grains.push_back(&g);
    }
    mo.rigid_diameter = rigid_below_d50 * shapes.psd.d50;

    const mesh::ShSurfaceBasis basis(subdivisions, shapes.degree);
    std::vector<mesh::GrainMeshResult> results(grains.size());
    std::vector<std::string> failures(grains.size());
    auto progress = ctx.progress("meshing", grains.size());
    const Volume<std::uint32_t>* label_volume = labels ? &labels->labels : nullptr;
#pragma omp parallel for schedule(dynamic, 1)
    for (std::size_t i = 0; i < grains.size(); ++i) {
      if (cli::interrupted()) continue;
      const auto box = label_volume ? bbox.at(grains[i]->label) : std::array<std::size_t, 6>{};
      try {
        results[i] = mesh::mesh_grain(*grains[i], basis, label_volume, box, mo);
      } catch (const Error& e) {
        failures[i] = e.message();
      }
      progress->advance(1);
    }
    progress.reset();
    cli::throw_if_interrupted();
    for (std::size_t i = 0; i < grains.size(); ++i)
      if (!failures[i].empty())
        throw DataError("grain " + std::to_string(grains[i]->label) + " could not be meshed: " + failures[i]);

    fdem::Model model;
    Report report;
    std::size_t origin_count[3] = {0, 0, 0}, rigid = 0, remeshed = 0, optimized = 0, below = 0, curving_inverted = 0;
    double seconds = 0.0;
    for (std::size_t i = 0; i < grains.size(); ++i) {
      const auto& r = results[i];
      mesh::append_grain(model, r.mesh, grains[i]->label, r.kind);
      report.add(grains[i]->label, r);
      ++origin_count[static_cast<int>(r.origin)];
      rigid += r.kind == fdem::GrainKind::rigid;
      remeshed += r.remeshed;
      optimized += r.gmsh.optimized;
      curving_inverted += r.gmsh.inverted_after_curving > 0;
      below += r.quality.below_floor > 0 || r.quality.inverted > 0;
      seconds += r.gmsh.seconds;
      if (!r.note.empty()) spdlog::debug("grain {}: {}", grains[i]->label, r.note);
    }
    // The sample: ct2labels' region when it is bounded, else the cylinder around the grains.
    fdem::SampleCylinder sample = mesh::enclosing_cylinder(model, thickness);
    std::string sample_source = "grains";
    if (labels && std::isfinite(labels->sample.region.radius) && labels->sample.region.radius > 0) {
      const auto& c = labels->sample.region;
      sample.axis_xy = {c.centre_x, c.centre_y};
      sample.radius = c.radius;
      if (std::isfinite(c.z_min) && std::isfinite(c.z_max)) sample.z_min = c.z_min, sample.z_max = c.z_max;
      sample_source = "labels";
    }
    model.sample = sample;
    model.platens = mesh::end_platens(sample, platen_friction);

    const std::size_t n = grains.size();
    spdlog::info("{} grains: {} from SH, {} from voxels, {} as ellipsoids; {} rigid (below {:.3g} mm)", n, origin_count[0],
                 origin_count[1], origin_count[2], rigid, mo.rigid_diameter * 1e3);
    spdlog::info("{} nodes, {} elements ({:.0f} per grain), {} surface triangles; {:.2f} s in gmsh ({:.3f} s per grain)",
                 model.nodes.size(), model.element_count(), static_cast<double>(model.element_count()) / n, model.triangles.size(),
                 seconds, seconds / n);
    spdlog::info("quality: {} grains had elements inverted by curving ({} through optimize(HighOrder), the others' mid-edge "
                 "nodes pulled back); {} grains remeshed, {} still below the gamma floor {} or inverted",
                 curving_inverted, optimized, remeshed, below, mo.gamma_floor);
    spdlog::info("sample cylinder ({}): axis ({:.4g}, {:.4g}) mm, radius {:.4g} mm, z {:.4g} .. {:.4g} mm", sample_source,
                 sample.axis_xy.x() * 1e3, sample.axis_xy.y() * 1e3, sample.radius * 1e3, sample.z_min * 1e3, sample.z_max * 1e3);

    const nlohmann::json parameters = {
        {"order", mo.order}, {"elements_per_diameter", mo.size.elements_per_diameter}, {"surface_nodes", mo.size.surface_nodes},
        {"volume_tolerance", mo.size.volume_tolerance}, {"gamma_floor", mo.gamma_floor}, {"rigid_below_d50", rigid_below_d50},
        {"rigid_diameter_m", mo.rigid_diameter}, {"surface_subdivisions", subdivisions}, {"smooth_vox", mo.smooth_vox}, {"curving", curving},
        {"membrane_thickness_m", thickness}, {"platen_friction", platen_friction}, {"sample_source", sample_source},
        {"tracked_only", tracks_path.string()}, {"gmsh_serialised", true}};
    fdem::write_model_file(out.temp_path(), model, ctx.history(), [&](io::H5File& f) { report.write(f, parameters.dump()); });
    if (vtu_out) io::write_vtu(vtu_out->temp_path(), fdem::model_grid(model));
    if (msh_out) fdem::write_model_msh(msh_out->temp_path(), model);
    out.commit();
    if (vtu_out) vtu_out->commit();
    if (msh_out) msh_out->commit();
  });
}
