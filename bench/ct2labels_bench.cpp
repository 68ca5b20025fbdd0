// ct2labels_bench: speed and memory of the ct2labels chain against
// scikit-image + scipy and ITK 5.2 (both from Debian), side by side in one run on the same 256^3
// ctsynth scans with the same marker policy; and the 1000^3 scale run.
//   build/bin/ct2labels_bench [--work DIR] [--reps N] [--sand-only]
//   build/bin/ct2labels_bench --scale [--work DIR]
// Every implementation runs as its own process (bench::run_child: wall time and peak RSS measured
// alike) and times its own steps with a monotonic clock; the table compares the segmentation
// (denoise .. watershed) without reading the scan and writing the labels, because the three read
// and write different formats (see the method text). Labels are scored against the ctsynth truth
// by ct2labels_accuracy_bench --match, the same code for all.
// Children (run by the benchmark itself):
//   ct2labels_bench --child-graintwin SCAN.h5 LABELS.mhd TIMES.json THREADS [H_VOX MIN_VOLUME_VOX]
// (with H_VOX and MIN_VOLUME_VOX given, GrainTwin skips choosing h, as the references do)
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <omp.h>
#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>

#include "graintwin/io/h5file.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/segment/segment_grains.hpp"
#include "harness.hpp"

namespace fs = std::filesystem;
using namespace graintwin;
using nlohmann::json;

namespace {

const std::string kSource = GRAINTWIN_SOURCE_DIR;
const std::string kSkimage = "scikit-image + scipy";

/// The 1-minute load average, for the method text.
std::string load_average() {
  std::ifstream in("/proc/loadavg");
  std::string a;
  in >> a;
  return a;
}

json read_json(const fs::path& p) {
  std::ifstream in(p);
  if (!in) throw std::runtime_error("missing " + p.string());
  return json::parse(in);
}

/// MetaImage header + raw data (ElementSpacing in millimetres, the ITK convention).
template <class T>
void write_metaimage(const fs::path& mhd, const Volume<T>& v) {
  const char* type = std::is_same_v<T, std::uint16_t> ? "MET_USHORT" : "MET_UINT";
  fs::path raw = mhd;
  raw.replace_extension(".raw");
  std::ofstream(raw, std::ios::binary)
      .write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(v.size() * sizeof(T)));
  const Vec3& s = v.voxel_size();
  std::ofstream(mhd) << fmt::format(
      "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\nDimSize = {} {} {}\n"
      "ElementSpacing = {} {} {}\nElementType = {}\nElementDataFile = {}\n",
      v.nx(), v.ny(), v.nz(), s[2] * 1e3, s[1] * 1e3, s[0] * 1e3, type, raw.filename().string());
}

/// CPU time of this process (all threads), a check on contention from other work.
double cpu_seconds() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return ru.ru_utime.tv_sec + ru.ru_stime.tv_sec + 1e-6 * (ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
}

// --- the GrainTwin child: segment_grains with default options, timed per step -----------------

int child_graintwin(const fs::path& scan, const fs::path& out, const fs::path& times, int threads,
                    std::optional<double> h_vox, std::optional<double> min_volume_vox) {
  omp_set_num_threads(threads);
  using clock = std::chrono::steady_clock;
  json steps = json::object();
  auto t0 = clock::now();
  AnyVolume grey = io::read_volume_file(scan);
  steps["read"] = std::chrono::duration<double>(clock::now() - t0).count();
  const double cpu0 = cpu_seconds();
  segment::SegmentOptions o;  // defaults: what ct2labels runs without options
  o.h_vox = h_vox;
  o.min_volume_vox = min_volume_vox;
  std::string current;
  auto started = clock::now();
  o.on_step = [&](const std::string& step) {
    const auto now = clock::now();
    if (!current.empty()) steps[current] = std::chrono::duration<double>(now - started).count();
    current = step;
    started = now;
  };
  segment::SegmentResult r = std::visit(
      [&](auto& v) -> segment::SegmentResult {
        using T = typename std::decay_t<decltype(v)>::value_type;
        if constexpr (std::is_same_v<T, std::uint32_t>) throw std::runtime_error("uint32 scan");
        else return segment::segment_grains(std::move(v), o);
      },
      grey);
  steps[current] = std::chrono::duration<double>(clock::now() - started).count();
  const double cpu = cpu_seconds() - cpu0;
  t0 = clock::now();
  write_metaimage(out, r.labels);
  steps["write"] = std::chrono::duration<double>(clock::now() - t0).count();
  std::ofstream(times) << json{{"steps", steps},
                               {"cpu", cpu},
                               {"threshold", r.threshold},
                               {"h_vox", r.marker_parameter_vox},
                               {"min_volume_vox", r.min_volume_vox},
                               {"markers", r.markers},
                               {"labels", r.grains.size()}}
                              .dump()
                       << "\n";
  return 0;
}

