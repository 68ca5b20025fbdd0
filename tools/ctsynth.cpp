// ctsynth: synthetic CT scan series of a sand sample under triaxial load, with exact ground truth.
//   ctsynth pipelines/scenes/sand_small.toml out/            (one scan per entry of `strains`)
//   ctsynth scene.toml out/ --noise 0.1 --seed 7               (options override the scene file)
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <random>

#include "graintwin/cli/option_checks.hpp"
#include "graintwin/cli/tool.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/interrupt.hpp"
#include "graintwin/core/resources.hpp"
#include "graintwin/core/strings.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/shape/sh_basis.hpp"
#include "graintwin/synth/grains.hpp"
#include "graintwin/synth/ground_truth.hpp"
#include "graintwin/synth/loading.hpp"
#include "graintwin/synth/packing.hpp"
#include "graintwin/synth/psd.hpp"
#include "graintwin/synth/render.hpp"
#include "graintwin/version.hpp"

namespace fs = std::filesystem;
using namespace graintwin;
using namespace graintwin::synth;

namespace {

struct Options {
  std::uint64_t seed = 1;
  std::string grain_shape = "sand";
  int sh_degree = 15;
  double aspect_ratio = 1.3;
  std::vector<int> angular_facets{8, 20};
  int angular_dents = 2;
  double angular_dent_depth = 0.10, angular_roughness = 0.01;
  int angular_roughness_degree = 32;
  std::string d_min = "0.30mm", d50 = "0.551mm", d_max = "1.03mm";
  double psd_sigma = 0.25;
  std::string container = "cylinder";
  std::string diameter = "3.0mm", height = "3.6mm", box = "";
  double solid_fraction = 0.55;
  double contact_tolerance = 0.02;
  std::string pack_degrees = "7,11";
  std::string voxel_size = "27.5um";
  double margin_vox = 4.0;
  std::string membrane_thickness = "0.3mm";
  int supersample = 0;
  double blur = 0.8, noise = 0.05, photons = 0.0, rings = 0.0, beam_hardening = 0.0;
  double grey_void = 0.10, grey_grain = 0.75, grey_membrane = 0.35;
  double grey_scale = 50000.0, grey_offset = 5000.0;
  std::vector<double> strains{0.0, 0.02, 0.04};
  double bulge = 0.5;
  std::string band = "single";
  double band_angle = 60.0, band_azimuth = 0.0, band_slip = 0.5, nonaffine = 0.15, rotation_per_shear = 0.5;
  std::string band_width = "";  // default 10 d50
  std::string contact_search = "";  // default 2 voxels
};

std::string scan_name(const char* stem, std::size_t k) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%s_%03zu.h5", stem, k);
  return buf;
}

