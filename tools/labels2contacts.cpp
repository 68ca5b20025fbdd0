// labels2contacts: the contacts between labelled grains (docs/methods.md, contacts and fabric): detection in the
// 26-neighbourhood, PCA normals, sub-voxel normals and a contact confidence from the grey levels,
// branch vectors, coordination numbers, fabric tensors, anisotropy and rose counts.
//   labels2contacts labels_000.h5 scan_000.h5 contacts_000.h5
//   labels2contacts labels_000.h5 contacts_000.h5 --vtk contacts_000.vtp
#include <spdlog/spdlog.h>

#include <cmath>
#include <map>
#include <optional>

#include "graintwin/cli/option_checks.hpp"
#include "graintwin/cli/tool.hpp"
#include "graintwin/contacts/contacts_file.hpp"
#include "graintwin/contacts/network.hpp"
#include "graintwin/contacts/refine.hpp"
#include "graintwin/contacts/scan_contacts.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/interrupt.hpp"
#include "graintwin/core/resources.hpp"
#include "graintwin/core/strings.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/io/vtk.hpp"
#include "graintwin/segment/labels_file.hpp"

namespace fs = std::filesystem;
using namespace graintwin;

namespace {

struct Options {
  contacts::ContactsSettings settings;
  bool no_refine = false;
  fs::path vtk;
};

/// The grey volume's geometry must be the labels' (same scan).
void check_same_geometry(const io::ImageHeader& labels, const fs::path& labels_path, const io::ImageHeader& grey,
                         const fs::path& grey_path) {
  const auto dims = [](const Shape3& s) {
    return std::to_string(s[0]) + " x " + std::to_string(s[1]) + " x " + std::to_string(s[2]);
  };
  if (labels.shape != grey.shape)
    throw UsageError(grey_path.string() + " is " + dims(grey.shape) + " (z, y, x) but " + labels_path.string() + " is " +
                     dims(labels.shape) + "; pass the scan the labels were made from");
  for (int a = 0; a < 3; ++a)
    if (std::abs(labels.voxel_size[a] - grey.voxel_size[a]) > 1e-6 * labels.voxel_size[a])
      throw UsageError(grey_path.string() + " and " + labels_path.string() +
                       " have different voxel sizes; pass the scan the labels were made from");
}

/// The input headers, before anything heavy is read: the labels are uint32, the fit window fits
/// the volume, the grey scan (when given) has the labels' geometry. Records both inputs' history.
void check_inputs(cli::RunContext& ctx, const fs::path& labels_path, const fs::path& volume_path, const Options& o) {
  const io::H5File lf = io::open_kind(labels_path, schema::kind::labels, "pass the output of ct2labels");
  ctx.add_input_history(lf);
  const io::ImageHeader lh = io::read_image_header(lf, schema::path::labels);
  if (lh.dtype != DType::uint32)
    throw UsageError(labels_path.string() + ":/labels is " + dtype_name(lh.dtype) + ", expected uint32; rewrite it with ct2labels");
  const double window = o.settings.window_vox;
  if (o.settings.refined && window > 0.0)  // the fit reads a box of the window plus the third-grain margin
    check_kernel_fits(std::ceil(window) + contacts::RefineParams{}.exclusion_vox, lh.shape,
                      fmt::format("--window-vox {:g} (with its {}-voxel margin)", window, contacts::RefineParams{}.exclusion_vox),
                      "give a smaller --window-vox, or 0 for the automatic window");
  if (volume_path.empty()) return;
  const io::H5File vf = io::open_kind(volume_path, schema::kind::volume, "pass the grey scan (kind=volume) the labels were made from");
  ctx.add_input_history(vf);
  check_same_geometry(lh, labels_path, io::read_image_header(vf, schema::path::volume), volume_path);
}

void log_refinement(const std::vector<contacts::Refinement>& fits) {
  std::map<std::string, std::size_t> status;
  for (const auto& f : fits) ++status[contacts::status_name(f.status)];
  std::string summary;
  for (const auto& [name, n] : status) summary += (summary.empty() ? "" : ", ") + std::to_string(n) + " " + name;
  spdlog::info("refinement: {} (the others keep the PCA normal)", summary);
}

void log_counted(const contacts::ContactsFile& c, const std::vector<contacts::Refinement>& fits, const fs::path& volume_path) {
  const std::size_t m = c.contacts.size();
  if (c.settings.refined) {
    const double min_confidence = c.settings.min_confidence;
    const contacts::ConfidenceCount cc = contacts::count_confidences(fits, min_confidence);
    spdlog::info("{} of {} contacts are counted in Z and the fabric: {} with confidence >= {} and {} not fitted "
                 "(confidence unknown); {} below",
                 contacts::accepted_count(c), m, cc.at_least, min_confidence, cc.unknown, cc.below);
    if (m > 0 && cc.unknown == m)
      spdlog::warn("no contact could be fitted to the grey levels of {}: every confidence is unknown (NaN) and every "
                   "normal is the PCA one; check that it is the scan the labels were made from",
                   volume_path.string());
  }
  spdlog::info("mean coordination number {:.3f} over {} grains; anisotropy a = {:.3f} (normals), {:.3f} (branches)",
               c.coordination.mean, c.coordination.counted, c.fabric_normal.anisotropy, c.fabric_branch.anisotropy);
}

/// The inputs, the output and the options with their ranges and defaults.
void usage(cli::Tool& tool, fs::path& labels_path, fs::path& volume_path, fs::path& output, Options& o) {
  auto& app = tool.cli();
  tool.add_input("labels", labels_path, "kind=labels .h5 (ct2labels)");
  tool.add_optional_input("volume", volume_path, "kind=volume .h5: the grey scan the labels were made from; enables "
                                                 "the refined normals and the confidence");
  tool.add_output("contacts", output, "Output kind=contacts .h5");
  using cli::closed, cli::above, cli::number_in, cli::whole_number_in;
  app.add_option("--min-voxels", o.settings.min_voxels, "Contact voxels each grain of a pair needs for a contact")
      ->check(whole_number_in(1, 1000000000, "voxels"))
      ->capture_default_str();
  app.add_flag("--no-refine", o.no_refine, "Keep the PCA normals even when VOLUME is given (no confidence then)");
  app.add_option("--window-vox", o.settings.window_vox,
                 "Radius of the voxel ball fitted around each contact (0 = 0.6 x the smaller grain's equivalent "
                 "radius, within 3 to 7 voxels)")
      ->check(number_in(closed(0, 30, "voxels")))
      ->capture_default_str();
  app.add_option("--gap-tolerance-vox", o.settings.gap_tolerance_vox,
                 "The confidence is the probability that the fitted gap is below this (voxels)")
      ->check(number_in(above(0, 10, "voxels")))
      ->capture_default_str();
  app.add_option("--min-confidence", o.settings.min_confidence,
                 "Contacts counted in Z, fabric and roses need at least this confidence (unknown counts)")
      ->check(number_in(closed(0, 1)))
      ->capture_default_str();
  app.add_option("--theta-bins", o.settings.theta_bins, "Rose bins in the polar angle from +z over 0-90 degrees")
      ->check(whole_number_in(1, 90))
      ->capture_default_str();
  app.add_option("--phi-bins", o.settings.phi_bins, "Rose bins in the azimuth from +x over 0-360 degrees")
      ->check(whole_number_in(1, 360))
      ->capture_default_str();
  app.add_flag("--include-edge-grains", o.settings.include_edge_grains,
               "Count grains cut by the volume edge in the coordination histogram and mean");
  app.add_option("--vtk", o.vtk, "Also write the contact network as VTK polydata (.vtp) for ParaView");
  tool.set_examples({"labels2contacts labels_000.h5 scan_000.h5 contacts_000.h5",
                     "labels2contacts labels_000.h5 contacts_000.h5 --vtk contacts_000.vtp",
                     "labels2contacts labels_000.h5 scan_000.h5 contacts_000.h5 --min-confidence 0.9"});
}

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool(
      "labels2contacts",
      "Contacts between the grains of a labels file (method: docs/methods.md). Grains i < j touch where their voxels "
      "are 26-neighbours; each pair is one contact (all its regions together) when both grains have at least "
      "--min-voxels contact voxels. Per contact: PCA normal of the contact voxel pairs (low -> high label), area "
      "from the oriented voxel faces, centroid, branch vector. With the grey VOLUME the normal is refined to "
      "sub-voxel accuracy by fitting two osculating spheres, blurred as the scanner blurs them, to the grey "
      "levels around the contact (touching spheres, grey 0.25 / 0.75, blur 0.8 voxel, noise 0.03: mean error 0.9 "
      "degree at 8 and 0.2 degree at 20 voxels per diameter, against 13 and 5 degrees for PCA; on rough sand grains "
      "both stay near 15 degrees at 20 voxels per diameter, because their surface turns faster than the blur "
      "resolves), and the fitted gap between the surfaces gives each contact a confidence that the grains really "
      "touch (a global threshold merges grains about a voxel apart). Contacts with confidence below "
      "--min-confidence are written but not counted in the coordination numbers, fabric tensors, anisotropy "
      "and rose counts. Output: kind=contacts .h5 (docs/formats.md), optionally a .vtp for ParaView.");
  fs::path labels_path, volume_path, output;
  Options o;
  usage(tool, labels_path, volume_path, output, o);