// --- scenes -----------------------------------------------------------------------------------

/// Makes (or reuses, see ct2labels_accuracy_bench --scene) the ctsynth scene in `dir`.
void make_scene(const fs::path& scene, const fs::path& dir, const std::vector<std::string>& options) {
  std::vector<std::string> args{(bench::bin_dir() / "ct2labels_accuracy_bench").string(), "--scene", scene.string(),
                                dir.string()};
  args.insert(args.end(), options.begin(), options.end());
  bench::run_child(dir.string(), "ctsynth", args);
}

struct Run {
  bench::Row row;     ///< wall time and peak RSS of the process
  json times;         ///< the child's own step times
  json match;         ///< accuracy against the truth
  double compute = 0.0;  ///< sum of the steps without read and write
};

double compute_seconds(const json& times) {
  double s = 0.0;
  for (const auto& [step, secs] : times.at("steps").items())
    if (step != "read" && step != "write") s += secs.get<double>();
  return s;
}

/// Runs one implementation `reps` times (the run with the shortest segmentation time is kept) and
/// scores its labels.
Run run_impl(const std::string& case_name, const std::string& impl, const std::vector<std::string>& argv,
             const fs::path& times, const fs::path& labels, const fs::path& truth, int reps) {
  Run best;
  best.compute = std::numeric_limits<double>::infinity();
  for (int i = 0; i < reps; ++i) {
    std::cout << "  " << impl << " ..." << std::flush;
    Run r;
    r.row = bench::run_child(case_name, impl, argv);
    r.times = read_json(times);
    r.compute = compute_seconds(r.times);
    std::cout << fmt::format(" {:.2f} s segmentation, {:.2f} s wall, {:.0f} MB peak", r.compute, r.row.seconds,
                             r.row.peak_bytes / 1e6)
              << std::endl;
    if (r.compute < best.compute) best = std::move(r);
  }
  const fs::path match = labels.string() + ".match.json";
  bench::run_child(case_name, "match",
                   {(bench::bin_dir() / "ct2labels_accuracy_bench").string(), "--match", labels.string(),
                    truth.string(), match.string()});
  best.match = read_json(match);
  return best;
}

// --- item 5: speed and memory on 256^3 -----------------------------------------------------------

struct CaseRuns {
  std::string name;
  std::size_t voxels = 0;
  std::map<std::string, Run> runs;  // by implementation
  std::vector<std::string> order;
  bench::Row tool;                  // the ct2labels tool itself
};

