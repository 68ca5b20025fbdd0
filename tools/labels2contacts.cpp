// labels2contacts: the contacts between labelled grains (docs/methods.md, contacts and fabric): detection in the
// 26-neighbourhood, PCA normals, sub-voxel normals and a contact confidence from the grey levels,
// branch vectors, coordination numbers, fabric tensors, anisotropy and rose counts.
//   labels2contacts labels_000.h5 scan_000.h5 contacts_000.h5
//   labels2contacts labels_000.h5 contacts_000.h5 --vtk contacts_000.vtp
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>

#include "graintwin/cli/option_checks.hpp"
#include "graintwin/cli/tool.hpp"
#include "graintwin/contacts/detect.hpp"
#include "graintwin/contacts/fabric.hpp"
#include "graintwin/contacts/network.hpp"
#include "graintwin/contacts/refine.hpp"
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
namespace sc = graintwin::schema::contacts;

namespace {

struct Options {
  std::uint64_t min_voxels = 2;
  bool no_refine = false;
  double window_vox = contacts::RefineParams{}.window_vox;
  double gap_tolerance_vox = contacts::RefineParams{}.gap_tolerance_vox;
  double min_confidence = 0.5;
  int theta_bins = 9, phi_bins = 36;
  bool include_edge_grains = false;
  fs::path vtk;
};

/// Status code written to /contacts/fit_status for contacts whose fit was not attempted.
constexpr std::uint8_t kNotAttempted = 4;

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

/// Rows of (x, y, z) vectors as an M x 3 array.
std::vector<double> rows3(const std::vector<Vec3>& v) {
  std::vector<double> out;
  out.reserve(3 * v.size());
  for (const Vec3& x : v) out.insert(out.end(), x.begin(), x.end());
  return out;
}

io::DatasetOptions units(const char* u) {
  io::DatasetOptions o;
  o.units = u;
  return o;
}

void write_fabric(io::H5File& f, const std::string& group, const contacts::Fabric& fab) {
  const std::string g = group + "/";
  std::vector<double> tensor(9), directions(9);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      tensor[3 * i + j] = fab.tensor(i, j);
      directions[3 * i + j] = fab.principal_directions(j, i);  // row i = direction i
    }
  f.write(g + sc::tensor, tensor.data(), {3, 3}, units("1"));
  f.write(g + sc::principal_values, std::vector<double>(fab.principal_values.begin(), fab.principal_values.end()),
          units("1"));
  f.write(g + sc::principal_directions, directions.data(), {3, 3}, units("1"));
  f.write(g + sc::anisotropy, &fab.anisotropy, {}, units("1"));
  const auto count = static_cast<std::uint64_t>(fab.count);
  f.write(g + sc::count, &count, {});
}