  return tool.run(argc, argv, [&](cli::RunContext& ctx) {
    // Options, outputs and input headers first: nothing heavy is read before they pass.
    const std::string ext = lower(output.extension().string());
    if (ext != ".h5" && ext != ".hdf5") throw UsageError("output " + output.string() + " must end in .h5");
    if (!o.vtk.empty() && lower(o.vtk.extension().string()) != ".vtp")
      throw UsageError("--vtk " + o.vtk.string() + " must end in .vtp (VTK XML polydata)");
    io::AtomicOutput out(output, ctx.force());
    std::optional<io::AtomicOutput> vtk_out;
    if (!o.vtk.empty()) vtk_out.emplace(o.vtk, ctx.force());
    o.settings.refined = !volume_path.empty() && !o.no_refine;
    check_inputs(ctx, labels_path, volume_path, o);
    if (!volume_path.empty() && o.no_refine) spdlog::warn("--no-refine: {} is not used", volume_path.string());

    segment::LabelsFile lab = segment::read_labels_file(labels_path);
    if (lab.grains.empty())
      throw DataError(labels_path.string() + " holds no grains; check its segmentation (ct2labels threshold and markers)");
    throw_if_interrupted();
    AnyVolume grey;
    if (o.settings.refined) {
      grey = io::read_volume_file(volume_path);
      contacts::check_grey_for_refinement(grey, volume_path.string());
    }
    const Shape3& s = lab.labels.shape();
    spdlog::info("{} grains in {} x {} x {} voxels (z, y, x)", lab.grains.size(), s[0], s[1], s[2]);

    const contacts::ScanContacts scan =
        contacts::scan_contacts(lab, o.settings.refined ? &grey : nullptr, o.settings, labels_path.string(),
                                [&](const std::string& step) { return ctx.progress_callback(step); });
    if (o.settings.refined) log_refinement(scan.fits);
    const contacts::ContactsFile& content = scan.content;
    log_counted(content, scan.fits, volume_path);
    contacts::write_contacts_file(out.temp_path(), content, ctx.history());
    if (vtk_out) io::write_vtp(vtk_out->temp_path(), contacts::network_polydata(contacts::contact_network(content, lab.grains)));
    throw_if_interrupted();
    io::commit_outputs({&out, vtk_out ? &*vtk_out : nullptr});
  });
}
