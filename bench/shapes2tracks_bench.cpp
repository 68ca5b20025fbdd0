// shapes2tracks_bench: the matcher at paper scale.
// (1) Accuracy: a ctsynth series of about 2 400 sand grains at axial strains 0, 1, 2, 5 and 10 %
//     with a shear band; scan 0 is matched to each later scan (strain steps of 1, 2, 5 and 10 %)
//     by the improved default, the paper's Algorithm 1, nearest centroid and volume-only matching,
//     on shapes measured (labels2shapes, grey surfaces) from (a) ct2labels' segmentation and (b) the
//     true labels with 1 % of the deformed scans' grains deliberately merged in pairs or split in
//     two. Identities by ct2labels_accuracy_bench's scoring (IoU >= 0.8, validate/label_match.hpp):
//     correct / wrong / lost among the grains faithful in both scans (the targets), and the
//     segmentation-damaged grains apart (lost is right for them).
//     Also rotations of the matched grains against the truth, and the improved mode's lost cost.
// (2) Damaged segmentation: synthetic scans (track/synthetic.hpp) in which 0-40 % of the second
//     scan's grains are merged with a neighbour or cut in two; right / wrong / lost among the
//     intact grains and what became of the damaged ones, for improved, paper and nearest.
// (3) Speed: 16 000 synthetic grains (track/synthetic.hpp) matched on one core.
//   build/bin/shapes2tracks_bench [--quick] [--work DIR]
// --quick: a smaller sample, prints only. The series and derived files are kept in the work
// folder (default bench/out/shapes2tracks) and reused by later runs.
#include <fmt/format.h>
#include <omp.h>

#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <numbers>
#include <random>
#include <set>
#include <unordered_map>

#include "graintwin/io/h5file.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/segment/labels.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "graintwin/shape/shapes_file.hpp"
#include "graintwin/track/match.hpp"
#include "graintwin/track/rotation.hpp"
#include "graintwin/track/synthetic.hpp"
#include "graintwin/validate/label_match.hpp"
#include "harness.hpp"

namespace fs = std::filesystem;
using namespace graintwin;
using namespace graintwin::track;