// "7,11" -> {7, 11}: increasing SH degrees >= 2, those >= sh_degree dropped; "none" -> {}.
std::vector<int> parse_pack_degrees(const std::string& text, int sh_degree) {
  if (text == "none") return {};
  std::vector<int> out;
  for (const auto& part : split(text, ',')) {
    int d = -1;
    try {
      std::size_t used = 0;
      d = std::stoi(part, &used);
      if (used != part.size()) d = -1;
    } catch (const std::exception&) {
      d = -1;
    }
    if (d < 2 || (!out.empty() && d <= out.back()))
      throw UsageError("--pack-degrees '" + text + "' must be increasing SH degrees of at least 2, e.g. 7,11, or none");
    out.push_back(d);
  }
  // Stages at or above the grains' own degree would be the true shapes again.
  std::erase_if(out, [&](int d) { return d >= sh_degree; });
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool("ctsynth",
                 "Make a synthetic CT scan series of a dense sand sample under triaxial load, with exact ground "
                 "truth: grains (spheres, ellipsoids, random spherical-harmonic sand shapes, Ottawa-like by "
                 "default, or angular crushed-quartz-like polyhedra with dents and roughness) sized from a PSD and packed densely in a cylinder or box, prescribed loading states "
                 "(axial compression, bulging, shear band with nonaffine motion and grain rotations, overlaps "
                 "relaxed), partial-volume rendering with blur, noise, rings and cupping, and per scan a "
                 "kind=volume scan_NNN.h5 plus a kind=ground_truth truth_NNN.h5. Every scene key is an option "
                 "of the same name; options given on the command line override the scene file. Sand and angular grains pack "
                 "with the roughness off, then on (--pack-degrees). Every grain is star-shaped about its centroid "
                 "(angular grains too: no non-star grain is generated yet). Limit: in a cylinder 6.5 d50 wide they jam near 0.58 "
                 "solid fraction (the bundled series packs 0.5804; 0.582 jammed with another draw): the loose layer at "
                 "the walls costs the most, wider samples pack denser; states are prescribed kinematics, not mechanics.");
  Options o;
  fs::path outdir, scene;
  auto& app = tool.cli();
  tool.use_positional_config("scene", scene, "Scene file (TOML, keys = option names below)");
  tool.add_output("outdir", outdir, "Output folder (created; refused if it exists, unless --force)");
  // Every numeric option and scene key is checked while the scene and the command line are read,
  // against a physical range shown in --help (see docs/conventions.md, "Option ranges").
  using cli::closed, cli::above, cli::number_in, cli::whole_number_in, cli::length_in;
  const auto grain_size = length_in(1e-6, 0.1);       // grain diameters: micrometres to centimetres
  const auto sample_size = length_in(10e-6, 1.0);     // container dimensions
  const auto grey_level = number_in(closed(0, 10));   // grey levels, in units of the uint16 scale
  app.add_option("--seed", o.seed, "Random seed (same seed, same bytes)")->capture_default_str();
  app.add_option("--grain-shape", o.grain_shape,
                 "sphere, ellipsoid, sand (smooth SH grains) or angular (random convex polyhedra with sharp edges, "
                 "flat facets, dents and roughness; all star-shaped about their centroid)")
      ->capture_default_str();
  app.add_option("--sh-degree", o.sh_degree,
                 "SH degree of sand grains and of the stored coefficients (angular grains: of their least-squares fit; "
                 "the scans keep the sharp edges)")
      ->check(whole_number_in(2, 30))->capture_default_str();
  app.add_option("--aspect-ratio", o.aspect_ratio, "Ellipsoids: longest / shortest axis")
      ->check(number_in(closed(1, 10)))->capture_default_str();
  app.add_option("--angular-facets", o.angular_facets,
                 "Angular grains: fewest and most cutting planes per grain, MIN,MAX (4 <= MIN <= MAX <= 64; a few are "
                 "added where a vertex would be a needle)")
      ->delimiter(',')->expected(2)->check(whole_number_in(4, 64))->capture_default_str();
  app.add_option("--angular-dents", o.angular_dents, "Angular grains: most dents (local concavities) per grain, each drawn 0..this")
      ->check(whole_number_in(0, 8))->capture_default_str();
  app.add_option("--angular-dent-depth", o.angular_dent_depth,
                 "Angular grains: deepest dent, a fraction of the local radius (each dent 0.5-1 x this, 0.34-0.56 rad wide)")
      ->check(number_in(closed(0, 0.3)))->capture_default_str();
  app.add_option("--angular-roughness", o.angular_roughness,
                 "Angular grains: RMS surface roughness, a fraction of the radius (SH degrees 8 to --angular-roughness-degree)")
      ->check(number_in(closed(0, 0.05)))->capture_default_str();
  app.add_option("--angular-roughness-degree", o.angular_roughness_degree, "Angular grains: highest SH degree of the roughness")
      ->check(whole_number_in(8, 64))->capture_default_str();
  app.add_option("--d-min", o.d_min, "PSD: smallest grain (volume-equivalent diameter)")->check(grain_size)->capture_default_str();
  app.add_option("--d50", o.d50, "PSD: median by mass")->check(grain_size)->capture_default_str();
  app.add_option("--d-max", o.d_max, "PSD: largest grain")->check(grain_size)->capture_default_str();
  app.add_option("--psd-sigma", o.psd_sigma, "PSD: log-normal spread of the grading (by mass)")
      ->check(number_in(above(0, 2)))->capture_default_str();
  app.add_option("--container", o.container, "cylinder or box")->capture_default_str();
  app.add_option("--diameter", o.diameter, "Cylinder diameter (sample inside the membrane)")->check(sample_size)->capture_default_str();
  app.add_option("--height", o.height, "Cylinder height (platen to platen)")->check(sample_size)->capture_default_str();
  app.add_option("--box", o.box, "Box edge lengths X,Y,Z, e.g. 4mm,4mm,4mm (with --container box; each 10 um to 1 m)");
  app.add_option("--solid-fraction", o.solid_fraction,
                 fmt::format("Grain volume / container volume to pack ({:g} is the densest arrangement of equal spheres; random "
                             "packings of sand stop near 0.64)",
                             synth::kDensestPacking))
      ->check(number_in(above(0, synth::kDensestPacking)))->capture_default_str();
  app.add_option("--contact-tolerance", o.contact_tolerance,
                 "Largest interpenetration, as a fraction of the smallest grain radius; pairs within it touch")
      ->check(number_in(cli::NumberRange{0, 0.5, true, true, ""}))->capture_default_str();
  app.add_option("--pack-degrees", o.pack_degrees,
                 "Sand and angular grains: pack with the roughness off, then on: grow the grains low-passed to the first SH "
                 "degree, then relax at each next degree and at the true shapes (increasing; degrees from --sh-degree "
                 "up are skipped; none: grow the true shapes)")
      ->capture_default_str();
  app.add_option("--voxel-size", o.voxel_size, "Voxel size of the scans")->check(length_in(10e-9, 0.01))->capture_default_str();
  app.add_option("--margin-vox", o.margin_vox, "Air around the sample and membrane (voxels)")
      ->check(number_in(closed(0, 1000, "voxels")))->capture_default_str();
  app.add_option("--membrane-thickness", o.membrane_thickness, "Latex membrane around a cylinder (0 = none)")
      ->check(length_in(1e-6, 0.01, true))->capture_default_str();
  app.add_option("--supersample", o.supersample,
                 "Partial volumes: 0 = analytic (secant plane per boundary voxel, exact for a plane), "
                 "k = k^3 point samples per boundary voxel")
      ->check(whole_number_in(0, 16))->capture_default_str();
  app.add_option("--blur", o.blur, "Point-spread sigma (voxels)")->check(number_in(closed(0, 20, "voxels")))->capture_default_str();
  app.add_option("--noise", o.noise, "Gaussian noise sigma / (grain - void) contrast")
      ->check(number_in(closed(0, 10)))->capture_default_str();
  app.add_option("--photons", o.photons, "Mean photon count at grain grey for Poisson noise (0 = none)")
      ->check(number_in(closed(0, 1e9)))->capture_default_str();
  app.add_option("--rings", o.rings, "Ring artifact amplitude / contrast (0 = none)")
      ->check(number_in(closed(0, 10)))->capture_default_str();
  app.add_option("--beam-hardening", o.beam_hardening, "Cupping depth / grain grey at the axis (0 = none)")
      ->check(number_in(closed(0, 1)))->capture_default_str();
  app.add_option("--grey-void", o.grey_void, "Grey level of air and pores")->check(grey_level)->capture_default_str();
  app.add_option("--grey-grain", o.grey_grain, "Grey level of grains (above --grey-void)")->check(grey_level)->capture_default_str();
  app.add_option("--grey-membrane", o.grey_membrane, "Grey level of the membrane")->check(grey_level)->capture_default_str();
  app.add_option("--grey-scale", o.grey_scale,
                 "uint16 value per unit grey (smaller: fewer levels, smaller files); every grey level must land in "
                 "0..65535")
      ->check(number_in(above(0, 1e6)))->capture_default_str();
  app.add_option("--grey-offset", o.grey_offset, "uint16 value of grey 0")
      ->check(number_in(closed(0, 65535)))->capture_default_str();
  app.add_option("--strains", o.strains, "Nominal axial strain of each scan (compression positive)")
      ->delimiter(',')->check(number_in(cli::NumberRange{0, 0.5, false, true, ""}))->capture_default_str();
  app.add_option("--bulge", o.bulge, "Mean lateral strain / axial strain (0.5 keeps the volume)")
      ->check(number_in(closed(0, 2)))->capture_default_str();
  app.add_option("--band", o.band, "Shear band: none, single or crossed")->capture_default_str();
  app.add_option("--band-angle", o.band_angle, "Band inclination from horizontal (deg)")
      ->check(number_in(cli::NumberRange{0, 90, true, true, "deg"}))->capture_default_str();
  app.add_option("--band-azimuth", o.band_azimuth, "Dip direction in the x-y plane (deg from x)")
      ->check(number_in(closed(-360, 360, "deg")))->capture_default_str();
  app.add_option("--band-width", o.band_width, "Band thickness (default 10 d50)")->check(length_in(1e-6, 1.0));
  app.add_option("--band-slip", o.band_slip, "Slip across the band per unit axial strain, in sample heights")
      ->check(number_in(closed(0, 10)))->capture_default_str();
  app.add_option("--nonaffine", o.nonaffine, "Random grain motion in the band per unit slip (std)")
      ->check(number_in(closed(0, 10)))->capture_default_str();
  app.add_option("--rotation-per-shear", o.rotation_per_shear, "Grain rotation (rad) per unit local shear")
      ->check(number_in(closed(-10, 10, "rad")))->capture_default_str();
  app.add_option("--contact-search", o.contact_search, "Record pairs closer than this as near-contacts (default 2 voxels)")
      ->check(length_in(1e-9, 0.01));
  tool.set_examples({"ctsynth pipelines/scenes/sand_small.toml runs/sand_small_truth",
                     "ctsynth pipelines/scenes/sand_small.toml out --grain-shape sphere --noise 0.1 --strains 0,0.01",
                     "ctsynth scene.toml out --container box --box 3mm,3mm,3mm --band none"});

  return tool.run(argc, argv, [&](cli::RunContext& ctx) {
    // --- validate everything before heavy work ---
    const GrainShape shape_kind = parse_grain_shape(o.grain_shape);
    if (o.angular_facets.size() != 2 || o.angular_facets[0] > o.angular_facets[1])
      throw UsageError("--angular-facets needs MIN,MAX with MIN <= MAX, e.g. 8,20");
    Psd psd{parse_length_m(o.d_min, "--d-min"), parse_length_m(o.d50, "--d50"), parse_length_m(o.d_max, "--d-max"),
            o.psd_sigma};
    psd.validate();
    const double voxel = parse_length_m(o.voxel_size, "--voxel-size");
    Container container;
    if (o.container == "cylinder") {
      container.kind = Container::Kind::cylinder;
      container.radius = 0.5 * parse_length_m(o.diameter, "--diameter");
      container.height = parse_length_m(o.height, "--height");
    } else if (o.container == "box") {
      container.kind = Container::Kind::box;
      const auto parts = split(o.box, ',');
      if (parts.size() != 3) throw UsageError("--box needs three lengths X,Y,Z, e.g. 4mm,4mm,6mm");
      for (int a = 0; a < 3; ++a) container.box_size[a] = cli::parse_length_in(parts[a], "--box", 10e-6, 1.0);
    } else {
      throw UsageError("--container '" + o.container + "' is not cylinder or box");
    }
    if (o.strains.empty()) throw UsageError("--strains needs at least one value (0 for an unloaded scan)");
    const std::vector<int> pack_degrees =
        shape_kind == GrainShape::sand || shape_kind == GrainShape::angular ? parse_pack_degrees(o.pack_degrees, o.sh_degree) : std::vector<int>{};
    const double membrane_t = container.kind == Container::Kind::cylinder && o.membrane_thickness != "0"
                                  ? parse_length_m(o.membrane_thickness, "--membrane-thickness")
                                  : 0.0;
    const double band_width = o.band_width.empty() ? 10.0 * psd.d50 : parse_length_m(o.band_width, "--band-width");
    const double search_gap = o.contact_search.empty() ? 2.0 * voxel : parse_length_m(o.contact_search, "--contact-search");
    ShearBand band = ShearBand::single;
    if (o.band == "none") band = ShearBand::none;
    else if (o.band == "crossed") band = ShearBand::crossed;
    else if (o.band != "single") throw UsageError("--band '" + o.band + "' is not none, single or crossed");
    if (container.kind == Container::Kind::box && (band != ShearBand::none || o.bulge != 0.0) &&
        o.strains.size() > 1)
      spdlog::info("box container: loading uses the box centre as the sample axis");
    ScannerParams sp;
    sp.grey_void = o.grey_void;
    sp.grey_grain = o.grey_grain;
    sp.grey_membrane = o.grey_membrane;
    sp.uint16_scale = o.grey_scale;
    sp.uint16_offset = o.grey_offset;
    check_grey_levels(sp, membrane_t > 0.0);

    // --- image geometry: fixed for the series, large enough for the most bulged state ---
    const bool cyl = container.kind == Container::Kind::cylinder;
    const double eps_max = *std::max_element(o.strains.begin(), o.strains.end());
    const double margin = o.margin_vox * voxel;
    Vec3 lo, hi;  // x y z
    if (cyl) {
      const double r_out = container.radius * (1.0 + 1.5 * std::max(0.0, o.bulge) * eps_max) + membrane_t + margin;
      lo = {-r_out, -r_out, -margin};
      hi = {r_out, r_out, container.height + margin};
    } else {
      lo = {-margin, -margin, -margin};
      hi = {container.box_size.x() + margin, container.box_size.y() + margin, container.box_size.z() + margin};
    }
    const Vec3 voxels{std::ceil((hi[2] - lo[2]) / voxel), std::ceil((hi[1] - lo[1]) / voxel),
                      std::ceil((hi[0] - lo[0]) / voxel)};  // z y x, as reals until they are known to fit
    // What the series holds at once: the grains' tables (and one smoothed copy per packing stage)
    // and one scan being rendered.
    const double grains_expected = expected_grain_count(psd, o.solid_fraction * container.volume());
    const double scan_bytes = voxels[0] * voxels[1] * voxels[2] * kScanBytesPerVoxel;
    const double grain_table_bytes =
        grains_expected * grain_bytes(psd.d50, voxel, o.sh_degree) * static_cast<double>(1 + pack_degrees.size());
    // The advice names first what dominates: millions of tiny grains are fixed by the PSD, not the voxels.
    check_memory(scan_bytes + grain_table_bytes, "ctsynth",
                 fmt::format("scans of {:.3g} x {:.3g} x {:.3g} voxels (z, y, x) and about {:.3g} grains", voxels[0],
                             voxels[1], voxels[2], grains_expected),
                 grain_table_bytes > scan_bytes
                     ? "give larger grains (--d-min, --d50, --d-max), a smaller sample (--diameter, --height or --box) or larger voxels (--voxel-size)"
                     : "make the sample smaller (--diameter, --height or --box), the voxels larger (--voxel-size) or the grains larger (--d-min, --d50, --d-max)");
    const Shape3 shape{static_cast<std::size_t>(voxels[0]), static_cast<std::size_t>(voxels[1]),
                       static_cast<std::size_t>(voxels[2])};
    if (o.blur > 0.0)
      check_kernel_fits(std::ceil(3.0 * o.blur), shape, fmt::format("--blur {:g} (a Gaussian cut at 3 sigma)", o.blur),
                        "give a smaller --blur or a larger sample");
    io::AtomicOutput out(outdir, ctx.force());

    // --- grains ---
    std::mt19937_64 rng(o.seed);
    const std::vector<double> diameters = sample_diameters(psd, o.solid_fraction * container.volume(), rng);
    spdlog::info("{} {} grains, d50 {:.3f} mm by volume, {:.1f} voxels per d50", diameters.size(), o.grain_shape,
                 volume_median_diameter(diameters) * 1e3, psd.d50 / voxel);
    GrainSetParams gp;
    gp.shape = shape_kind;
    gp.sand.degree = o.sh_degree;
    gp.aspect_ratio = o.aspect_ratio;
    gp.angular.min_facets = o.angular_facets[0];
    gp.angular.max_facets = o.angular_facets[1];
    gp.angular.max_dents = o.angular_dents;
    gp.angular.dent_depth = o.angular_dent_depth;
    gp.angular.roughness = o.angular_roughness;
    gp.angular.roughness_degree = o.angular_roughness_degree;
    gp.voxel_size = voxel;
    gp.seed = o.seed;
    const GrainSet grains = make_grains(gp, diameters, ctx.progress_callback("grain shapes"));
    throw_if_interrupted();
    if (!grains.sh_fit_rms.empty()) {
      const auto [lo_fit, hi_fit] = std::minmax_element(grains.sh_fit_rms.begin(), grains.sh_fit_rms.end());
      double mean_fit = 0.0;
      for (double f : grains.sh_fit_rms) mean_fit += f / static_cast<double>(grains.sh_fit_rms.size());
      spdlog::info("angular grains: the degree-{} SH fit misses the exact (sharp) surface by {:.2f} % of the radius "
                   "RMS on average ({:.2f}-{:.2f} %); the scans and contacts use the exact surface",
                   o.sh_degree, 100.0 * mean_fit, 100.0 * *lo_fit, 100.0 * *hi_fit);
    }
    const auto tables = grains.table_pointers();
    double grain_volume = 0.0;
    for (const auto& t : grains.tables) grain_volume += t.volume();
    spdlog::info("the grains' exact volume fills {:.4f} of the {}", grain_volume / container.volume(), o.container);

    // --- packing (state 0) ---
    PackingParams pp;
    pp.seed = o.seed;
    pp.contact_tolerance = o.contact_tolerance;
    PackingReport report;
    std::vector<std::vector<shape::RadialTable>> smooth(pack_degrees.size());
    std::vector<std::vector<const shape::RadialTable*>> stages;
    for (std::size_t k = 0; k < pack_degrees.size(); ++k) {
      smooth[k] = smoothed_tables(grains, pack_degrees[k], voxel);
      stages.emplace_back();
      for (const auto& t : smooth[k]) stages.back().push_back(&t);
    }
    stages.push_back(tables);
    const std::vector<PackedGrain> packed =
        pack_in_stages(stages, container, pp, &report, ctx.progress_callback("packing"));
    smooth.clear();
    const std::vector<double> shell_edges{0.0, 0.25 * psd.d50, 0.5 * psd.d50, psd.d50, HUGE_VAL};
    const std::vector<double> shells = solid_fraction_by_wall_distance(tables, packed, container, shell_edges);
    spdlog::info("packed: solid fraction {:.4f} (by distance from the walls: {:.3f} within d50/4, {:.3f} d50/4-d50/2, "
                 "{:.3f} d50/2-d50, {:.3f} beyond d50), max overlap {:.3g} um (tolerance {:.3g} um), {} touching "
                 "pairs, {} stages, {} sweeps, {:.1f} s",
                 report.solid_fraction, shells[0], shells[1], shells[2], shells[3], report.max_overlap * 1e6,
                 report.tolerance * 1e6, report.touching_pairs, stages.size(), report.sweeps, report.seconds);
    throw_if_interrupted();

    // --- loading states ---
    LoadingParams lp;
    lp.centre_x = cyl ? 0.0 : 0.5 * container.box_size.x();
    lp.centre_y = cyl ? 0.0 : 0.5 * container.box_size.y();
    lp.height = cyl ? container.height : container.box_size.z();
    lp.radius = cyl ? container.radius : 0.5 * std::min(container.box_size.x(), container.box_size.y());
    lp.bulge = o.bulge;
    lp.band = band;
    lp.band_angle_deg = o.band_angle;
    lp.band_azimuth_deg = o.band_azimuth;
    lp.band_width = band_width;
    lp.band_slip = o.band_slip;
    lp.nonaffine = o.nonaffine;
    lp.rotation_per_shear = o.rotation_per_shear;
    lp.seed = o.seed;
    const auto states = loading_states(lp, packed, o.strains);

    const Vec3 vs{voxel, voxel, voxel};
    const Vec3 origin{lo[2] + 0.5 * voxel, lo[1] + 0.5 * voxel, lo[0] + 0.5 * voxel};
    spdlog::info("scans: {} x {} x {} voxels (z,y,x) at {:.4g} um, {} states", shape[0], shape[1], shape[2],
                 voxel * 1e6, o.strains.size());

    fs::create_directory(out.temp_path());
    const ShRotator rotator(grains.sh_degree);
    nlohmann::json series;
    series["scans"] = nlohmann::json::array();
    for (std::size_t k = 0; k < states.size(); ++k) {
      const double eps = o.strains[k];
      std::vector<PackedGrain> poses = states[k];
      const double height_k = lp.height * (1.0 - eps);
      PackingReport relax_report = report;
      if (k > 0 || eps != 0.0) {
        Container walls = container;
        if (cyl) {
          walls.height = height_k;
          walls.radius = lp.radius * (1.0 + 1.5 * lp.bulge * eps);
        } else {
          walls.box_size.z() = height_k;
        }
        relax_report = relax_grains(tables, poses, walls, pp);
        spdlog::info("state {} (strain {:.4g}): overlaps relaxed in {} sweeps, max overlap {:.3g} um", k, eps,
                     relax_report.sweeps, relax_report.max_overlap * 1e6);
      }
      // Render.
      std::vector<PlacedGrain> placed(poses.size());
      for (std::size_t i = 0; i < poses.size(); ++i)
        placed[i] = {tables[i], poses[i].position, poses[i].orientation, static_cast<std::uint32_t>(i + 1)};
      GrainImages images = render_grains(placed, shape, vs, origin, RenderParams{o.supersample},
                                         ctx.progress_callback("render scan " + std::to_string(k)));
      throw_if_interrupted();
      Volume<float> membrane;
      sp.blur_sigma_vox = o.blur;
      sp.noise = o.noise;
      sp.photons = o.photons;
      sp.ring_amplitude = o.rings;
      sp.beam_hardening = o.beam_hardening;
      sp.axis_x = lp.centre_x;
      sp.axis_y = lp.centre_y;
      sp.field_radius = cyl ? hi[0] : 0.5 * std::hypot(hi[0] - lo[0], hi[1] - lo[1]);
      sp.seed = o.seed * 1000003ull + k;
      if (membrane_t > 0.0) {
        Shell shell;
        shell.inner_radius = [&](double z) { return sample_radius_at(lp, z, eps); };
        shell.thickness = membrane_t;
        shell.z0 = 0.0;
        shell.z1 = height_k;
        membrane = render_shell(shell, shape, vs, origin, RenderParams{o.supersample});
      }
      const Volume<std::uint16_t> scan = simulate_scan(images.fraction, membrane_t > 0.0 ? &membrane : nullptr, sp);
      const fs::path scan_path = out.temp_path() / scan_name("scan", k);
      io::write_volume_file(scan_path, scan, ctx.history(), "1");

      // Ground truth.
      GroundTruth truth;
      truth.scan_index = static_cast<int>(k);
      truth.axial_strain = eps;
      truth.sample_height = height_k;
      truth.sample_radius = lp.radius;
      double sample_volume = 0.0;
      if (cyl) {
        const int nz = 2000;
        for (int s = 0; s < nz; ++s) {
          const double r = sample_radius_at(lp, (s + 0.5) / nz * height_k, eps);
          sample_volume += M_PI * r * r * height_k / nz;
        }
      } else {
        sample_volume = container.box_size.x() * container.box_size.y() * height_k;
      }
      truth.solid_fraction = grain_volume / sample_volume;
      truth.void_ratio = sample_volume / grain_volume - 1.0;
      truth.contact_tolerance = relax_report.tolerance;
      truth.labels = std::move(images.labels);
      truth.poses = poses;
      truth.sh_degree = grains.sh_degree;
      truth.sh_coeffs_body = grains.coeffs_body;
      truth.sh_coeffs.resize(grains.coeffs_body.rows(), grains.coeffs_body.cols());
      truth.sh_invariants.resize(grains.coeffs_body.rows(), grains.sh_degree + 1);
#pragma omp parallel for schedule(dynamic)
      for (Eigen::Index i = 0; i < grains.coeffs_body.rows(); ++i) {
        const Eigen::VectorXd body = grains.coeffs_body.row(i).transpose();
        truth.sh_coeffs.row(i) = rotator.rotate(body, poses[static_cast<std::size_t>(i)].orientation.toRotationMatrix()).transpose();
        truth.sh_invariants.row(i) = shape::sh_invariants(body, grains.sh_degree).transpose();
      }
      for (const auto& st : grains.stats) {
        truth.volume.push_back(st.volume);
        truth.equivalent_diameter.push_back(st.equivalent_diameter);
        truth.sphericity.push_back(st.sphericity);
        truth.aspect_ratio.push_back(st.aspect_ratio);
      }
      truth.contacts = true_contacts(tables, poses, search_gap, relax_report.tolerance, shape_kind == GrainShape::angular);
      const auto touching = std::count_if(truth.contacts.begin(), truth.contacts.end(),
                                          [](const TrueContact& c) { return c.touching; });
      write_ground_truth(out.temp_path() / scan_name("truth", k), truth, ctx.history());
      spdlog::info("scan {}: strain {:.4g}, solid fraction {:.4f} (void ratio {:.4f}), {} touching contacts, {} near",
                   k, eps, truth.solid_fraction, truth.void_ratio, touching, truth.contacts.size() - touching);
      series["scans"].push_back({{"scan", scan_name("scan", k)},
                                 {"truth", scan_name("truth", k)},
                                 {"axial_strain", eps},
                                 {"sample_height_m", height_k},
                                 {"solid_fraction", truth.solid_fraction},
                                 {"void_ratio", truth.void_ratio},
                                 {"grains", poses.size()},
                                 {"touching_contacts", touching},
                                 {"near_contacts", truth.contacts.size() - touching},
                                 {"max_overlap_m", relax_report.max_overlap}});
      throw_if_interrupted();
    }
    series["packing"] = {{"solid_fraction", report.solid_fraction},
                         {"shell_edges_m", std::vector<double>(shell_edges.begin(), shell_edges.end() - 1)},
                         {"shell_solid_fractions", shells},
                         {"max_overlap_m", report.max_overlap},
                         {"sweeps", report.sweeps},
                         {"seconds", report.seconds}};
    series["grains"] = grains.tables.size();
    series["voxels_per_d50"] = psd.d50 / voxel;
    series["shape_zyx"] = shape;
    series["history"] = ctx.history();
    std::ofstream(out.temp_path() / "series.json") << series.dump(2) << "\n";
    std::ofstream(out.temp_path() / "scene.toml") << "# effective scene of this series (ctsynth " << graintwin::version
                                                  << ")\n" << tool.effective_config();
    io::commit_outputs({&out});
  });
}