CaseRuns run_case(const std::string& name, const fs::path& dir, int reps, int cores) {
  CaseRuns c;
  c.name = name;
  const fs::path scan = dir / "scan_000.h5", truth = dir / "truth_000.h5";
  // ITK's input: a MetaImage copy of the scan (ITK's HDF5 reader expects ITK's own layout).
  const fs::path mhd = dir / "scan.mhd";
  {
    const auto v = std::get<Volume<std::uint16_t>>(io::read_volume_file(scan));
    c.voxels = v.size();
    write_metaimage(mhd, v);  // rewritten every run: the scan may have been regenerated
  }
  std::cout << name << " (" << dir.string() << ")" << std::endl;
  const auto add = [&](const std::string& impl, Run r) {
    c.order.push_back(impl);
    c.runs[impl] = std::move(r);
  };
  const std::string self = (bench::bin_dir() / "ct2labels_bench").string();
  const std::string gt1 = "GrainTwin, 1 thread", gtn = fmt::format("GrainTwin, {} threads", cores);
  add(gt1, run_impl(name, gt1, {self, "--child-graintwin", scan.string(), (dir / "gt1.mhd").string(),
                                (dir / "gt1.json").string(), "1"},
                    dir / "gt1.json", dir / "gt1.mhd", truth, reps));
  add(gtn, run_impl(name, gtn, {self, "--child-graintwin", scan.string(), (dir / "gtn.mhd").string(),
                                (dir / "gtn.json").string(), std::to_string(cores)},
                    dir / "gtn.json", dir / "gtn.mhd", truth, reps));
  // The same marker policy for the references: h-maxima with the h GrainTwin chose from the image.
  const std::string h = fmt::format("{:.17g}", c.runs[gt1].times.at("h_vox").get<double>());
  // GrainTwin given that h (and the fragment size it chose) does the references' work: the same
  // labels as its default run, without choosing h.
  const std::string gtg = "GrainTwin, 1 thread, h given";
  add(gtg, run_impl(name, gtg, {self, "--child-graintwin", scan.string(), (dir / "gtg.mhd").string(),
                                (dir / "gtg.json").string(), "1", h,
                                fmt::format("{:.17g}", c.runs[gt1].times.at("min_volume_vox").get<double>())},
                    dir / "gtg.json", dir / "gtg.mhd", truth, reps));
  // scipy and scikit-image run these steps on one thread; keep numpy's BLAS helpers to one as well.
  setenv("OMP_NUM_THREADS", "1", 1);
  setenv("OPENBLAS_NUM_THREADS", "1", 1);
  // The same denoising: GrainTwin's default Gaussian.
  const std::string sigma = fmt::format("{}", segment::SegmentOptions{}.gaussian_sigma_vox);
  add(kSkimage, run_impl(name, kSkimage, {"/usr/bin/python3", kSource + "/bench/reference/skimage_segment.py",
                                          scan.string(), (dir / "sk.mhd").string(), (dir / "sk.json").string(), h,
                                          sigma},
                         dir / "sk.json", dir / "sk.mhd", truth, reps));
  unsetenv("OMP_NUM_THREADS");
  unsetenv("OPENBLAS_NUM_THREADS");
  const fs::path itk = bench::bin_dir() / "itk_segment";
  if (fs::exists(itk))
    add("ITK 5.2, 1 thread",
        run_impl(name, "ITK 5.2, 1 thread",
                 {itk.string(), mhd.string(), (dir / "itk.mhd").string(), (dir / "itk.json").string(), h, "1", sigma},
                 dir / "itk.json", dir / "itk.mhd", truth, reps));
  else
    std::cout << "  (no " << itk.string() << ": ITK rows skipped; bench/deps-bench.sh, then ninja itk_segment)"
              << std::endl;
  std::cout << "  ct2labels tool ..." << std::flush;
  c.tool = bench::run_child(name, "ct2labels", {(bench::bin_dir() / "ct2labels").string(), scan.string(),
                                                (dir / "ct2labels.h5").string(), "--force", "--quiet", "-j",
                                                std::to_string(cores)});
  std::cout << fmt::format(" {:.2f} s wall, {:.0f} MB peak", c.tool.seconds, c.tool.peak_bytes / 1e6) << std::endl;
  return c;
}

