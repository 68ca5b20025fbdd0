// ctsynth: synthetic CT scan series of a sand sample under triaxial load, with exact ground truth.
//   ctsynth pipelines/scenes/sand_small.toml out/            (one scan per entry of `strains`)
//   ctsynth scene.toml out/ --noise 0.1 --seed 7               (options override the scene file)
#include <fstream>

#include "graintwin/cli/option_checks.hpp"
#include "graintwin/cli/tool.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/strings.hpp"
#include "graintwin/experiment/triaxial_loading.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/synth/series.hpp"
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
  double non_star_share = 0.0;
  std::string library, library_labels;
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
  std::string nonaffine_correlation = "0";
  std::string contact_search = "";  // default 2 voxels
  std::string loading = "prescribed";
  std::string triaxial_scene;
  double simulated_surface_nodes = 500.0;
  bool keep_simulation = true;
};

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


// The series' parameters from the options, every one checked before heavy work.
SeriesParams series_params(const Options& o) {
  SeriesParams p;
  p.seed = o.seed;
  p.grains.shape = parse_grain_shape(o.grain_shape);
  if (o.angular_facets.size() != 2 || o.angular_facets[0] > o.angular_facets[1])
    throw UsageError("--angular-facets needs MIN,MAX with MIN <= MAX, e.g. 8,20");
  p.grains.sand.degree = o.sh_degree;
  p.grains.aspect_ratio = o.aspect_ratio;
  p.grains.angular.min_facets = o.angular_facets[0];
  p.grains.angular.max_facets = o.angular_facets[1];
  p.grains.angular.max_dents = o.angular_dents;
  p.grains.angular.dent_depth = o.angular_dent_depth;
  p.grains.angular.roughness = o.angular_roughness;
  p.grains.angular.roughness_degree = o.angular_roughness_degree;
  p.grains.non_star_share = o.non_star_share;
  if (o.non_star_share > 0.0 && p.grains.shape != GrainShape::angular)
    throw UsageError("--non-star-share applies to angular grains only; give --grain-shape angular or --non-star-share 0");
  const bool library = p.grains.shape == GrainShape::library;
  if (library != !o.library.empty() || library != !o.library_labels.empty())
    throw UsageError(library ? "--grain-shape library needs --library SHAPES.h5 and --library-labels LABELS.h5"
                             : "--library and --library-labels go with --grain-shape library");
  p.library_shapes = o.library;
  p.library_labels = o.library_labels;
  p.psd = {parse_length_m(o.d_min, "--d-min"), parse_length_m(o.d50, "--d50"), parse_length_m(o.d_max, "--d-max"),
           o.psd_sigma};
  p.psd.validate();
  p.voxel_size = parse_length_m(o.voxel_size, "--voxel-size");
  p.container.kind = parse_container_kind(o.container);
  if (p.container.kind == Container::Kind::cylinder) {
    p.container.radius = 0.5 * parse_length_m(o.diameter, "--diameter");
    p.container.height = parse_length_m(o.height, "--height");
  } else {
    const auto parts = split(o.box, ',');
    if (parts.size() != 3) throw UsageError("--box needs three lengths X,Y,Z, e.g. 4mm,4mm,6mm");
    for (int a = 0; a < 3; ++a) p.container.box_size[a] = cli::parse_length_in(parts[a], "--box", 10e-6, 1.0);
  }
  p.solid_fraction = o.solid_fraction;
  p.packing.contact_tolerance = o.contact_tolerance;
  if (p.grains.shape == GrainShape::sand || p.grains.shape == GrainShape::angular || library)
    p.pack_degrees = parse_pack_degrees(o.pack_degrees, o.sh_degree);
  p.membrane_thickness = p.container.kind == Container::Kind::cylinder && o.membrane_thickness != "0"
                             ? parse_length_m(o.membrane_thickness, "--membrane-thickness")
                             : 0.0;
  p.margin = o.margin_vox * p.voxel_size;
  p.render.supersample = o.supersample;
  p.scanner.grey_void = o.grey_void;
  p.scanner.grey_grain = o.grey_grain;
  p.scanner.grey_membrane = o.grey_membrane;
  p.scanner.uint16_scale = o.grey_scale;
  p.scanner.uint16_offset = o.grey_offset;
  p.scanner.blur_sigma_vox = o.blur;
  p.scanner.noise = o.noise;
  p.scanner.photons = o.photons;
  p.scanner.ring_amplitude = o.rings;
  p.scanner.beam_hardening = o.beam_hardening;
  check_grey_levels(p.scanner, p.membrane_thickness > 0.0);
  if (o.strains.empty()) throw UsageError("--strains needs at least one value (0 for an unloaded scan)");
  p.strains = o.strains;
  p.loading.bulge = o.bulge;
  p.loading.band = parse_enum(kShearBandNames, o.band, "--band");
  p.loading.band_angle_deg = o.band_angle;
  p.loading.band_azimuth_deg = o.band_azimuth;
  p.loading.band_width = o.band_width.empty() ? 0.0 : parse_length_m(o.band_width, "--band-width");
  p.loading.band_slip = o.band_slip;
  p.loading.nonaffine = o.nonaffine;
  p.loading.nonaffine_correlation = parse_signed_length_m(o.nonaffine_correlation, "--nonaffine-correlation");
  p.loading.rotation_per_shear = o.rotation_per_shear;
  p.contact_search = o.contact_search.empty() ? 0.0 : parse_length_m(o.contact_search, "--contact-search");
  const LoadingKind loading = parse_enum(kLoadingKindNames, o.loading, "--loading");
  if (loading == LoadingKind::simulated) {
    if (o.triaxial_scene.empty())
      throw UsageError("--loading simulated needs --triaxial-scene, e.g. pipelines/scenes/triaxial.toml");
    experiment::check_loading_inputs(p);
    experiment::TriaxialLoadingParams tp;
    tp.scene = o.triaxial_scene;
    experiment::check_loading_scene(tp.scene, p.container, p.membrane_thickness);
    io::declare_input(tp.scene);  // an input: no output may replace it, even with --force
    tp.size.surface_nodes = o.simulated_surface_nodes;
    tp.keep_results = o.keep_simulation;
    tp.membrane_thickness = p.membrane_thickness;
    p.simulate = experiment::triaxial_loading(tp);
  } else if (!o.triaxial_scene.empty()) {
    throw UsageError("--triaxial-scene drives --loading simulated only; give both or neither");
  }
  return p;
}

