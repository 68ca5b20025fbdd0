// labels2contacts_bench: (1) the project's speed target: all contacts of a 512^3 label volume with
// about 20 000 grains on one core (and on all cores), and the refinement cost per contact; (2) normal
// accuracy against voxels per diameter on touching spheres (the spam protocol) for the PCA, vector-
// area and refined normals, charted with the anchors' spam figures; (3) false contacts against the
// true gap; (4) whole ctsynth scenes (spheres, the bundled sand_small and sand_angular) through ct2labels against
// their ground truth: normals, touching recall, false contacts, coordination and anisotropy.
//   build/bin/labels2contacts_bench [--quick]
#include <fmt/format.h>
#include <omp.h>

#include <algorithm>
#include <ctime>
#include <cmath>
#include <fstream>
#include <iostream>
#include <map>
#include <numbers>
#include <random>
#include <unordered_map>

#include "graintwin/contacts/detect.hpp"
#include "graintwin/contacts/fabric.hpp"
#include "graintwin/contacts/refine.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/segment/edt.hpp"
#include "graintwin/segment/labels.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "graintwin/segment/markers.hpp"
#include "graintwin/segment/threshold.hpp"
#include "graintwin/segment/watershed.hpp"
#include "graintwin/shape/radial_table.hpp"
#include "graintwin/synth/render.hpp"
#include "harness.hpp"

namespace fs = std::filesystem;
using namespace graintwin;
using namespace graintwin::contacts;
namespace sg = schema::ground_truth;

namespace {
const std::string kSource = GRAINTWIN_SOURCE_DIR;
const std::string kDocs = kSource + "/docs/benchmarks.md";

/// CPU time of the calling thread (s): one-core costs on a shared machine, where wall time also
/// counts the waits for a core.
double thread_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

double angle_deg(const Vec3& a, const Vec3& b) {
  const double d = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) /
                   std::sqrt((a[0] * a[0] + a[1] * a[1] + a[2] * a[2]) * (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]));
  return std::acos(std::min(1.0, std::abs(d))) * 180.0 / std::numbers::pi;
}

double mean(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x;
  return v.empty() ? std::nan("") : s / static_cast<double>(v.size());
}

/// The q-quantile (0..1) by rank.
double quantile(std::vector<double> v, double q) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))];
}

double sd(const std::vector<double>& v) {
  const double m = mean(v);
  double s = 0.0;
  for (double x : v) s += (x - m) * (x - m);
  return v.empty() ? std::nan("") : std::sqrt(s / static_cast<double>(v.size()));
}

/// A 512^3-class label volume: n^3 spheres on a jittered cubic lattice, radius 0.56 of the pitch so
/// that neighbours overlap, each overlap given to the nearer centre (flat interfaces, Z about 6).
Volume<std::uint32_t> lattice_labels(std::size_t side, int n) {
  const double step = static_cast<double>(side) / n, r = 0.56 * step;
  Volume<std::uint32_t> lab({side, side, side}, {27.5e-6, 27.5e-6, 27.5e-6});
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-0.15 * r, 0.15 * r);
  std::vector<std::array<double, 3>> c;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k) c.push_back({step * (i + 0.5) + u(rng), step * (j + 0.5) + u(rng), step * (k + 0.5) + u(rng)});
  const auto d2 = [](const std::array<double, 3>& p, long z, long y, long x) {
    return (z - p[0]) * (z - p[0]) + (y - p[1]) * (y - p[1]) + (x - p[2]) * (x - p[2]);
  };
  const long hi = static_cast<long>(side) - 1;
  for (std::uint32_t g = 0; g < c.size(); ++g) {
    const auto& p = c[g];
    for (long z = std::max(0L, static_cast<long>(p[0] - r)); z <= std::min(hi, static_cast<long>(p[0] + r) + 1); ++z)
      for (long y = std::max(0L, static_cast<long>(p[1] - r)); y <= std::min(hi, static_cast<long>(p[1] + r) + 1); ++y)
        for (long x = std::max(0L, static_cast<long>(p[2] - r)); x <= std::min(hi, static_cast<long>(p[2] + r) + 1); ++x) {
          const double d = d2(p, z, y, x);
          std::uint32_t& l = lab(z, y, x);
          if (d > r * r || (l != 0 && d2(c[l - 1], z, y, x) <= d)) continue;
          l = g + 1;
        }
  }
  return lab;
}