int speed_main(const fs::path& work, int reps, bool sand_only) {
  const int cores = omp_get_num_procs();
  const std::string scene = kSource + "/bench/scenes/ct2labels_sand256.toml";
  std::vector<std::pair<std::string, fs::path>> cases{{"sand 256^3", work / "sand256"}};
  make_scene(scene, work / "sand256", {});
  if (!sand_only) {
    cases.push_back({"spheres 256^3", work / "spheres256"});
    make_scene(scene, work / "spheres256", {"--grain-shape", "sphere"});
  }
  const std::string load = load_average();
  std::vector<CaseRuns> all;
  for (const auto& [name, dir] : cases) all.push_back(run_case(name, dir, reps, cores));
  const std::string load_after = load_average();

  const std::string gt1 = "GrainTwin, 1 thread", gtn = fmt::format("GrainTwin, {} threads", cores);
  const std::string itk = "ITK 5.2, 1 thread";
  const auto share = [](const Run& r) { return 100 * r.match.at("matched_share").get<double>(); };
  const auto cpu = [](const Run& r) { return r.times.at("cpu").get<double>(); };
  std::string summary;
  for (const auto& c : all) {
    const Run& sk = c.runs.at(kSkimage);
    const Run& g1 = c.runs.at(gt1);
    const Run& gn = c.runs.at(gtn);
    const Run* it = c.runs.count(itk) ? &c.runs.at(itk) : nullptr;
    summary += fmt::format("\n\n**{}**: GrainTwin on 1 thread is {:.1f}x faster than scikit-image (target 10x: {})",
                           c.name, sk.compute / g1.compute, sk.compute / g1.compute >= 10 ? "met" : "missed");
    if (it)
      summary += fmt::format(" and {:.1f}x faster than ITK on 1 thread (target 5x: {})", it->compute / g1.compute,
                             it->compute / g1.compute >= 5 ? "met" : "missed");
    summary += fmt::format(" (in CPU time, which other load does not inflate: {:.1f}x", cpu(sk) / cpu(g1));
    if (it) summary += fmt::format(" and {:.1f}x", cpu(*it) / cpu(g1));
    const Run& gg = c.runs.at("GrainTwin, 1 thread, h given");
    summary += fmt::format("); given the h it chose, i.e. doing the references' work, {:.1f}x", sk.compute / gg.compute);
    if (it) summary += fmt::format(" and {:.1f}x", it->compute / gg.compute);
    summary += fmt::format("; on {} threads {:.1f}x", cores, sk.compute / gn.compute);
    if (it) summary += fmt::format(" and {:.1f}x", it->compute / gn.compute);
    summary += fmt::format("; grains matched {:.1f} % against {:.1f} % (scikit-image)", share(g1), share(sk));
    if (it) summary += fmt::format(" and {:.1f} % (ITK)", share(*it));
    summary += fmt::format(
        "; peak {:.1f} bytes per voxel on 1 thread (target 12: {}), scikit-image {:.1f}. The ct2labels tool itself "
        "(the same chain plus reading the HDF5 scan and writing the gzip-compressed labels file with the grain "
        "table) took {:.1f} s wall on {} threads at {:.1f} bytes per voxel.",
        g1.row.peak_bytes / c.voxels, g1.row.peak_bytes / c.voxels <= 12 ? "met" : "missed",
        sk.row.peak_bytes / c.voxels, c.tool.seconds, cores, c.tool.peak_bytes / c.voxels);
  }
  const std::string method =
      "Scans: ctsynth `bench/scenes/ct2labels_sand256.toml` (about 3 400 Ottawa-like sand grains, 16 voxels per d50, "
      "5 % noise, blur 0.8, in a cylinder with a membrane; 256^3 uint16) and the same scene with spheres. Every "
      "implementation runs the same chain as its own process: Gaussian smoothing of sigma 0.4 voxel (GrainTwin's "
      "default), Otsu on the exact integer histogram (GrainTwin inside the sample cylinder it fits, the references "
      "over the whole volume, which costs them less), hole filling, exact EDT, h-maxima markers, marker watershed of -EDT in the solid, 26-connectivity. Marker "
      "policy: GrainTwin chooses h from the image (its default; the time includes that choice, fragment merging, "
      "the sample cylinder and the grain table), the references get the same h; the row `h given` is GrainTwin "
      "given that h and fragment size (identical labels, no choice of h). scikit-image 0.19.3 + scipy 1.10.1 "
      "(Debian python3, `bench/reference/skimage_segment.py`: gaussian_filter, threshold_otsu, binary_fill_holes, "
      "distance_transform_edt, h_maxima, label, watershed) reads the .h5 with h5py; ITK 5.2.1 (Debian, "
      "`bench/reference/itk_segment.cpp`, one thread: DiscreteGaussian, OtsuThreshold, BinaryFillhole, SignedMaurerDistanceMap "
      "of the void, HMaxima + RegionalMaxima + ConnectedComponent, MorphologicalWatershedFromMarkers, Mask) reads "
      "a MetaImage copy of the scan. **Time = the segmentation, from the grey volume in memory to the label volume "
      "in memory**, measured inside each process around the same steps; reading and writing (different formats) are "
      "excluded from it and included in the wall time in the notes (which also holds interpreter start-up); the "
      "notes also give the CPU time of the segmentation. Peak memory = peak RSS of the whole process (for Python "
      "including the interpreter and libraries, about 0.1 GB). Accuracy: share of the truth's grains matched "
      "one-to-one with IoU >= 0.8 (`ct2labels_accuracy_bench --match`, the same code for all). " +
      fmt::format("{} run(s) each (the fastest kept), in one sitting; load average {} at the start and {} at the end ",
                  reps, load, load_after) +
      "(2 cores shared with other work: absolute times are noisy, the ratios of the same run are the figures)." +
      summary;
  bench::Report speed("ct2labels_speed", "ct2labels: speed and memory against scikit-image and ITK", method);
  for (const auto& c : all)
    for (const auto& impl : c.order) {
      const Run& r = c.runs.at(impl);
      std::string note = fmt::format("wall {:.1f} s with I/O, CPU {:.1f} s; {:.1f} B/voxel; {:.1f} % of {} grains "
                                     "matched; {} markers",
                                     r.row.seconds, cpu(r), r.row.peak_bytes / c.voxels, share(r),
                                     r.match.at("grains").get<int>(), r.times.at("markers").get<std::size_t>());
      if (impl.rfind("GrainTwin", 0) == 0 && c.runs.count(itk))
        note += fmt::format("; {:.1f}x faster than ITK", c.runs.at(itk).compute / r.compute);
      speed.add({c.name, impl, r.compute, r.row.peak_bytes, note});
    }
  // Steps of the first (sand) case in pipeline order, implementations side by side; I/O is in the
  // wall times above.
  bench::Report steps("ct2labels_steps", "ct2labels: time per step (" + all.front().name + ")",
                      "The step times behind the table above (seconds, measured inside each process; GrainTwin's "
                      "`markers` includes choosing h from the image, which the references are given; `sample "
                      "region`, `fragments` and `grain table` are GrainTwin-only). Ratios against scikit-image per "
                      "step.");
  const CaseRuns& c0 = all.front();
  for (const char* step : {"denoise", "threshold", "fill holes", "sample region", "distance transform", "markers",
                           "watershed", "fragments", "grain table"})
    for (const auto& impl : c0.order) {
      const json& st = c0.runs.at(impl).times.at("steps");
      if (st.contains(step)) steps.add({step, impl, st.at(step).get<double>(), 0, ""});
    }
  speed.publish(kSkimage, kSource + "/docs/benchmarks.md");
  steps.publish(kSkimage, kSource + "/docs/benchmarks.md");
  return 0;
}