// The options, each a scene key of the same name, checked against the range --help shows
// (docs/conventions.md, "Option ranges").
void add_options(cli::Tool& tool, Options& o) {
  auto& app = tool.cli();
  using cli::closed, cli::above, cli::number_in, cli::whole_number_in, cli::length_in;
  const auto grain_size = length_in(1e-6, 0.1);       // grain diameters: micrometres to centimetres
  const auto sample_size = length_in(10e-6, 1.0);     // container dimensions
  const auto grey_level = number_in(closed(0, 10));   // grey levels, in units of the uint16 scale
  app.add_option("--seed", o.seed, "Random seed (same seed, same bytes)")->capture_default_str();
  app.add_option("--grain-shape", o.grain_shape,
                 "sphere, ellipsoid, sand (smooth SH grains), angular (random convex polyhedra with sharp edges, "
                 "flat facets, dents and roughness; --non-star-share of them with an undercut) or library "
                 "(the grains of a segmented scan: --library and --library-labels)")
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
  app.add_option("--non-star-share", o.non_star_share,
                 "Angular grains: share drawn with an undercut (a flat cavity, 0.6 of the radius across and 0.35 high, "
                 "its centre 0.35 of the radius below the surface, tilted 35 degrees so that it opens on one side and "
                 "lies under a roof of grain on the other), so that they are not star-shaped about their centroid")
      ->check(number_in(closed(0, 1)))->capture_default_str();
  app.add_option("--library", o.library,
                 "Library grains: the kind=shapes file of a segmented scan; its grains are drawn at random (whole "
                 "grains only: those cut by the field of view, small or with the centroid outside are left out) "
                 "at their own size until --solid-fraction is reached; the PSD options are not used");
  app.add_option("--library-labels", o.library_labels,
                 "Library grains: the kind=labels file the --library shapes were measured from (the grains' voxels)");
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
  app.add_option("--nonaffine-correlation", o.nonaffine_correlation,
                 "Correlation length of that motion (0: each grain draws its own; a length such as 2mm: a smooth random "
                 "field over it, so neighbours move together and overlap less; about 5 d50 keeps a tall sample's states "
                 "cheap to relax)")
      ->capture_default_str();
  app.add_option("--rotation-per-shear", o.rotation_per_shear, "Grain rotation (rad) per unit local shear")
      ->check(number_in(closed(-10, 10, "rad")))->capture_default_str();
  app.add_option("--loading", o.loading,
                 "prescribed: the states are kinematics (compression, bulge, shear band, nonaffine motion; overlaps "
                 "relaxed); simulated: fdemrun's triaxial test of the packed grains (rigid meshes of their exact SH "
                 "surfaces) gives the states at the --strains, read as log strains from the start of shearing (sphere, ellipsoid and sand grains in a cylinder)")
      ->capture_default_str();
  app.add_option("--triaxial-scene", o.triaxial_scene,
                 "--loading simulated: the fdemrun scene of the test (its [triaxial] and [run] tables; its target and "
                 "frame strains are set from --strains, its model is the packed grains), e.g. pipelines/scenes/triaxial.toml");
  app.add_option("--simulated-surface-nodes", o.simulated_surface_nodes,
                 "--loading simulated: surface nodes of each grain's rigid mesh")
      ->check(number_in(closed(20, 1e5)))->capture_default_str();
  app.add_flag("--keep-simulation,!--drop-simulation", o.keep_simulation,
               "--loading simulated: keep the test's results as simulation.h5 (frames, series; kind=fdem_results), or "
               "drop them: the truth files hold the stress-strain curve either way")
      ->capture_default_str();
  app.add_option("--contact-search", o.contact_search, "Record pairs closer than this as near-contacts (default 2 voxels)")
      ->check(length_in(1e-9, 0.01));
  tool.set_examples({"ctsynth pipelines/scenes/sand_small.toml runs/sand_small_truth",
                     "ctsynth pipelines/scenes/sand_small.toml out --grain-shape sphere --noise 0.1 --strains 0,0.01",
                     "ctsynth scene.toml out --container box --box 3mm,3mm,3mm --band none",
                     "ctsynth sample_volumes/sand_angular/scene.toml out --non-star-share 0.3",
                     "ctsynth scene.toml out --grain-shape library --library runs/soil_crop/shapes_000.h5 "
                     "--library-labels runs/soil_crop/labels_000.h5"});

}

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool("ctsynth",
                 "Make a synthetic CT scan series of a dense sand sample under triaxial load, with exact ground "
                 "truth: grains (spheres, ellipsoids, random spherical-harmonic sand shapes, Ottawa-like by "
                 "default, or angular crushed-quartz-like polyhedra with dents and roughness) sized from a PSD and packed densely in a cylinder or box (or grains drawn from a segmented scan's shape library), prescribed loading states "
                 "(axial compression, bulging, shear band with nonaffine motion and grain rotations, overlaps "
                 "relaxed), partial-volume rendering with blur, noise, rings and cupping, and per scan a "
                 "kind=volume scan_NNN.h5 plus a kind=ground_truth truth_NNN.h5. Every scene key is an option "
                 "of the same name; options given on the command line override the scene file. Sand and angular grains pack "
                 "with the roughness off, then on (--pack-degrees). Grains that are not star-shaped about their centroid "
                 "(angular grains with an undercut, library grains) are packed and searched for contacts through their star "
                 "hull and rendered from their solid; their truth files say what a radial description misses of them. Limit: in a cylinder 6.5 d50 wide they jam near 0.58 "
                 "solid fraction (the bundled series packs 0.5804; 0.582 jammed with another draw): the loose layer at "
                 "the walls costs the most, wider samples pack denser. The loading states are prescribed kinematics, or with "
                 "--loading simulated fdemrun's triaxial test of the packed grains: scans of a physically consistent "
                 "motion, with each pair's contact force and the stress-strain curve (simulation.h5) as truth.");
  Options o;
  fs::path outdir, scene;
  tool.use_positional_config("scene", scene, "Scene file (TOML, keys = option names below)");
  tool.add_output("outdir", outdir, "Output folder (created; refused if it exists, unless --force)");
  add_options(tool, o);
  return tool.run(argc, argv, [&](cli::RunContext& ctx) {
    const SeriesParams params = series_params(o);
    if (params.grains.shape == GrainShape::library) {  // their histories carry on; no output may replace them
      ctx.add_input_history(io::open_kind(params.library_shapes, schema::kind::shapes, "pass the output of labels2shapes"));
      ctx.add_input_history(io::open_kind(params.library_labels, schema::kind::labels, "pass the output of ct2labels"));
    }
    io::AtomicOutput out(outdir, ctx.force());
    fs::create_directory(out.temp_path());
    make_series(params, out.temp_path(), ctx.history(),
                [&](const std::string& step) { return ctx.progress_callback(step); });
    std::ofstream(out.temp_path() / "scene.toml") << "# effective scene of this series (ctsynth " << graintwin::version
                                                  << ")\n" << tool.effective_config();
    io::commit_outputs({&out});
  });
}