namespace {

const std::string kSource = GRAINTWIN_SOURCE_DIR;
const std::vector<double> kStrains = {0.0, 0.01, 0.02, 0.05, 0.10};
const std::vector<Method> kMethods = {Method::improved, Method::paper, Method::nearest, Method::volume};

void run_or_die(const std::string& cmd) {
  std::cout << "+ " << cmd << std::endl;
  if (std::system(cmd.c_str()) != 0) throw std::runtime_error("failed: " + cmd);
}

std::string scan_name(const char* stem, std::size_t k) { return fmt::format("{}_{:03d}.h5", stem, k); }

double thread_seconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

double load_average() {
  std::ifstream in("/proc/loadavg");
  double l = 0.0;
  in >> l;
  return l;
}

/// The series: the bundled scene made larger (about 2 400 grains; --quick: about 600) with a
/// shear band 4 d50 wide, at 15.7 voxels per d50, in prescribed kinematics (the bundled series'
/// own loading is a simulated test).
void make_series(const fs::path& dir, bool quick) {
  if (fs::exists(dir / scan_name("truth", kStrains.size() - 1))) return;
  std::string strains;
  for (double s : kStrains) strains += fmt::format("{}{}", strains.empty() ? "" : ",", s);
  run_or_die(fmt::format("{}/ctsynth {}/pipelines/scenes/sand_small.toml {} --diameter {} --height {} --voxel-size 35um "
                         "--band-width 2.2mm --strains {} --seed 7 --loading prescribed --triaxial-scene \"\" --force -q",
                         bench::bin_dir().string(), kSource, dir.string(), quick ? "4mm" : "7mm", quick ? "5mm" : "8mm", strains));
}

void labels2shapes(const fs::path& labels, const fs::path& scan, const fs::path& out) {
  if (fs::exists(out)) return;
  run_or_die(fmt::format("{}/labels2shapes {} {} {} --config {}/pipelines/params/labels2shapes.toml -q", bench::bin_dir().string(),
                         labels.string(), scan.string(), out.string(), kSource));
}

Volume<std::uint32_t> read_labels_image(const fs::path& p) {
  return io::read_image_as<std::uint32_t>(io::H5File::open(p), schema::path::labels);
}

/// What every row of a shapes file is, by the scoring of ct2labels_accuracy_bench
/// (validate/label_match.hpp): the true grain (index = true label - 1) it reproduces faithfully
/// (IoU >= 0.8), else -1; and its home grain (the true grain holding most of its voxels), -1 for
/// the background.
struct Identity {
  std::vector<long> faithful, home;
};
Identity identify(const Volume<std::uint32_t>& labels, const Volume<std::uint32_t>& truth, const shape::ShapesFile& shapes) {
  const validate::MatchResult r = validate::match_labels(truth, labels);
  const std::vector<std::uint32_t> faithful = r.faithful_grain();
  Identity id;
  for (const auto& g : shapes.grains) {
    const bool known = g.label < faithful.size();
    id.faithful.push_back(known ? long(faithful[g.label]) - 1 : -1);
    id.home.push_back(known ? long(r.home_grain[g.label]) - 1 : -1);
  }
  return id;
}

/// A true label image with touching pairs merged and grains split (fraction / 2 of the grains
/// damaged by each: fraction / 4 pairs merged, fraction / 2 grains split), labels renumbered 1..M.
Volume<std::uint32_t> damage(const Volume<std::uint32_t>& truth, double fraction, std::uint64_t seed) {
  const auto [nz, ny, nx] = truth.shape();
  std::uint32_t n = 0;
  for (std::uint32_t v : truth.values()) n = std::max(n, v);
  // Touching pairs from face neighbours.
  std::set<std::pair<std::uint32_t, std::uint32_t>> pairs;
  for (std::size_t z = 0; z < nz; ++z)
    for (std::size_t y = 0; y < ny; ++y)
      for (std::size_t x = 0; x < nx; ++x) {
        const std::uint32_t a = truth(z, y, x);
        if (!a) continue;
        for (const auto& [dz, dy, dx] : {std::array<std::size_t, 3>{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}) {
          if (z + dz >= nz || y + dy >= ny || x + dx >= nx) continue;
          const std::uint32_t b = truth(z + dz, y + dy, x + dx);
          if (b && b != a) pairs.insert({std::min(a, b), std::max(a, b)});
        }
      }
  std::mt19937_64 rng(seed);
  std::vector<std::pair<std::uint32_t, std::uint32_t>> order(pairs.begin(), pairs.end());
  std::shuffle(order.begin(), order.end(), rng);
  const std::size_t each = std::max<std::size_t>(1, std::size_t(std::lround(fraction / 2.0 * n)));
  std::vector<std::uint32_t> map(n + 1);
  for (std::uint32_t l = 0; l <= n; ++l) map[l] = l;
  std::set<std::uint32_t> used;
  for (const auto& [a, b] : order) {
    if (used.size() + 1 >= each) break;
    if (used.count(a) || used.count(b)) continue;
    used.insert(a), used.insert(b);
    map[b] = a;
  }
  // Splits: grains not merged, cut by the horizontal plane through their centroid.
  std::vector<std::uint32_t> candidates;
  for (std::uint32_t l = 1; l <= n; ++l)
    if (!used.count(l)) candidates.push_back(l);
  std::shuffle(candidates.begin(), candidates.end(), rng);
  std::map<std::uint32_t, double> split_z;  // label -> mean z index
  for (std::size_t k = 0; k < each && k < candidates.size(); ++k) split_z[candidates[k]] = 0.0;
  std::map<std::uint32_t, std::size_t> count;
  for (std::size_t z = 0; z < nz; ++z)
    for (std::size_t y = 0; y < ny; ++y)
      for (std::size_t x = 0; x < nx; ++x) {
        const auto it = split_z.find(truth(z, y, x));
        if (it != split_z.end()) it->second += double(z), ++count[it->first];
      }
  for (auto& [l, z] : split_z) z /= double(count[l]);
  // New image: merged labels mapped, the upper halves of split grains get labels n + 1, ...
  Volume<std::uint32_t> labels(truth.shape(), truth.voxel_size(), truth.origin());
  std::map<std::uint32_t, std::uint32_t> upper;
  for (const auto& [l, z] : split_z) upper[l] = n + 1 + std::uint32_t(upper.size());
  for (std::size_t z = 0; z < nz; ++z)
    for (std::size_t y = 0; y < ny; ++y)
      for (std::size_t x = 0; x < nx; ++x) {
        const std::uint32_t l = truth(z, y, x);
        const auto it = split_z.find(l);
        labels(z, y, x) = it != split_z.end() && double(z) > it->second ? upper[l] : map[l];
      }
  // Renumber 1..M in order of the old labels.
  std::vector<std::uint32_t> present(n + upper.size() + 1, 0);
  for (std::uint32_t v : labels.values()) present[v] = 1;
  std::vector<std::uint32_t> renumber(present.size(), 0);
  std::uint32_t next = 0;
  for (std::uint32_t l = 1; l < present.size(); ++l)
    if (present[l]) renumber[l] = ++next;
  for (auto& v : labels.values()) v = renumber[v];
  return labels;
}

void write_labels(const fs::path& out, const Volume<std::uint32_t>& labels, const std::string& what) {
  segment::LabelsFile f;
  f.labels = labels;
  f.grains = segment::grain_table(f.labels);
  f.parameters_json = "{}";
  segment::write_labels_file(out, f, {what});
}

/// One condition: shapes of every scan with the identity of each row.
struct Condition {
  std::string name;
  std::vector<shape::ShapesFile> shapes;
  std::vector<ScanGrains> scans;
  std::vector<Identity> identity;
};

/// One matching scored against the truth. A reference grain is *faithful* when it and its partner
/// in the other scan both reproduce the same true grain with IoU >= 0.8; the others are
/// *segmentation-damaged* (merged, split or reshaped in either scan), and for them being lost is
/// right. A match to a label whose home is the reference grain's own home grain (e.g. the larger
/// half of a split grain) is counted as "own grain", not wrong.
struct Outcome {
  struct Counts {
    std::size_t grains = 0, correct = 0, own_grain = 0, wrong = 0, lost = 0;
    double pct(std::size_t x) const { return grains ? 100.0 * double(x) / double(grains) : 0.0; }
  };
  Counts faithful, damaged;
  std::size_t lost_volume_changed = 0;                             // faithful lost, volume changed by > 10 %
  std::vector<std::pair<std::size_t, std::size_t>> correct_pairs;  // (ref row, def row)
  std::vector<std::size_t> faithful_failed;                        // ref rows: faithful, lost or wrong
  /// Every reference grain: tracked = correct or own grain.
  Counts all() const {
    return {faithful.grains + damaged.grains, faithful.correct + damaged.own_grain, 0, faithful.wrong + damaged.wrong,
            faithful.lost + damaged.lost};
  }
};

Outcome evaluate(const Identity& ref, const Identity& def, const Matching& m, const ScanGrains& a, const ScanGrains& b) {
  std::unordered_map<long, std::size_t> faithful_row;
  for (std::size_t j = 0; j < def.faithful.size(); ++j)
    if (def.faithful[j] >= 0) faithful_row[def.faithful[j]] = j;
  Outcome o;
  for (std::size_t i = 0; i < ref.faithful.size(); ++i) {
    const auto it = ref.faithful[i] >= 0 ? faithful_row.find(ref.faithful[i]) : faithful_row.end();
    const bool faithful = it != faithful_row.end();
    Outcome::Counts& c = faithful ? o.faithful : o.damaged;
    ++c.grains;
    const int j = m.partner[i];
    if (j < 0) {
      ++c.lost;
      if (faithful) {
        o.lost_volume_changed += std::abs(b.volume[it->second] - a.volume[i]) > 0.1 * a.volume[i];
        o.faithful_failed.push_back(i);
      }
    } else if (faithful && std::size_t(j) == it->second) {
      ++c.correct;
      o.correct_pairs.push_back({i, it->second});
    } else if (!faithful && ref.home[i] >= 0 && def.home[std::size_t(j)] == ref.home[i]) {
      ++c.own_grain;
    } else {
      ++c.wrong;
      if (faithful) o.faithful_failed.push_back(i);
    }
  }
  return o;
}

std::vector<Eigen::Quaterniond> read_orientations(const fs::path& truth) {
  const auto q = io::H5File::open(truth).read<double>(schema::ground_truth::grain_orientation);
  std::vector<Eigen::Quaterniond> out;
  for (std::size_t i = 0; i + 3 < q.size(); i += 4) out.emplace_back(q[i], q[i + 1], q[i + 2], q[i + 3]);
  return out;
}

/// Why faithful grains failed: one line each (position, prediction error, volume and shape change
/// of the true pair, also in units of the matcher's global spreads, the grain taken instead,
/// segmentation-damaged grains next to the true partner).
void print_failures(const Outcome& o, const Condition& c, std::size_t k, const Matching& m) {
  const ScanGrains &a = c.scans[0], &b = c.scans[k];
  const Identity &ia = c.identity[0], &ib = c.identity[k];
  std::unordered_map<long, std::size_t> row_b;
  for (std::size_t j = 0; j < b.size(); ++j)
    if (ib.faithful[j] >= 0) row_b[ib.faithful[j]] = j;
  for (std::size_t i : o.faithful_failed) {
    const std::size_t j = row_b.at(ia.faithful[i]);
    std::size_t damaged_near = 0;
    for (std::size_t q = 0; q < b.size(); ++q)
      damaged_near += ib.faithful[q] < 0 && (b.centroid[q] - b.centroid[j]).norm() < 1.5 * a.d50;
    const int got = m.partner[i];
    std::cout << fmt::format("  failed: grain {} at ({:.2f}, {:.2f}, {:.2f}) d50, moved {:.2f} d50, prediction off by "
                             "{:.2f} d50 ({:.1f} spreads); volume ratio {:.3f} ({:.1f} spreads), shape D/R0 {:.3f} ({:.1f} "
                             "spreads); {}; {} damaged grains within 1.5 d50",
                             ia.faithful[i], a.centroid[i].x() / a.d50, a.centroid[i].y() / a.d50, a.centroid[i].z() / a.d50,
                             (b.centroid[j] - a.centroid[i]).norm() / a.d50, (b.centroid[j] - m.predicted[i]).norm() / a.d50,
                             (b.centroid[j] - m.predicted[i]).norm() / m.diagnostics.sigma_position, b.volume[j] / a.volume[i],
                             std::abs(std::log(b.volume[j] / a.volume[i])) / m.diagnostics.sigma_volume,
                             invariant_distance(a, i, b, j) / a.invariants(Eigen::Index(i), 0),
                             invariant_distance(a, i, b, j) / a.invariants(Eigen::Index(i), 0) / m.diagnostics.sigma_shape,
                             got < 0 ? std::string("lost")
                                     : fmt::format("took grain {} (home {}) {:.2f} d50 from the prediction", ib.faithful[std::size_t(got)],
                                                   ib.home[std::size_t(got)],
                                                   (b.centroid[std::size_t(got)] - m.predicted[i]).norm() / a.d50),
                             damaged_near)
              << std::endl;
  }
}

std::string outcome_note(const Outcome& o) {
  const Outcome::Counts &f = o.faithful, &d = o.damaged, all = o.all();
  return fmt::format("faithful: correct {:.2f} %, wrong {:.2f} %, lost {:.2f} % of {} ({} of the lost changed volume by "
                     "> 10 %); damaged: {} lost, {} own grain, {} wrong of {}; all grains: {:.2f} % tracked, {} wrong",
                     f.pct(f.correct), f.pct(f.wrong), f.pct(f.lost), f.grains, o.lost_volume_changed, d.lost, d.own_grain,
                     d.wrong, d.grains, all.pct(all.correct), all.wrong);
}

/// The matchers on synthetic scans whose second scan's segmentation damaged a share of the grains
/// (half of them merged in touching pairs, half cut in two): the independent stress test's case
/// (200 grains, a 5 % step, non-affine motion 0.15 d50 per component, shapes and volumes measured
/// to 3 %; five pairs of scans per row) and a larger one with a shear band (2 000 grains, a 10 %
/// step, slip 0.8 d50).
bench::Report damaged_segmentation(bool quick) {
  bench::Report r(
      "shapes2tracks_damaged", "shapes2tracks: matching when the segmentation damaged many grains",
      "Synthetic grain tables (`track/synthetic.hpp`): the second scan's segmentation merges half of the damaged "
      "grains with a touching neighbour (one label: volume the sum, centroid the volume-weighted mean, invariants of "
      "the joined bodies) and cuts the other half in two (two labels: the pieces' volumes, centroids and invariants). "
      "Non-affine motion 0.15 d50 per component, shape and volume measured to 3 %. **intact**: grains with one label "
      "in each scan; right / wrong / lost are shares of them. **damaged**: merged or cut grains, for which lost is "
      "right; 'own' = matched to a label holding part of them, 'wrong' = to other grains' labels, of which 'stolen' "
      "= an intact grain's label. Time: all the matchings of the row, wall, with the backward check.");
  struct Case {
    std::string name;
    std::size_t grains;
    int pairs;
    double strain, slip;
  };
  std::vector<Case> cases{{"200 grains, 5 % step", 200, 5, 0.05, 0.0}};
  if (!quick) cases.push_back({"2 000 grains, 10 % step, shear band", 2000, 1, 0.10, 0.8});
  for (const Case& c : cases)
    for (double damaged : {0.0, 0.1, 0.2, 0.4})
      for (Method me : {Method::improved, Method::paper, Method::nearest}) {
        SyntheticScore t;
        double seconds = 0.0;
        for (int k = 1; k <= c.pairs; ++k) {
          const ScanGrains a = synthetic_grains(c.grains, 0.44e-3, 15, std::uint64_t(k));
          SyntheticMotion mo;
          mo.axial_strain = c.strain, mo.band_slip_d50 = c.slip, mo.noise_d50 = 0.15;
          mo.shape_noise = 0.03, mo.volume_noise = 0.03;
          mo.merged = mo.cut = damaged / 2.0;
          mo.seed = 100 + std::uint64_t(k);
          const DeformedScan b = deform_scan(a, mo);
          MatchOptions o;
          o.method = me;
          Matching m;
          seconds += bench::best_seconds(1, [&] { m = match_grains(a, b.grains, o); });
          const SyntheticScore s = score_matching(b, m);
          t.intact += s.intact, t.right += s.right, t.wrong += s.wrong, t.lost += s.lost;
          t.damaged += s.damaged, t.damaged_lost += s.damaged_lost, t.damaged_own += s.damaged_own;
          t.damaged_wrong += s.damaged_wrong, t.stolen += s.stolen;
        }
        const auto pct = [](std::size_t x, std::size_t of) { return of ? 100.0 * double(x) / double(of) : 0.0; };
        const std::string note = fmt::format(
            "intact: right {:.2f} %, wrong {:.2f} %, lost {:.2f} % of {}; damaged: {} lost, {} own, {} wrong ({} stolen) of {}",
            pct(t.right, t.intact), pct(t.wrong, t.intact), pct(t.lost, t.intact), t.intact, t.damaged_lost, t.damaged_own,
            t.damaged_wrong, t.stolen, t.damaged);
        const std::string name = fmt::format("{}, {:g} % damaged", c.name, 100 * damaged);
        r.add({name, method_name(me), seconds, 0.0, note});
        std::cout << name << " " << method_name(me) << ": " << note << std::endl;
      }
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false;
  fs::path work = kSource + "/bench/out/shapes2tracks";
  if (!bench::parse_quick_work(argc, argv, quick, work)) {
    std::cerr << "usage: shapes2tracks_bench [--quick] [--work DIR]\n";
    return 2;
  }
  if (quick) work /= "quick";
  const bench::Report damaged = damaged_segmentation(quick);
  const fs::path series = work / "series";
  fs::create_directories(work);
  make_series(series, quick);
  const std::size_t n_scans = kStrains.size();

  // Shapes of every scan for both conditions (kept between runs).
  Condition seg{"ct2labels", {}, {}, {}}, dmg{"true labels, 1 % damaged", {}, {}, {}};
  std::vector<std::vector<Eigen::Quaterniond>> orientation;
  for (std::size_t k = 0; k < n_scans; ++k) {
    const fs::path scan = series / scan_name("scan", k), truth = series / scan_name("truth", k);
    const fs::path seg_labels = work / scan_name("seg_labels", k), seg_shapes = work / scan_name("seg_shapes", k);
    if (!fs::exists(seg_labels))
      run_or_die(fmt::format("{}/ct2labels {} {} --config {}/pipelines/params/ct2labels.toml -q", bench::bin_dir().string(),
                             scan.string(), seg_labels.string(), kSource));
    labels2shapes(seg_labels, scan, seg_shapes);
    const Volume<std::uint32_t> truth_labels = read_labels_image(truth);
    seg.shapes.push_back(shape::read_shapes_file(seg_shapes));
    seg.identity.push_back(identify(read_labels_image(seg_labels), truth_labels, seg.shapes.back()));
    // The reference scan keeps its true labels intact; later scans lose 1 % of their grains to
    // merges and splits.
    const fs::path dmg_labels = work / scan_name("damaged_labels", k), dmg_shapes = work / scan_name("damaged_shapes", k);
    if (!fs::exists(dmg_labels))
      write_labels(dmg_labels, k ? damage(truth_labels, 0.01, 100 + k) : truth_labels,
                   k ? "true labels, 1 % merged or split" : "true labels");
    labels2shapes(dmg_labels, scan, dmg_shapes);
    dmg.shapes.push_back(shape::read_shapes_file(dmg_shapes));
    dmg.identity.push_back(identify(read_labels_image(dmg_labels), truth_labels, dmg.shapes.back()));
    orientation.push_back(read_orientations(truth));
  }
  for (Condition* c : {&seg, &dmg})
    for (const auto& s : c->shapes) c->scans.push_back(scan_grains(s));

  const std::size_t grains = orientation[0].size(), labels = seg.scans[0].size();
  std::size_t faithful = 0;
  for (long t : seg.identity[0].faithful) faithful += t >= 0;
  bench::Report acc(
      "shapes2tracks_accuracy", "shapes2tracks: matching accuracy against the strain step",
      fmt::format(
          "ctsynth series (`pipelines/scenes/sand_small.toml` with `--diameter 7mm --height 8mm --voxel-size 35um "
          "--band-width 2.2mm --seed 7 --loading prescribed`: {} Ottawa-like sand grains, 15.7 voxels per d50, a shear band 4 d50 wide with "
          "slip 0.5 H0 per unit strain, nonaffine motion and grain rotations in it) at axial strains 0, 1, 2, 5 and 10 %; "
          "scan 0 matched to each later scan, so the steps are 1, 2, 5 and 10 %. Shapes: `labels2shapes` with grey "
          "surfaces. **ct2labels**: labels from `ct2labels`. A label reproduces a true grain *faithfully* when "
          "their IoU is at least 0.8 (the criterion of `ct2labels_accuracy`, same code; {} of {} labels of scan 0). "
          "**faithful**: reference grains faithful in both scans; correct / wrong / lost are shares of them (the "
          "targets). **damaged**: the other reference grains (merged, split or reshaped by the segmentation in either "
          "scan), for which lost is right; 'own grain' = matched to a label that is mostly the same true grain (e.g. the "
          "larger half of a split grain), 'wrong' = matched to another grain. **all grains**: every reference grain, "
          "tracked = correct or own grain. **true labels, 1 % damaged**: the exact labels, with 1 % of the grains of each "
          "later scan merged with a touching neighbour (0.5 %) or split in two (0.5 %) on purpose, scored the same way. Methods: `improved` (the default: prediction, combined cost, global assignment, lost cost 144, no volume "
          "filter; the rows 'improved, lost cost ..., volume filter ...' vary those two at the 1 and 10 % steps), "
          "`paper` (Algorithm 1: 3 d50, 10 %, invariant distance, conflicts by smallest score), `nearest` (same resolution, "
          "centroid distance, no volume filter), `volume` (same, relative volume change, 10 % filter); all with the "
          "backward check. Time: the matching of one step, wall, {} thread(s). Grains draw their own SH spectra "
          "(`shape/sand_shape.hpp`), yet within 3 d50 a grain has 10-20 neighbours of similar volume and invariants, "
          "which is where `paper` goes wrong.\n\n"
          "![faithful grains not matched correctly against the strain step, with the targets](img/shapes2tracks_accuracy.png)",
          grains, faithful, labels, omp_get_max_threads()));
  std::ofstream csv(work / "accuracy.csv");
  csv << "series,label,x,y\n";
  for (Condition* c : {&seg, &dmg})
    for (std::size_t k = 1; k < n_scans; ++k) {
      const std::string name = fmt::format("{:g} % step, {}", 100 * kStrains[k], c->name);
      for (Method me : kMethods) {
        MatchOptions o;
        o.method = me;
        Matching m;
        const double t = bench::best_seconds(1, [&] { m = match_grains(c->scans[0], c->scans[k], o); });
        const Outcome out = evaluate(c->identity[0], c->identity[k], m, c->scans[0], c->scans[k]);
        acc.add({name, method_name(me), t, 0.0, outcome_note(out)});
        std::cout << name << " " << method_name(me) << ": " << outcome_note(out) << std::endl;
        if (me == Method::improved) print_failures(out, *c, k, m);
        if (c == &seg || me == Method::improved || me == Method::paper)  // the chart: every method on ct2labels' labels
          csv << method_name(me) << (c == &seg ? " (ct2labels)" : " (true labels)") << ","
              << fmt::format("{:g} %", 100 * kStrains[k]) << "," << 100 * kStrains[k] << ","
              << std::max(100.0 - out.faithful.pct(out.faithful.correct), 0.01) << "\n";
      }
    }
  // The improved mode's lost cost and volume filter at the smallest and the largest step: a higher
  // lost cost keeps more doubtful matches, a wider filter admits grains whose segmentation changed.
  for (std::size_t k : {std::size_t(1), n_scans - 1})
    for (const auto& [lost, tol] : std::vector<std::pair<double, double>>{
             {25.0, -1.0}, {64.0, -1.0}, {144.0, -1.0}, {256.0, -1.0}, {576.0, -1.0}, {144.0, 0.1}, {144.0, 0.2}, {144.0, 0.3}})
      for (Condition* c : {&seg, &dmg}) {
        MatchOptions o;
        o.lost_cost = lost;
        o.volume_tol = tol;
        Matching m;
        const double t = bench::best_seconds(1, [&] { m = match_grains(c->scans[0], c->scans[k], o); });
        const Outcome out = evaluate(c->identity[0], c->identity[k], m, c->scans[0], c->scans[k]);
        const std::string impl =
            fmt::format("improved, lost cost {:g}, volume filter {}", lost, tol < 0 ? std::string("off") : fmt::format("{:g}", tol));
        acc.add({fmt::format("{:g} % step, {}", 100 * kStrains[k], c->name), impl, t, 0.0, outcome_note(out)});
        std::cout << impl << " " << k << " " << c->name << ": " << outcome_note(out) << std::endl;
      }
  for (const auto& [step, share] : std::vector<std::pair<double, double>>{{1, 0.2}, {2, 0.2}, {10, 1.0}})
    csv << fmt::format("target,,{},{}\n", step, share);
  csv.close();

  // Rotations of the grains the improved mode matched correctly (ct2labels), against the truth.
  bench::Report rot("shapes2tracks_rotation", "shapes2tracks: grain rotations against the truth",
                    "The grains of scan 0 matched correctly to each later scan by the improved mode on ct2labels' "
                    "segmentation; their rotation from the shapes (labels2shapes, grey surfaces) against the true "
                    "rotation q_k q_0^-1 of ctsynth. `axes`: principal axes of the inertia ellipsoids, signs chosen by the "
                    "SH surfaces, undefined when two semi-axes are within 5 % or the surfaces cannot tell the signs "
                    "apart by a misfit ratio of 1.3; `sh`: then aligned by the SH surfaces (degree 8), undefined when "
                    "no rotation fits 1.3 times better than every other. Time: all grains of the step, all threads.");
  for (std::size_t k = 1; k < n_scans; ++k) {
    const Matching m = match_grains(seg.scans[0], seg.scans[k], MatchOptions{});
    const Outcome out = evaluate(seg.identity[0], seg.identity[k], m, seg.scans[0], seg.scans[k]);
    for (RotationMethod rm : {RotationMethod::sh, RotationMethod::axes}) {
      RotationOptions ro;
      ro.method = rm;
      const RotationEstimator est(std::min(seg.shapes[0].degree, seg.shapes[k].degree), ro);
      std::vector<double> err(out.correct_pairs.size(), -1.0), truth_angle(out.correct_pairs.size());
      const double t = bench::best_seconds(1, [&] {
#pragma omp parallel for schedule(dynamic, 8)
        for (std::size_t p = 0; p < out.correct_pairs.size(); ++p) {
          const auto [i, j] = out.correct_pairs[p];
          const long id = seg.identity[0].faithful[i];
          const Eigen::Quaterniond q = orientation[k][std::size_t(id)] * orientation[0][std::size_t(id)].conjugate();
          truth_angle[p] = q.angularDistance(Eigen::Quaterniond::Identity()) * 180.0 / std::numbers::pi;
          const RotationEstimate e = est.estimate(seg.shapes[0].grains[i], seg.shapes[k].grains[j]);
          if (e.defined) err[p] = e.rotation.angularDistance(q) * 180.0 / std::numbers::pi;
        }
      });
      std::vector<double> defined;
      for (double e : err)
        if (e >= 0.0) defined.push_back(e);
      std::sort(defined.begin(), defined.end());
      std::sort(truth_angle.begin(), truth_angle.end());
      const auto q = [&](double f) { return defined.empty() ? NAN : defined[std::size_t(f * double(defined.size() - 1))]; };
      const std::size_t flipped = std::size_t(std::count_if(defined.begin(), defined.end(), [](double e) { return e > 90.0; }));
      const std::string note = fmt::format(
          "defined for {} of {} ({:.1f} %); error median {:.2f}, 90 % {:.2f}, 99 % {:.1f} deg; {} off by > 90 deg; true "
          "rotation median {:.2f} deg",
          defined.size(), err.size(), 100.0 * double(defined.size()) / double(err.size()), q(0.5), q(0.9), q(0.99), flipped,
          truth_angle.empty() ? 0.0 : truth_angle[truth_angle.size() / 2]);
      rot.add({fmt::format("{:g} % step", 100 * kStrains[k]), rm == RotationMethod::sh ? "sh" : "axes", t, 0.0, note});
      std::cout << k << (rm == RotationMethod::sh ? " sh: " : " axes: ") << note << std::endl;
    }
  }

  // Speed: 16 000 synthetic grains (about 25 d50 a side) on one core.
  omp_set_num_threads(1);
  const std::size_t n_speed = quick ? 4000 : 16000;
  const ScanGrains a = synthetic_grains(n_speed, 0.55e-3, 15, 1);
  const double load_before = load_average();
  bench::Report speed(
      "shapes2tracks_speed", "shapes2tracks: matching speed",
      fmt::format("{} synthetic grains (`track/synthetic.hpp`: jittered dense arrangement, log-normal sizes, ctsynth-like "
                  "invariant spectra of degree 15) and a deformed copy (axial strain as in the case, a shear band with "
                  "slip 0.8 x the strain in d50, nonaffine noise 0.02 d50, 1 % volume and shape noise), matched by "
                  "`match_grains` with the backward check, one thread; best of 3 wall times; the note gives the CPU time "
                  "of the thread (the machine is shared: load average {:.1f} when the timing started) and the share "
                  "matched correctly. Target: under 1 s.",
                  n_speed, load_before));
  for (double strain : {0.02, 0.10}) {
    SyntheticMotion mo;
    mo.axial_strain = strain;
    mo.band_slip_d50 = 8.0 * strain;
    std::vector<int> truth;
    const ScanGrains b = deform_grains(a, mo, truth);
    for (Method me : kMethods) {
      MatchOptions o;
      o.method = me;
      Matching m;
      double cpu = 1e300;
      const double wall = bench::best_seconds(3, [&] {
        const double c0 = thread_seconds();
        m = match_grains(a, b, o);
        cpu = std::min(cpu, thread_seconds() - c0);
      });
      std::size_t ok = 0;
      for (std::size_t i = 0; i < truth.size(); ++i) ok += m.partner[i] == truth[i];
      const std::string note = fmt::format("CPU {:.3f} s; {:.2f} % correct", cpu, 100.0 * double(ok) / double(truth.size()));
      speed.add({fmt::format("{} grains, {:g} % step", n_speed, 100 * strain), method_name(me), wall, 0.0, note});
      std::cout << n_speed << " grains " << strain << " " << method_name(me) << ": " << wall << " s, " << note << std::endl;
    }
  }

  if (quick) {
    std::cout << acc.markdown("paper") << "\n" << damaged.markdown("paper") << "\n" << rot.markdown("axes") << "\n"
              << speed.markdown("paper") << std::endl;
    return 0;
  }
  const std::string png = kSource + "/docs/img/shapes2tracks_accuracy.png";
  bench::plot_xy(work / "accuracy.csv", png, "shapes2tracks: grains not matched correctly", "axial strain step (%)",
                 "faithful grains not correct: wrong or lost (%, floor 0.01)");
  const std::string md = kSource + "/docs/benchmarks.md";
  acc.publish("paper", md);
  damaged.publish("paper", md);
  rot.publish("axes", md);
  speed.publish("paper", md);
  return 0;
}