// --- item 6: 1000^3 ------------------------------------------------------------------------------

double mem_available_bytes() {
  std::ifstream in("/proc/meminfo");
  std::string key;
  double kb = 0;
  while (in >> key >> kb) {
    if (key == "MemAvailable:") return kb * 1024.0;
    in.ignore(256, '\n');
  }
  return 0.0;
}

int scale_main(const fs::path& work) {
  const int cores = omp_get_num_procs();
  const std::size_t n = 1000;
  const fs::path dir = work / "sand256";
  make_scene(kSource + "/bench/scenes/ct2labels_sand256.toml", dir, {});
  const fs::path big = work / "sand1000.h5";
  std::size_t grains_in_tile = 0;
  {
    const io::H5File truth = io::open_kind(dir / "truth_000.h5", schema::kind::ground_truth);
    grains_in_tile = truth.read<std::uint32_t>(schema::ground_truth::grain_label).size();
  }
  // Rebuilt when missing or older than the scan it tiles (the scene may have been remade).
  if (!fs::exists(big) || fs::last_write_time(big) < fs::last_write_time(dir / "scan_000.h5")) {
    // 4 x 4 x 4 copies of the 256^3 scan, every other copy mirrored so neighbouring tiles meet
    // face to face (air margin against air margin), cropped to 1000^3: many samples' worth of
    // grains with the grey statistics of a real render.
    std::cout << "building " << big.string() << std::endl;
    const auto tile = std::get<Volume<std::uint16_t>>(io::read_volume_file(dir / "scan_000.h5"));
    const Shape3 t = tile.shape();
    Volume<std::uint16_t> v({n, n, n}, tile.voxel_size());
#pragma omp parallel for schedule(static)
    for (std::size_t z = 0; z < n; ++z)
      for (std::size_t y = 0; y < n; ++y)
        for (std::size_t x = 0; x < n; ++x) {
          const auto fold = [](std::size_t i, std::size_t m) {
            const std::size_t k = i / m, r = i % m;
            return k % 2 ? m - 1 - r : r;
          };
          v(z, y, x) = tile(fold(z, t[0]), fold(y, t[1]), fold(x, t[2]));
        }
    io::write_volume_file(big, AnyVolume(std::move(v)), {"ct2labels_bench --scale: 4x4x4 mirrored tiles of " +
                                                         (dir / "scan_000.h5").string()});
  }
  // 12 bytes per voxel is 12 GB here; refuse rather than push a shared machine into the OOM killer.
  const double need = 13e9, avail = mem_available_bytes();
  std::cout << fmt::format("memory available: {:.1f} GB", avail / 1e9) << std::endl;
  if (avail < need) {
    std::cerr << fmt::format("only {:.1f} GB available, {:.0f} GB needed; run again when the machine is quieter\n",
                             avail / 1e9, need / 1e9);
    return 1;
  }
  const fs::path out = work / "sand1000_labels.h5";
  std::cout << "ct2labels on 1000^3 ..." << std::flush;
  const std::string load = load_average();
  bench::Row r = bench::run_child("1000^3 uint16", fmt::format("ct2labels, {} threads", cores),
                                  {(bench::bin_dir() / "ct2labels").string(), big.string(), out.string(), "--force",
                                   "--quiet", "--region", "volume", "-j", std::to_string(cores)});
  std::cout << fmt::format(" {:.0f} s, {:.2f} GB peak", r.seconds, r.peak_bytes / 1e9) << std::endl;
  const io::H5File lf = io::open_kind(out, schema::kind::labels);
  const json p = json::parse(lf.read_strings(schema::labels::parameters).at(0));
  const double voxels = static_cast<double>(n * n * n);
  r.note = fmt::format("{:.2f} GB peak = {:.1f} B/voxel (limit 24 GB: {}); {} labels from 64 copies of a {}-grain scan "
                       "(those on the far faces cropped, cutting grains); h {:.2f}",
                       r.peak_bytes / 1e9, r.peak_bytes / voxels, r.peak_bytes <= 24e9 ? "met" : "missed",
                       p.at("grains").get<std::size_t>(), grains_in_tile, p.at("h_vox").get<double>());
  bench::Report report(
      "ct2labels_scale", "ct2labels: a 1000^3 uint16 volume",
      "Target: a 1000^3 uint16 volume segments within 24 GB. The volume is 4 x 4 x 4 mirrored copies of the "
      "256^3 sand scan of the speed benchmark, cropped to 1000^3 (16 voxels per d50, 5 % noise), written as a "
      "kind=volume .h5; `ct2labels` runs on it with default settings except `--region volume` "
      "(the tiles hold many cylinders). Time = wall time of the process including reading the scan and writing the "
      "labels (gzip); memory = its peak RSS. Load average " + load + " at the start.");
  report.add(r);
  report.publish("none", kSource + "/docs/benchmarks.md");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if ((argc == 6 || argc == 8) && std::string(argv[1]) == "--child-graintwin")
      return child_graintwin(argv[2], argv[3], argv[4], std::stoi(argv[5]),
                             argc == 8 ? std::optional<double>(std::stod(argv[6])) : std::nullopt,
                             argc == 8 ? std::optional<double>(std::stod(argv[7])) : std::nullopt);
    fs::path work = "/tmp/graintwin_ct2labels_bench";
    int reps = 1;
    bool scale = false, sand_only = false;
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      if (a == "--work" && i + 1 < argc) work = argv[++i];
      else if (a == "--reps" && i + 1 < argc) reps = std::max(1, std::stoi(argv[++i]));
      else if (a == "--scale") scale = true;
      else if (a == "--sand-only") sand_only = true;
      else {
        std::cerr << "usage: ct2labels_bench [--work DIR] [--reps N] [--sand-only] | --scale [--work DIR]\n";
        return 2;
      }
    }
    fs::create_directories(work);
    return scale ? scale_main(work) : speed_main(work, reps, sand_only);
  } catch (const std::exception& e) {
    std::cerr << "ct2labels_bench: " << e.what() << "\n";
    return 1;
  }
}