void write_rose(io::H5File& f, const std::string& group, const contacts::Rose& r) {
  const std::string g = group + "/";
  const hsize_t nt = r.theta_edges.size() - 1, np = r.phi_edges.size() - 1;
  f.write(g + sc::theta_edges, r.theta_edges, units("rad"));
  f.write(g + sc::phi_edges, r.phi_edges, units("rad"));
  f.write(g + sc::counts, r.counts.data(), {nt, np});
  f.write(g + sc::density, r.density.data(), {nt, np}, units("1/sr"));
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
  auto& app = tool.cli();
  tool.add_input("labels", labels_path, "kind=labels .h5 (ct2labels)");
  tool.add_optional_input("volume", volume_path, "kind=volume .h5: the grey scan the labels were made from; enables "
                                                 "the refined normals and the confidence");
  tool.add_output("contacts", output, "Output kind=contacts .h5");
  using cli::closed, cli::above, cli::number_in, cli::whole_number_in;
  app.add_option("--min-voxels", o.min_voxels, "Contact voxels each grain of a pair needs for a contact")
      ->check(whole_number_in(1, 1000000000, "voxels"))
      ->capture_default_str();
  app.add_flag("--no-refine", o.no_refine, "Keep the PCA normals even when VOLUME is given (no confidence then)");
  app.add_option("--window-vox", o.window_vox,
                 "Radius of the voxel ball fitted around each contact (0 = 0.6 x the smaller grain's equivalent "
                 "radius, within 3 to 7 voxels)")
      ->check(number_in(closed(0, 30, "voxels")))
      ->capture_default_str();
  app.add_option("--gap-tolerance-vox", o.gap_tolerance_vox,
                 "The confidence is the probability that the fitted gap is below this (voxels)")
      ->check(number_in(above(0, 10, "voxels")))
      ->capture_default_str();
  app.add_option("--min-confidence", o.min_confidence,
                 "Contacts counted in Z, fabric and roses need at least this confidence (unknown counts)")
      ->check(number_in(closed(0, 1)))
      ->capture_default_str();
  app.add_option("--theta-bins", o.theta_bins, "Rose bins in the polar angle from +z over 0-90 degrees")
      ->check(whole_number_in(1, 90))
      ->capture_default_str();
  app.add_option("--phi-bins", o.phi_bins, "Rose bins in the azimuth from +x over 0-360 degrees")
      ->check(whole_number_in(1, 360))
      ->capture_default_str();
  app.add_flag("--include-edge-grains", o.include_edge_grains,
               "Count grains cut by the volume edge in the coordination histogram and mean");
  app.add_option("--vtk", o.vtk, "Also write the contact network as VTK polydata (.vtp) for ParaView");
  tool.set_examples({"labels2contacts labels_000.h5 scan_000.h5 contacts_000.h5",
                     "labels2contacts labels_000.h5 contacts_000.h5 --vtk contacts_000.vtp",
                     "labels2contacts labels_000.h5 scan_000.h5 contacts_000.h5 --min-confidence 0.9"});

  return tool.run(argc, argv, [&](cli::RunContext& ctx) {
    // Options, outputs and input headers first: nothing heavy is read before they pass.
    const std::string ext = lower(output.extension().string());
    if (ext != ".h5" && ext != ".hdf5") throw UsageError("output " + output.string() + " must end in .h5");
    if (!o.vtk.empty() && lower(o.vtk.extension().string()) != ".vtp")
      throw UsageError("--vtk " + o.vtk.string() + " must end in .vtp (VTK XML polydata)");
    io::AtomicOutput out(output, ctx.force());
    std::optional<io::AtomicOutput> vtk_out;
    if (!o.vtk.empty()) vtk_out.emplace(o.vtk, ctx.force());
    const bool have_grey = !volume_path.empty();
    const bool refine = have_grey && !o.no_refine;
    {
      const io::H5File lf = io::open_kind(labels_path, schema::kind::labels, "pass the output of ct2labels");
      ctx.add_input_history(lf);
      const io::ImageHeader lh = io::read_image_header(lf, schema::path::labels);
      if (lh.dtype != DType::uint32)
        throw UsageError(labels_path.string() + ":/labels is " + dtype_name(lh.dtype) + ", expected uint32; rewrite it with ct2labels");
      if (refine && o.window_vox > 0.0)  // the fit reads a box of the window plus the third-grain margin
        check_kernel_fits(std::ceil(o.window_vox) + contacts::RefineParams{}.exclusion_vox, lh.shape,
                          fmt::format("--window-vox {:g} (with its {}-voxel margin)", o.window_vox,
                                      contacts::RefineParams{}.exclusion_vox),
                          "give a smaller --window-vox, or 0 for the automatic window");
      if (have_grey) {
        const io::H5File vf = io::open_kind(volume_path, schema::kind::volume, "pass the grey scan (kind=volume) the labels were made from");
        ctx.add_input_history(vf);
        check_same_geometry(lh, labels_path, io::read_image_header(vf, schema::path::volume), volume_path);
      }
    }
    if (have_grey && o.no_refine) spdlog::warn("--no-refine: {} is not used", volume_path.string());

    segment::LabelsFile lab = segment::read_labels_file(labels_path);
    if (lab.grains.empty())
      throw DataError(labels_path.string() + " holds no grains; check its segmentation (ct2labels threshold and markers)");
    throw_if_interrupted();
    AnyVolume grey;
    if (refine) {
      grey = io::read_volume_file(volume_path);
      contacts::check_grey_for_refinement(grey, volume_path.string());
    }
    const Shape3& s = lab.labels.shape();
    spdlog::info("{} grains in {} x {} x {} voxels (z, y, x)", lab.grains.size(), s[0], s[1], s[2]);

    std::vector<contacts::Contact> found;
    try {
      found = contacts::find_contacts(lab.labels, lab.grains, {o.min_voxels}, ctx.progress_callback("contacts"));
    } catch (Error& e) {
      throw e.add_context("in " + labels_path.string() + "; its grain table does not match its label image");
    }
    throw_if_interrupted();
    const std::size_t m = found.size();
    if (m == 0) spdlog::warn("no contacts: the grains of {} do not touch", labels_path.string());

    std::vector<contacts::Refinement> fits(m);
    if (refine) {
      contacts::RefineParams rp;
      rp.window_vox = o.window_vox;
      rp.gap_tolerance_vox = o.gap_tolerance_vox;
      std::visit([&](const auto& g) {
        fits = contacts::refine_contacts(g, lab.labels, found, lab.grains, rp, ctx.progress_callback("refine normals"));
      }, grey);
      throw_if_interrupted();
      std::map<std::string, std::size_t> status;
      for (const auto& f : fits) ++status[contacts::status_name(f.status)];
      std::string summary;
      for (const auto& [name, n] : status) summary += (summary.empty() ? "" : ", ") + std::to_string(n) + " " + name;
      spdlog::info("refinement: {} (the others keep the PCA normal)", summary);
    }

    // Per-contact columns; the refined normal and point where the fit succeeded.
    std::vector<std::uint32_t> pair(2 * m);
    std::vector<std::uint64_t> voxels(2 * m);
    std::vector<Vec3> normal(m), normal_pca(m), vector_area(m), centroid(m), point(m), branch(m);
    std::vector<double> area(m), confidence(m), gap(m), gap_sd(m), radius(2 * m), blur(m), rms(m);
    std::vector<std::uint8_t> status(m), accepted(m);
    std::vector<contacts::Contact> counted;
    for (std::size_t k = 0; k < m; ++k) {
      const contacts::Contact& c = found[k];
      const contacts::Refinement& f = fits[k];
      pair[2 * k] = c.low, pair[2 * k + 1] = c.high;
      voxels[2 * k] = c.voxels_low, voxels[2 * k + 1] = c.voxels_high;
      normal_pca[k] = c.normal;
      normal[k] = f.ok() ? f.normal : c.normal;
      vector_area[k] = c.vector_area;
      area[k] = c.area;
      centroid[k] = c.centroid;
      point[k] = f.ok() ? f.point : c.centroid;
      branch[k] = c.branch;
      confidence[k] = f.confidence, gap[k] = f.gap, gap_sd[k] = f.gap_sd, blur[k] = f.blur, rms[k] = f.rms;
      radius[2 * k] = f.radius[0], radius[2 * k + 1] = f.radius[1];
      status[k] = refine ? static_cast<std::uint8_t>(f.status) : kNotAttempted;
      accepted[k] = !(f.confidence < o.min_confidence);  // unknown (NaN) counts
      if (accepted[k]) {
        counted.push_back(c);
        counted.back().normal = normal[k];
      }
    }
    if (refine) {
      const contacts::ConfidenceCount cc = contacts::count_confidences(fits, o.min_confidence);
      spdlog::info("{} of {} contacts are counted in Z and the fabric: {} with confidence >= {} and {} not fitted "
                   "(confidence unknown); {} below",
                   counted.size(), m, cc.at_least, o.min_confidence, cc.unknown, cc.below);
      if (m > 0 && cc.unknown == m)
        spdlog::warn("no contact could be fitted to the grey levels of {}: every confidence is unknown (NaN) and every "
                     "normal is the PCA one; check that it is the scan the labels were made from",
                     volume_path.string());
    }
    const contacts::Coordination z = contacts::coordination(lab.grains, counted, o.include_edge_grains);
    std::vector<Vec3> counted_normals, counted_branches;
    for (const auto& c : counted) counted_normals.push_back(c.normal), counted_branches.push_back(c.branch);
    const contacts::Fabric fab_n = contacts::fabric_tensor(counted_normals);
    const contacts::Fabric fab_b = contacts::fabric_tensor(counted_branches);
    spdlog::info("mean coordination number {:.3f} over {} grains; anisotropy a = {:.3f} (normals), {:.3f} (branches)",
                 z.mean, z.counted, fab_n.anisotropy, fab_b.anisotropy);

    {
      io::H5File f = io::H5File::create(out.temp_path());
      io::write_root_attrs(f, schema::kind::contacts);
      const hsize_t mm = m;
      f.write(sc::pair, pair.data(), {mm, 2});
      f.write(sc::normal, rows3(normal).data(), {mm, 3}, units("1"));
      f.write(sc::normal_pca, rows3(normal_pca).data(), {mm, 3}, units("1"));
      f.write(sc::vector_area, rows3(vector_area).data(), {mm, 3}, units("m^2"));
      f.write(sc::area, area, units("m^2"));
      f.write(sc::centroid, rows3(centroid).data(), {mm, 3}, units("m"));
      f.write(sc::point, rows3(point).data(), {mm, 3}, units("m"));
      f.write(sc::branch, rows3(branch).data(), {mm, 3}, units("m"));
      f.write(sc::voxels, voxels.data(), {mm, 2});
      f.write(sc::confidence, confidence, units("1"));
      f.write(sc::gap, gap, units("m"));
      f.write(sc::gap_sd, gap_sd, units("m"));
      f.write(sc::radius, radius.data(), {mm, 2}, units("m"));
      f.write(sc::blur, blur, units("m"));
      f.write(sc::fit_rms, rms, units("1"));
      f.write(sc::fit_status, status);
      f.set_attr(sc::fit_status, "codes",
                 std::string("0 fitted, 1 few_voxels, 2 not_converged, 3 rejected, 4 not attempted (no grey volume)"));
      f.write(sc::accepted, accepted);
      f.set_attr(sc::group, "min_voxels", static_cast<long long>(o.min_voxels));
      f.set_attr(sc::group, "refined", static_cast<long long>(refine));
      f.set_attr(sc::group, "window_vox", o.window_vox);
      f.set_attr(sc::group, "gap_tolerance_vox", o.gap_tolerance_vox);
      f.set_attr(sc::group, "min_confidence", o.min_confidence);

      std::vector<std::uint32_t> grain_label;
      std::vector<std::uint8_t> edge;
      for (const auto& g : lab.grains) grain_label.push_back(g.label), edge.push_back(g.touches_edge);
      f.write(sc::grain_label, grain_label);
      f.write(sc::grain_coordination, z.per_grain);
      f.write(sc::grain_touches_edge, edge);
      std::vector<std::uint32_t> zs(z.histogram.size());
      for (std::size_t i = 0; i < zs.size(); ++i) zs[i] = static_cast<std::uint32_t>(i);
      f.write(sc::coordination_z, zs);
      f.write(sc::coordination_count, z.histogram);
      f.set_attr("/coordination", "mean", z.mean);
      f.set_attr("/coordination", "grains_counted", static_cast<long long>(z.counted));
      f.set_attr("/coordination", "include_edge_grains", static_cast<long long>(o.include_edge_grains));
      write_fabric(f, sc::fabric_normal, fab_n);
      write_fabric(f, sc::fabric_branch, fab_b);
      write_rose(f, sc::rose_normal, contacts::rose(counted_normals, o.theta_bins, o.phi_bins));
      write_rose(f, sc::rose_branch, contacts::rose(counted_branches, o.theta_bins, o.phi_bins));
      io::write_history(f, ctx.history());
    }  // closed before the rename

    if (vtk_out) {
      contacts::ContactNetwork net;
      const auto centroid_of = [&](std::uint32_t label) {
        return std::lower_bound(lab.grains.begin(), lab.grains.end(), label,
                                [](const segment::GrainRecord& g, std::uint32_t l) { return g.label < l; })
            ->centroid_xyz;  // every contact label has a row: find_contacts checked it
      };
      for (std::size_t k = 0; k < m; ++k) {
        net.pairs.push_back({found[k].low, found[k].high});
        net.centroids.push_back({centroid_of(found[k].low), centroid_of(found[k].high)});
      }
      net.points = point;
      net.normals = normal;
      net.values = {{"area", area}, {"confidence", confidence}, {"gap", gap},
                    {"accepted", std::vector<double>(accepted.begin(), accepted.end())}};
      io::write_vtp(vtk_out->temp_path(), contacts::network_polydata(net));
    }
    throw_if_interrupted();
    io::commit_outputs({&out, vtk_out ? &*vtk_out : nullptr});
  });
}