/// Two spheres of `diameter` voxels `gap` voxels apart along a random direction, rendered with
/// ctsynth's analytic partial volumes and scanned by the spam protocol (grey 0.25 / 0.75, blur 0.8
/// voxel, noise 0.03 = 6 % of the contrast), thresholded at 0.5 and split by the marker watershed
/// of the EDT.
struct PairCase {
  Volume<std::uint16_t> grey;
  Volume<std::uint32_t> labels;
  std::vector<segment::GrainRecord> grains;
  Vec3 normal;  // (x, y, z), up to sign
};
PairCase pair_case(double diameter, double gap, std::uint32_t seed) {
  const double h = 1e-5, r = diameter / 2;
  static std::map<double, shape::RadialTable> tables;
  if (!tables.count(r)) tables[r] = shape::RadialTable::from_function([&](const Eigen::Vector3d&) { return r * h; }, 16);
  std::mt19937 rng(seed);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> jitter(-0.5, 0.5);
  Eigen::Vector3d dir(g(rng), g(rng), g(rng));  // (x, y, z)
  dir.normalize();
  const auto n = static_cast<std::size_t>(std::ceil(2 * diameter + gap + 10));
  const Eigen::Vector3d c(n / 2.0 + jitter(rng), n / 2.0 + jitter(rng), n / 2.0 + jitter(rng));
  const synth::PlacedGrain a{&tables[r], (c - dir * (r + gap / 2)) * h, Eigen::Quaterniond::Identity(), 1};
  const synth::PlacedGrain b{&tables[r], (c + dir * (r + gap / 2)) * h, Eigen::Quaterniond::Identity(), 2};
  const auto im = synth::render_grains({a, b}, {n, n, n}, {h, h, h}, {0, 0, 0}, synth::RenderParams{});
  synth::ScannerParams sp;
  sp.grey_void = 0.25, sp.grey_grain = 0.75, sp.blur_sigma_vox = 0.8, sp.noise = 0.06, sp.seed = seed;
  PairCase p;
  p.grey = synth::simulate_scan(im.fraction, nullptr, sp);
  const auto edt = segment::distance_transform(segment::binarise(p.grey, 0.5 * sp.uint16_scale + sp.uint16_offset));
  p.labels = segment::watershed(edt, segment::h_maxima_markers(edt, 1.0));
  p.grains = segment::grain_table(p.labels);
  p.normal = {dir[0], dir[1], dir[2]};
  return p;
}

struct SphereRow {
  double d;
  std::vector<double> pca, area, refined, gaps;
  int cases = 0, merged = 0, accepted = 0;
  double refine_seconds = 0.0;
};

/// Normal errors, detection and acceptance over `n` pairs at one size and gap, on one core.
SphereRow sphere_row(double diameter, double gap, int n) {
  SphereRow row{diameter, {}, {}, {}, {}, 0, 0, 0, 0.0};
  for (int k = 0; k < n; ++k) {
    const PairCase p = pair_case(diameter, gap, 1000 + k);
    ++row.cases;
    const auto cs = find_contacts(p.labels, p.grains);
    if (p.grains.size() != 2 || cs.size() != 1) continue;  // not merged by the threshold, or not split in two
    ++row.merged;
    const double t0 = thread_cpu_seconds();
    const Refinement f = refine_contacts(p.grey, p.labels, cs, p.grains)[0];
    row.refine_seconds += thread_cpu_seconds() - t0;
    row.pca.push_back(angle_deg(cs[0].normal, p.normal));
    row.area.push_back(angle_deg(cs[0].vector_area, p.normal));
    if (f.ok()) {
      row.refined.push_back(angle_deg(f.normal, p.normal));
      row.gaps.push_back(f.gap / 1e-5);
    }
    row.accepted += !(f.confidence < 0.5);
  }
  return row;
}

/// Our contacts against a ctsynth truth file: labels mapped to true grains by majority overlap.
struct SceneResult {
  std::string name;
  std::size_t grains = 0, true_touching = 0, detected = 0, fitted_touching = 0, accepted_touching = 0;
  std::vector<double> pca, refined;  // touching pairs
  std::map<std::string, std::pair<int, int>> by_gap;  // gap bin -> (detected, accepted)
  double z_true = 0.0, z_ours = 0.0, a_true = 0.0, a_ours = 0.0, a_ours_all = 0.0;
};

SceneResult evaluate_scene(const std::string& name, const fs::path& scan, const fs::path& truth_path, const fs::path& labels_path) {
  SceneResult s;
  s.name = name;
  const segment::LabelsFile lab = segment::read_labels_file(labels_path);
  const AnyVolume grey = io::read_volume_file(scan);
  const io::H5File truth = io::open_kind(truth_path, schema::kind::ground_truth);
  const Volume<std::uint32_t> tl = io::read_image_as<std::uint32_t>(truth, schema::path::labels);
  const double vox = tl.voxel_size()[0];
  std::unordered_map<std::uint64_t, std::uint64_t> overlap;
  for (std::size_t i = 0; i < tl.size(); ++i)
    if (lab.labels.values()[i] && tl.values()[i]) ++overlap[std::uint64_t{lab.labels.values()[i]} << 32 | tl.values()[i]];
  std::map<std::uint32_t, std::pair<std::uint32_t, std::uint64_t>> to_true;
  for (const auto& [key, count] : overlap) {
    auto& best = to_true[static_cast<std::uint32_t>(key >> 32)];
    if (count > best.second) best = {static_cast<std::uint32_t>(key & 0xFFFFFFFFu), count};
  }
  const auto pair = truth.read<std::uint32_t>(sg::contact_pair);
  const auto normal = truth.read<double>(sg::contact_normal);
  const auto gap_m = truth.read<double>(sg::contact_overlap);
  const auto touching = truth.read<std::uint8_t>(sg::contact_touching);
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::size_t> true_index;
  std::vector<Vec3> true_normals;
  for (std::size_t k = 0; k < touching.size(); ++k) {
    true_index[{pair[2 * k], pair[2 * k + 1]}] = k;
    if (touching[k]) true_normals.push_back({normal[3 * k], normal[3 * k + 1], normal[3 * k + 2]});
  }
  s.grains = lab.grains.size();
  s.true_touching = true_normals.size();
  s.z_true = 2.0 * static_cast<double>(s.true_touching) / static_cast<double>(truth.read<std::uint32_t>(sg::grain_label).size());
  s.a_true = fabric_tensor(true_normals).anisotropy;

  const auto cs = find_contacts(lab.labels, lab.grains);
  std::vector<Refinement> fits;
  std::visit([&](const auto& g) { fits = refine_contacts(g, lab.labels, cs, lab.grains); }, grey);
  s.detected = cs.size();
  std::vector<Vec3> accepted_normals, all_normals;
  std::size_t accepted = 0;
  for (std::size_t k = 0; k < cs.size(); ++k) {
    const Vec3 n = fits[k].ok() ? fits[k].normal : cs[k].normal;
    all_normals.push_back(n);
    const bool acc = !(fits[k].confidence < 0.5);
    if (acc) accepted_normals.push_back(n), ++accepted;
    const std::uint32_t a = to_true[cs[k].low].first, b = to_true[cs[k].high].first;
    const auto it = true_index.find({std::min(a, b), std::max(a, b)});
    std::string bin = "no true pair within 2 voxels";
    if (it != true_index.end()) {
      const std::size_t t = it->second;
      const double g = -gap_m[t] / vox;
      if (touching[t]) {
        bin = "touching";
        const Vec3 tn{normal[3 * t], normal[3 * t + 1], normal[3 * t + 2]};
        s.pca.push_back(angle_deg(cs[k].normal, tn));
        if (fits[k].ok()) s.refined.push_back(angle_deg(fits[k].normal, tn)), ++s.fitted_touching;
        s.accepted_touching += acc;
      } else {
        bin = g <= 0.35 ? "gap 0-0.35 voxel" : g <= 0.75 ? "gap 0.35-0.75 voxel" : g <= 1.25 ? "gap 0.75-1.25 voxel" : "gap > 1.25 voxel";
      }
    }
    auto& [det, acc_count] = s.by_gap[bin];
    ++det;
    acc_count += acc;
  }
  s.z_ours = 2.0 * static_cast<double>(accepted) / static_cast<double>(lab.grains.size());
  s.a_ours = fabric_tensor(accepted_normals).anisotropy;
  s.a_ours_all = fabric_tensor(all_normals).anisotropy;
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  const bool quick = argc > 1 && std::string(argv[1]) == "--quick";
  const fs::path bin = bench::bin_dir();
  const int cores = omp_get_num_procs();

  // (2) and (3) first: they also give the refinement cost per contact for (1).
  omp_set_num_threads(1);
  const std::vector<double> sizes = quick ? std::vector<double>{8, 20} : std::vector<double>{6, 8, 12, 16, 20, 32};
  const int n_pairs = quick ? 10 : 40;
  std::vector<SphereRow> rows;
  for (double d : sizes) rows.push_back(sphere_row(d, 0.0, n_pairs));
  // The anchors' measurements of spam on the same protocol (docs in shared/references).
  const std::map<double, std::pair<double, double>> spam = {{6, {26.3, 15.4}}, {8, {12.0, 4.6}}, {12, {9.1, 2.8}},
                                                            {16, {6.8, 2.6}}, {20, {4.5, 1.9}}, {32, {3.1, 0.9}}};
  bench::Report acc("labels2contacts_normals", "labels2contacts: contact normals of touching spheres",
                    fmt::format("Two touching spheres along a random direction, random sub-voxel centre, rendered with "
                                "exact partial volumes (ctsynth's analytic method) and scanned by the spam protocol "
                                "(grey 0.25 / 0.75, Gaussian blur 0.8 voxel, noise 0.03 = 6 % of the contrast), thresholded at 0.5 and split by the "
                                "EDT h-maxima watershed; {} pairs per size, one core. Mean angular error (p90 in the "
                                "note) of the PCA normal (midpoints of the contact-voxel pairs), the vector-area "
                                "normal and the refined normal; the time column is the refinement per contact. "
                                "Targets: refined mean <= 4 degrees at 8 and <= 1.5 at 20 voxels per "
                                "diameter, <= 5 ms per contact. spam rows: the anchors' measurement of spam's ITK "
                                "(watershed + PCA) and RW (random walker + PCA) modes.\n\n"
                                "![normal error against voxels per diameter](img/labels2contacts_normals.png)",
                                n_pairs));
  std::ofstream csv(kSource + "/docs/img/labels2contacts_normals.csv");
  csv << "series,label,x,y\n";
  for (const SphereRow& r : rows) {
    const std::string c = fmt::format("d = {} voxels ({} of {} pairs split)", r.d, r.merged, r.cases);
    const double per_contact = r.refine_seconds / std::max(1, r.merged);
    acc.add({c, "PCA, pair midpoints", 0, 0, fmt::format("mean {:.2f} deg, p90 {:.2f}", mean(r.pca), quantile(r.pca, 0.9))});
    acc.add({c, "vector area", 0, 0, fmt::format("mean {:.2f} deg, p90 {:.2f}", mean(r.area), quantile(r.area, 0.9))});
    acc.add({c, "refined", per_contact, 0,
             fmt::format("mean {:.2f} deg, p90 {:.2f}; {} fitted; gap {:.3f} +- {:.3f} voxel", mean(r.refined),
                         quantile(r.refined, 0.9), r.refined.size(), mean(r.gaps), sd(r.gaps))});
    if (spam.count(r.d))
      acc.add({c, "spam ITK / RW (anchors)", 0, 0, fmt::format("mean {} / {} deg", spam.at(r.d).first, spam.at(r.d).second)});
    csv << "PCA (pair midpoints),," << r.d << "," << mean(r.pca) << "\n"
        << "vector area,," << r.d << "," << mean(r.area) << "\n"
        << "refined,," << r.d << "," << mean(r.refined) << "\n";
    if (spam.count(r.d))
      csv << "spam ITK (anchors),," << r.d << "," << spam.at(r.d).first << "\nspam RW (anchors),," << r.d << ","
          << spam.at(r.d).second << "\n";
  }
  csv.close();
  acc.publish("none", kDocs);
  bench::plot_xy(kSource + "/docs/img/labels2contacts_normals.csv", kSource + "/docs/img/labels2contacts_normals.png",
                 "labels2contacts: touching spheres", "voxels per diameter", "mean normal error (degrees)");

  bench::Report gaps("labels2contacts_gaps", "labels2contacts: false contacts against the true gap",
                     fmt::format("Two spheres a given gap apart (same protocol, {} pairs per row). Merged: the global "
                                 "threshold joins them and the watershed makes one contact of them. Accepted: merged "
                                 "and confidence >= 0.5 (fitted gap below the 0.5-voxel tolerance). For gaps > 0 the "
                                 "accepted fraction is the false-contact rate after the confidence, the merged "
                                 "fraction the rate without it.",
                                 n_pairs));
  for (double d : {8.0, 16.0})
    for (double gap : {0.0, 0.25, 0.5, 1.0, 1.5, 2.0}) {
      const SphereRow r = sphere_row(d, gap, n_pairs);
      gaps.add({fmt::format("d = {}, gap {} voxel", d, gap), "labels2contacts", 0, 0,
                fmt::format("merged {:.0f} %, accepted {:.0f} %, fitted gap {:.2f} voxel",
                            100.0 * r.merged / r.cases, 100.0 * r.accepted / r.cases, mean(r.gaps))});
    }
  gaps.publish("none", kDocs);

  // (1) Speed on a 512^3 label volume.
  const std::size_t side = quick ? 256 : 512;
  const int per_axis = quick ? 13 : 27;
  const Volume<std::uint32_t> lab = lattice_labels(side, per_axis);
  const auto grains = segment::grain_table(lab);
  std::vector<Contact> found;
  omp_set_num_threads(1);
  double t1 = 1e30;
  for (int rep = 0; rep < (quick ? 1 : 2); ++rep) {
    const double t0 = thread_cpu_seconds();
    found = find_contacts(lab, grains);
    t1 = std::min(t1, thread_cpu_seconds() - t0);
  }
  omp_set_num_threads(cores);
  const double tn = bench::best_seconds(quick ? 1 : 2, [&] { found = find_contacts(lab, grains); });
  const std::string label = fmt::format("{}^3, {} grains, {} contacts", side, grains.size(), found.size());
  bench::Report speed("labels2contacts_speed", "labels2contacts: speed",
                      "All contacts (detection, PCA normals, areas, branch vectors) of a label volume of spheres "
                      "on a jittered cubic lattice, neighbours overlapping and split at the bisecting plane. Target"
                      ": 512^3 with about 20 000 grains in under 5 s on one core. Refinement rows: the "
                      "grey-level fit per contact at 8 and 20 voxels per diameter (one core), target <= 5 ms. "
                      "One-core rows are CPU times of the thread (the machine is shared; wall time there also "
                      "counts waits for a core), the all-core row is wall time.");
  speed.add({label, "find_contacts, 1 core", t1, 0, "the target: < 5 s"});
  speed.add({label, fmt::format("find_contacts, {} cores", cores), tn, 0, ""});
  for (const SphereRow& r : rows)
    if (r.d == 8 || r.d == 20)
      speed.add({fmt::format("two spheres, d = {} voxels", r.d), "refine_contact, 1 core",
                 r.refine_seconds / std::max(1, r.merged), 0, "per contact; the target: < 0.005 s"});
  speed.publish("find_contacts, 1 core", kDocs);

  // (4) ctsynth scenes through ct2labels, against their truth.
  const fs::path tmp = fs::temp_directory_path() / fmt::format("labels2contacts_bench_{}", ::getpid());
  fs::create_directories(tmp);
  std::ofstream(tmp / "spheres.toml") << "seed = 7\ngrain-shape = \"sphere\"\nsh-degree = 4\nd-min = \"0.45mm\"\n"
                                         "d50 = \"0.551mm\"\nd-max = \"0.65mm\"\npsd-sigma = 0.1\ncontainer = \"box\"\n"
                                         "box = \"2.2mm,2.2mm,2.2mm\"\nsolid-fraction = 0.50\ncontact-tolerance = 0.02\n"
                                         "voxel-size = \"27.5um\"\nmargin-vox = 2\nmembrane-thickness = \"0mm\"\n"
                                         "supersample = 4\nblur = 0.8\nnoise = 0.06\nstrains = [0.0]\n";
  bench::run_child("spheres", "ctsynth", {(bin / "ctsynth").string(), (tmp / "spheres.toml").string(), (tmp / "spheres").string(), "-q"});
  omp_set_num_threads(cores);
  std::vector<SceneResult> scenes;
  const fs::path sand = kSource + "/sample_volumes/sand_small", angular = kSource + "/sample_volumes/sand_angular";
  for (const auto& [name, dir] : std::vector<std::pair<std::string, fs::path>>{{"67 spheres (0.45-0.65 mm)", tmp / "spheres"},
                                                                                {"sand_small (210 sand grains)", sand},
                                                                                {"sand_angular (190 angular grains)", angular}}) {
    const fs::path labels = tmp / (dir.filename().string() + "_labels.h5");
    bench::run_child(name, "ct2labels", {(bin / "ct2labels").string(), (dir / "scan_000.h5").string(), labels.string(), "-q", "-f"});
    scenes.push_back(evaluate_scene(name, dir / "scan_000.h5", dir / "truth_000.h5", labels));
  }
  fs::remove_all(tmp);
  bench::Report scene("labels2contacts_scenes", "labels2contacts: ctsynth scenes against ground truth",
                      "scan_000 of a ctsynth scene (27.5 um voxels, about 20 voxels per d50, blur 0.8 voxel, noise "
                      "5-6 % of the contrast) segmented by ct2labels with its defaults; labels mapped to the true "
                      "grains by largest overlap; touching = true |overlap| within the scene's contact tolerance. "
                      "Normal errors over the truly touching pairs (refined: the fitted ones). Rows by true gap: "
                      "detected pairs and how many the confidence accepts (>= 0.5). Z = 2 contacts / grains; a from "
                      "the normals of the accepted contacts against the truly touching ones.");
  for (const SceneResult& s : scenes) {
    scene.add({s.name, "normals of touching pairs", 0, 0,
               fmt::format("PCA mean {:.1f} deg; refined mean {:.1f} deg, median {:.1f} ({} of {} detected touching pairs "
                           "fitted)", mean(s.pca), mean(s.refined), quantile(s.refined, 0.5), s.fitted_touching, s.pca.size())});
    for (const auto& [bin, counts] : s.by_gap)
      scene.add({s.name, bin, 0, 0, fmt::format("{} detected, {} accepted", counts.first, counts.second)});
    scene.add({s.name, "network", 0, 0,
               fmt::format("true touching {}, detected {}; Z true {:.2f}, accepted {:.2f}; a true {:.3f}, accepted "
                           "{:.3f}, all detected {:.3f}", s.true_touching, s.detected, s.z_true, s.z_ours, s.a_true,
                           s.a_ours, s.a_ours_all)});
  }
  scene.publish("none", kDocs);
  return 0;
}
