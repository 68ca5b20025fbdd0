// A synthetic CT scan series: grains, packing, loading states, scans and ground truth.
#include "graintwin/synth/series.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <numbers>
#include <numeric>
#include <random>

#include "graintwin/core/error.hpp"
#include "graintwin/core/geometry.hpp"
#include "graintwin/core/interrupt.hpp"
#include "graintwin/core/resources.hpp"
#include "graintwin/core/statistics.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/shape/grain_measure.hpp"
#include "graintwin/shape/sh_basis.hpp"
#include "graintwin/synth/ground_truth.hpp"
#include "graintwin/synth/shape_library.hpp"

namespace graintwin::synth {

namespace {

std::string scan_name(const char* stem, std::size_t k) { return fmt::format("{}_{:03d}.h5", stem, k); }

// Image box (m, x y z) that holds the sample in its most bulged state, with the membrane and margin:
// the prescribed bulge's bound (known before any state is made).
struct ImageBox {
  Vec3 lo, hi;
};
ImageBox image_box(const SeriesParams& p) {
  const double eps_max = *std::max_element(p.strains.begin(), p.strains.end());
  if (p.container.kind == Container::Kind::cylinder) {
    const double r_out = p.container.radius * (1.0 + 1.5 * std::max(0.0, p.loading.bulge) * eps_max) +
                         p.membrane_thickness + p.margin;
    return {{-r_out, -r_out, -p.margin}, {r_out, r_out, p.container.height + p.margin}};
  }
  const Eigen::Vector3d& b = p.container.box_size;
  return {{-p.margin, -p.margin, -p.margin}, {b.x() + p.margin, b.y() + p.margin, b.z() + p.margin}};
}

// Simulated states bulge as the mechanics has it: the box around the widest membrane and the
// platens of every state (at least the container with its membrane and margin).
constexpr int kProfileSamples = 200;
ImageBox image_box(const SeriesParams& p, const std::vector<LoadedState>& states) {
  double r_in = p.container.radius, z_lo = 0.0, z_hi = p.container.height;
  for (const LoadedState& s : states) {
    for (int k = 0; k <= kProfileSamples; ++k)
      for (int a = 0; a < kProfileSamples; ++a)
        r_in = std::max(r_in, s.membrane_inner_radius(2.0 * std::numbers::pi * a / kProfileSamples,
                                                      s.base_z + (s.top_z - s.base_z) * k / kProfileSamples));
    z_lo = std::min(z_lo, s.base_z);
    z_hi = std::max(z_hi, s.top_z);
  }
  const double r_out = r_in + p.membrane_thickness + p.margin;
  return {{-r_out, -r_out, z_lo - p.margin}, {r_out, r_out, z_hi + p.margin}};
}

// Volume (m^3) of a loaded sample: its lateral surface integrated between the platens.
double sample_volume(const SeriesParams& p, const LoadedState& s) {
  const double height = s.top_z - s.base_z;
  if (p.container.kind == Container::Kind::box) return p.container.box_size.x() * p.container.box_size.y() * height;
  // Slices of the height, each a polygon of sectors (the prescribed surfaces are round: one sector).
  constexpr int kSlices = 2000;
  const int sectors = s.simulated ? 720 : 1;
  double v = 0.0;
  for (int k = 0; k < kSlices; ++k) {
    const double z = s.base_z + (k + 0.5) / kSlices * height;
    for (int a = 0; a < sectors; ++a) {
      const double r = s.membrane_inner_radius(2.0 * std::numbers::pi * (a + 0.5) / sectors, z);
      v += std::numbers::pi * r * r * height / kSlices / sectors;
    }
  }
  return v;
}

// labels2shapes' criteria of an unreliable radial fit (its defaults), applied to the exact measures.
bool misses_much(const NonStarMeasures& m, double voxel) {
  const shape::MeasureOptions criteria;
  return m.hidden_void_fraction > criteria.max_hidden_void_fraction ||
         m.reentry_depth > criteria.max_reentry_depth_vox * voxel;
}

GrainSet make_grain_set(const SeriesParams& p, const ShapeLibrary* library, std::mt19937_64& rng,
                        const std::function<void(double)>& progress) {
  const double target = p.solid_fraction * p.container.volume();
  if (library)
    return make_library_grains(*library, draw_library_grains(*library, target, rng), p.grains.sand.degree,
                               p.voxel_size, progress);
  const std::vector<double> diameters = sample_diameters(p.psd, target, rng);
  GrainSetParams gp = p.grains;
  gp.voxel_size = p.voxel_size;
  gp.seed = p.seed;
  return make_grains(gp, diameters, progress);
}

void log_grains(const SeriesParams& p, const GrainSet& grains, const ShapeLibrary* library, double d50, double d_ref) {
  spdlog::info("{} grains{}, d50 {:.3f} mm by volume, {:.1f} voxels per d50", grains.tables.size(),
               library ? fmt::format(" drawn from a library of {} ({} left out)", library->grains.size(), library->left_out)
                       : "",
               d50 * 1e3, d_ref / p.voxel_size);
  if (!grains.sh_fit_rms.empty()) {
    const auto [lo, hi] = std::minmax_element(grains.sh_fit_rms.begin(), grains.sh_fit_rms.end());
    double mean = 0.0;
    for (double f : grains.sh_fit_rms) mean += f / static_cast<double>(grains.sh_fit_rms.size());
    spdlog::info("the degree-{} SH fit misses the exact surface by {:.2f} % of the radius RMS on average "
                 "({:.2f}-{:.2f} %); the scans and contacts use the exact surface",
                 grains.sh_degree, 100.0 * mean, 100.0 * *lo, 100.0 * *hi);
  }
  if (!grains.solids.empty()) {
    const auto much = std::count_if(grains.non_star.begin(), grains.non_star.end(),
                                    [&](const NonStarMeasures& m) { return misses_much(m, p.voxel_size); });
    const auto some = std::count_if(grains.non_star.begin(), grains.non_star.end(),
                                    [](const NonStarMeasures& m) { return m.multi_exit_fraction > 0.0; });
    spdlog::info("{} grains are not star-shaped about their centroid; for {} a radial description misses more than 1 % "
                 "of the volume or reaches more than a voxel off the surface",
                 some, much);
  }
}

// The per-scan scanner: axis and field radius of the cupping and rings, seed of the noise.
ScannerParams scanner_for_scan(const SeriesParams& p, const LoadingParams& lp, const ImageBox& box, std::size_t k) {
  ScannerParams sp = p.scanner;
  sp.axis_x = lp.centre_x;
  sp.axis_y = lp.centre_y;
  sp.field_radius = p.container.kind == Container::Kind::cylinder
                        ? box.hi[0]
                        : 0.5 * std::hypot(box.hi[0] - box.lo[0], box.hi[1] - box.lo[1]);
  sp.seed = p.seed * 1000003ull + k;
  return sp;
}


// The prescribed kinematics' parameters for this sample: its axis, height and radius, a band width
// of 0 made 10 d50.
LoadingParams loading_params(const SeriesParams& p, double d_ref) {
  const bool cyl = p.container.kind == Container::Kind::cylinder;
  LoadingParams lp = p.loading;
  lp.centre_x = cyl ? 0.0 : 0.5 * p.container.box_size.x();
  lp.centre_y = cyl ? 0.0 : 0.5 * p.container.box_size.y();
  lp.height = cyl ? p.container.height : p.container.box_size.z();
  lp.radius = cyl ? p.container.radius : 0.5 * std::min(p.container.box_size.x(), p.container.box_size.y());
  if (lp.band_width == 0.0) lp.band_width = 10.0 * d_ref;
  lp.seed = p.seed;
  return lp;
}

// The deepest overlap (of d50) a prescribed state's kinematics may make and still be relaxed in
// one go. Measured: 147-199 um (0.27-0.36 d50) relaxed in a few hundred sweeps at 4 to 10 mm; 376 um
// (0.68 d50: 5 % strain in a 10 mm cylinder, whose random grain motion grows with the height)
// stayed near 290 um.
constexpr double kRelaxableOverlapOfD50 = 0.35;

// The deepest overlap (m) of grains at `poses`, 0 if none touch.
double deepest_overlap(const std::vector<const shape::RadialTable*>& tables, const std::vector<PackedGrain>& poses) {
  double deepest = 0.0;
  for (const GrainContact& c : find_contacts(tables, poses, 0.0)) deepest = std::max(deepest, c.contact.overlap);
  return deepest;
}

// The prescribed states: the kinematics moves the packed grains, then their overlaps are relaxed
// inside the state's walls (the packing itself where the strain is 0). A state whose kinematics
// overlap grains deeper than kRelaxableOverlapOfD50 is reached from the state before, relaxed, in
// steps of its kinematic increment (positions in equal parts, rotations by equal angles), each
// relaxed inside the walls of its strain.
std::vector<LoadedState> prescribed_states(const SeriesParams& p, const LoadingParams& lp,
                                           const std::vector<const shape::RadialTable*>& tables,
                                           const std::vector<PackedGrain>& packed, const PackingParams& pp,
                                           const PackingReport& packing, double d50) {
  const bool cyl = p.container.kind == Container::Kind::cylinder;
  if (!cyl && (lp.band != ShearBand::none || lp.bulge != 0.0) && p.strains.size() > 1)
    spdlog::info("box container: loading uses the box centre as the sample axis");
  std::vector<std::vector<PackedGrain>> poses = loading_states(lp, packed, p.strains);
  auto walls_at = [&](double eps) {
    Container walls = p.container;
    if (cyl) {
      walls.height = lp.height * (1.0 - eps);
      walls.radius = lp.radius * (1.0 + 1.5 * lp.bulge * eps);
    } else {
      walls.box_size.z() = lp.height * (1.0 - eps);
    }
    return walls;
  };
  std::vector<LoadedState> states(poses.size());
  std::vector<PackedGrain> kinematics_before = packed;  // the state before's poses as the kinematics put them
  double eps_before = 0.0;
  for (std::size_t k = 0; k < poses.size(); ++k) {
    const double eps = p.strains[k];
    LoadedState& s = states[k];
    s.axial_strain = eps;
    s.poses = std::move(poses[k]);
    s.top_z = lp.height * (1.0 - eps);
    s.membrane_inner_radius = [lp, eps](double, double z) { return sample_radius_at(lp, z, eps); };
    PackingReport relaxed = packing;
    if (k > 0 || eps != 0.0) {
      const std::vector<PackedGrain> kinematics = s.poses;
      const double deepest = deepest_overlap(tables, kinematics);
      const int steps = static_cast<int>(std::ceil(deepest / (kRelaxableOverlapOfD50 * d50)));
      if (steps <= 1) {
        relaxed = relax_grains(tables, s.poses, walls_at(eps), pp, log_packing_status(fmt::format("state {}: relaxation", k)));
      } else {
        spdlog::info("state {}: its kinematics overlap grains by up to {:.0f} um, {:.2f} d50: reached from state {} in "
                     "{} relaxed steps",
                     k, deepest * 1e6, deepest / d50, k == 0 ? std::string("the packing") : std::to_string(k - 1), steps);
        s.poses = k > 0 ? states[k - 1].poses : packed;
        int sweeps = 0;
        for (int step = 1; step <= steps; ++step) {
          const double share = 1.0 / steps;
          for (std::size_t i = 0; i < s.poses.size(); ++i) {
            s.poses[i].position += share * (kinematics[i].position - kinematics_before[i].position);
            const Eigen::Quaterniond turn = kinematics[i].orientation * kinematics_before[i].orientation.inverse();
            s.poses[i].orientation = (Eigen::Quaterniond::Identity().slerp(share, turn) * s.poses[i].orientation).normalized();
          }
          relaxed = relax_grains(tables, s.poses, walls_at(eps_before + step * share * (eps - eps_before)), pp,
                                 log_packing_status(fmt::format("state {}: relaxation step {} of {}", k, step, steps)));
          sweeps += relaxed.sweeps;
          throw_if_interrupted();
        }
        relaxed.sweeps = sweeps;
      }
      spdlog::info("state {} (strain {:.4g}): overlaps relaxed in {} sweeps, max overlap {:.3g} um", k, eps,
                   relaxed.sweeps, relaxed.max_overlap * 1e6);
      kinematics_before = kinematics;
    }
    eps_before = eps;
    s.contact_tolerance = relaxed.tolerance;
    s.max_overlap = relaxed.max_overlap;
    s.relax_sweeps = relaxed.sweeps;
    throw_if_interrupted();
  }
  return states;
}

// A simulated state's contact forces on the truth's contacts: every pair that carries a force
// touches, whatever its overlap; a pair the geometric search missed is reported.
void attach_forces(GroundTruth& truth, const LoadedState& state) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, Eigen::Vector3d> force;
  for (const PairForce& f : state.forces) force[{f.low, f.high}] = f.force;
  truth.contact_force.assign(truth.contacts.size(), Eigen::Vector3d::Zero());
  std::size_t found = 0;
  for (std::size_t c = 0; c < truth.contacts.size(); ++c) {
    const auto it = force.find({truth.contacts[c].low, truth.contacts[c].high});
    if (it == force.end()) continue;
    truth.contact_force[c] = it->second;
    truth.contacts[c].touching = true;
    ++found;
  }
  if (found < force.size())
    spdlog::warn("{} of {} loaded pairs of the simulation are farther apart than the contact search; their forces are "
                 "not in the truth (give a larger --contact-search)",
                 force.size() - found, force.size());
}

}  // namespace

SeriesSummary make_series(const SeriesParams& p, const std::filesystem::path& dir,
                          const std::vector<std::string>& history,
                          const std::function<std::function<void(double)>(const std::string&)>& progress) {
  if (p.strains.empty()) throw UsageError("--strains needs at least one value (0 for an unloaded scan)");
  check_grey_levels(p.scanner, p.membrane_thickness > 0.0);
  const bool from_library = p.grains.shape == GrainShape::library;
  std::unique_ptr<ShapeLibrary> library;
  if (from_library) library = std::make_unique<ShapeLibrary>(read_shape_library(p.library_shapes, p.library_labels));

  // --- image geometry: the bound of the most bulged state, to check before any heavy work ---
  const ImageBox bound = image_box(p);
  const double voxel = p.voxel_size;
  const Vec3 voxels{std::ceil((bound.hi[2] - bound.lo[2]) / voxel), std::ceil((bound.hi[1] - bound.lo[1]) / voxel),
                    std::ceil((bound.hi[0] - bound.lo[0]) / voxel)};  // z y x, as reals until they are known to fit
  // What the series holds at once: the grains' tables (and one smoothed copy while a packing stage
  // runs, unless the tables are SH surfaces, freed meanwhile) and one scan being rendered.
  const double target = p.solid_fraction * p.container.volume();
  double mean_grain_volume = 0.0, typical_d = p.psd.d50;
  if (library) {
    for (const auto& g : library->grains) mean_grain_volume += g.volume / static_cast<double>(library->grains.size());
    typical_d = equivalent_diameter(mean_grain_volume);
  }
  const double grains_expected = library ? target / mean_grain_volume : expected_grain_count(p.psd, target);
  const double scan_bytes = voxels[0] * voxels[1] * voxels[2] * kScanBytesPerVoxel;
  const bool tables_freed_while_smoothed = !library && tables_are_sh_surfaces(p.grains.shape);
  const double grain_table_bytes = grains_expected * grain_bytes(typical_d, voxel, p.grains.sand.degree) *
                                   (p.pack_degrees.empty() || tables_freed_while_smoothed ? 1.0 : 2.0);
  // The advice names first what dominates: millions of tiny grains are fixed by the PSD, not the voxels.
  check_memory(scan_bytes + grain_table_bytes, "ctsynth",
               fmt::format("scans of {:.3g} x {:.3g} x {:.3g} voxels (z, y, x) and about {:.3g} grains", voxels[0],
                           voxels[1], voxels[2], grains_expected),
               grain_table_bytes > scan_bytes
                   ? "give larger grains (--d-min, --d50, --d-max), a smaller sample (--diameter, --height or --box) or larger voxels (--voxel-size)"
                   : "make the sample smaller (--diameter, --height or --box), the voxels larger (--voxel-size) or the grains larger (--d-min, --d50, --d-max)");
  const bool cylinder = p.container.kind == Container::Kind::cylinder;
  check_nonaffine_correlation(p.loading.nonaffine_correlation,
                              cylinder ? Eigen::Vector3d(2 * p.container.radius, 2 * p.container.radius, p.container.height)
                                       : p.container.box_size);
  if (p.scanner.blur_sigma_vox > 0.0)
    check_kernel_fits(std::ceil(3.0 * p.scanner.blur_sigma_vox),
                      Shape3{static_cast<std::size_t>(voxels[0]), static_cast<std::size_t>(voxels[1]),
                             static_cast<std::size_t>(voxels[2])},
                      fmt::format("--blur {:g} (a Gaussian cut at 3 sigma)", p.scanner.blur_sigma_vox),
                      "give a smaller --blur or a larger sample");

  // --- grains ---
  std::mt19937_64 rng(p.seed);
  GrainSet grains = make_grain_set(p, library.get(), rng, progress("grain shapes"));
  throw_if_interrupted();
  // The grains' d50 from their exact volumes, the truth's (as validate reads it). Lengths in units
  // of d50 (wall shells, the band width) take the PSD's d50, or the library's drawn one.
  std::vector<double> grain_volumes;
  for (const auto& st : grains.stats) grain_volumes.push_back(st.volume);
  const double d50 = d50_of_volumes(grain_volumes);
  const double d_ref = library ? d50 : p.psd.d50;
  log_grains(p, grains, library.get(), d50, d_ref);
  const auto solids = grains.solid_pointers();
  const double grain_volume = std::accumulate(grain_volumes.begin(), grain_volumes.end(), 0.0);
  spdlog::info("the grains' exact volume fills {:.4f} of the {}", grain_volume / p.container.volume(),
               container_kind_name(p.container.kind));

  // --- packing (state 0) ---
  // How long a packing takes is not known in advance (it grows and relaxes until its overlaps
  // settle), so it logs status lines rather than a share done.
  PackingParams pp = p.packing;
  pp.seed = p.seed;
  PackingReport report;
  // The smoothed stages' tables are made as each stage starts, so one stage's copy lives at a time.
  // Tables that are the grains' SH surfaces are freed while the smoothed stages run and made again
  // for the last one, bit for bit: one table per grain at any time (a paper-sized sample's 26 000
  // grains hold 8.7 GB of tables).
  std::vector<shape::RadialTable> smooth;
  const std::size_t stage_count = p.pack_degrees.size() + 1;
  const bool free_tables = stage_count > 1 && grains.tables_are_sh_surfaces;
  if (free_tables) grains.tables = {};
  auto stage_shapes = [&](std::size_t k) {
    smooth = {};  // the last stage's copy goes before the next is made
    if (k + 1 == stage_count) {
      if (free_tables)
        grains.tables = smoothed_tables(grains, grains.sh_degree, voxel,
                                        progress(fmt::format("packing stage {}: the grains' exact tables", k + 1)));
      return grains.table_pointers();
    }
    const int degree = p.pack_degrees[k];
    smooth = smoothed_tables(grains, degree, voxel,
                             progress(fmt::format("packing stage {}: grains low-passed to SH degree {}", k + 1, degree)));
    std::vector<const shape::RadialTable*> shapes;
    for (const auto& t : smooth) shapes.push_back(&t);
    return shapes;
  };
  const std::vector<PackedGrain> packed =
      pack_in_stages(stage_count, stage_shapes, p.container, pp, &report, log_packing_status("packing"));
  const auto tables = grains.table_pointers();
  const std::vector<double> shell_edges{0.0, 0.25 * d_ref, 0.5 * d_ref, d_ref, HUGE_VAL};
  const std::vector<double> shells = solid_fraction_by_wall_distance(tables, packed, p.container, shell_edges);
  spdlog::info("packed: solid fraction {:.4f} (by distance from the walls: {:.3f} within d50/4, {:.3f} d50/4-d50/2, "
               "{:.3f} d50/2-d50, {:.3f} beyond d50), max overlap {:.3g} um (tolerance {:.3g} um), {} touching "
               "pairs, {} stages, {} sweeps, {:.1f} s",
               report.solid_fraction, shells[0], shells[1], shells[2], shells[3], report.max_overlap * 1e6,
               report.tolerance * 1e6, report.touching_pairs, stage_count, report.sweeps, report.seconds);
  throw_if_interrupted();

  // --- loading states ---
  const LoadingParams lp = loading_params(p, d_ref);
  SimulatedLoading loaded;
  if (p.simulate)
    loaded = p.simulate(grains, packed, p.container, p.strains, dir, history, progress);
  else
    loaded.states = prescribed_states(p, lp, tables, packed, pp, report, d_ref);
  const std::vector<LoadedState>& states = loaded.states;
  throw_if_interrupted();
  // The scans' grid: fixed for the series, from the bound (prescribed) or the states (simulated).
  const ImageBox box = p.simulate ? image_box(p, states) : bound;
  const Shape3 shape{static_cast<std::size_t>(std::ceil((box.hi[2] - box.lo[2]) / voxel)),
                     static_cast<std::size_t>(std::ceil((box.hi[1] - box.lo[1]) / voxel)),
                     static_cast<std::size_t>(std::ceil((box.hi[0] - box.lo[0]) / voxel))};
  const Vec3 vs{voxel, voxel, voxel};
  const Vec3 origin{box.lo[2] + 0.5 * voxel, box.lo[1] + 0.5 * voxel, box.lo[0] + 0.5 * voxel};
  spdlog::info("scans: {} x {} x {} voxels (z,y,x) at {:.4g} um, {} states", shape[0], shape[1], shape[2],
               voxel * 1e6, p.strains.size());
  const double search_gap = p.contact_search > 0.0 ? p.contact_search : 2.0 * voxel;
  const bool separating = p.grains.shape == GrainShape::angular || from_library;

  const ShRotator rotator(grains.sh_degree);
  namespace sr = schema::series_record;
  nlohmann::json series;
  series[sr::scans] = nlohmann::json::array();
  for (std::size_t k = 0; k < states.size(); ++k) {
    const LoadedState& state = states[k];
    const std::vector<PackedGrain>& poses = state.poses;
    const double eps = state.axial_strain;
    const double height_k = state.top_z - state.base_z;
    // Render.
    std::vector<PlacedGrain> placed(poses.size());
    for (std::size_t i = 0; i < poses.size(); ++i)
      placed[i] = {tables[i], poses[i].position, poses[i].orientation, static_cast<std::uint32_t>(i + 1), solids[i]};
    GrainImages images = render_grains(placed, shape, vs, origin, p.render, progress("render scan " + std::to_string(k)));
    throw_if_interrupted();
    {  // the membrane's image and the scan go before the truth is measured
      Volume<float> membrane;
      if (p.membrane_thickness > 0.0) {
        Shell shell;
        shell.inner_radius = state.membrane_inner_radius;
        shell.thickness = p.membrane_thickness;
        shell.z0 = state.base_z;
        shell.z1 = state.top_z;
        membrane = render_shell(shell, shape, vs, origin, p.render, progress(fmt::format("render scan {}: membrane", k)));
      }
      const Volume<std::uint16_t> scan = simulate_scan(
          std::move(images.fraction), p.membrane_thickness > 0.0 ? &membrane : nullptr, scanner_for_scan(p, lp, box, k));
      io::write_volume_file(dir / scan_name("scan", k), scan, history, "1");
    }

    // Ground truth.
    GroundTruth truth;
    truth.scan_index = static_cast<int>(k);
    truth.axial_strain = eps;
    truth.sample_height = height_k;
    truth.sample_radius = lp.radius;
    const double volume_k = sample_volume(p, state);
    truth.solid_fraction = grain_volume / volume_k;
    truth.void_ratio = volume_k / grain_volume - 1.0;
    truth.contact_tolerance = state.contact_tolerance;
    truth.labels = std::move(images.labels);
    truth.poses = poses;
    truth.sh_degree = grains.sh_degree;
    truth.sh_coeffs_body = grains.coeffs_body;
    truth.sh_coeffs.resize(grains.coeffs_body.rows(), grains.coeffs_body.cols());
    truth.sh_invariants.resize(grains.coeffs_body.rows(), grains.sh_degree + 1);
#pragma omp parallel for schedule(dynamic)
    for (Eigen::Index i = 0; i < grains.coeffs_body.rows(); ++i) {
      const Eigen::VectorXd body = grains.coeffs_body.row(i).transpose();
      truth.sh_coeffs.row(i) =
          rotator.rotate(body, poses[static_cast<std::size_t>(i)].orientation.toRotationMatrix()).transpose();
      truth.sh_invariants.row(i) = shape::sh_invariants(body, grains.sh_degree).transpose();
    }
    for (const auto& st : grains.stats) {
      truth.volume.push_back(st.volume);
      truth.equivalent_diameter.push_back(st.equivalent_diameter);
      truth.sphericity.push_back(st.sphericity);
      truth.aspect_ratio.push_back(st.aspect_ratio);
    }
    if (!grains.solids.empty()) truth.non_star = grains.non_star;
    truth.contacts = true_contacts(tables, poses, search_gap, state.contact_tolerance, separating,
                                   grains.solids.empty() ? std::vector<const GrainSolid*>{} : solids);
    if (state.simulated) {
      truth.simulated = true;
      attach_forces(truth, state);
      truth.stress_ratio = state.stress_ratio;
      truth.volumetric_strain = state.volumetric_strain;
      truth.loading_curve = loaded.curve;
    }
    const auto touching =
        std::count_if(truth.contacts.begin(), truth.contacts.end(), [](const TrueContact& c) { return c.touching; });
    write_ground_truth(dir / scan_name("truth", k), truth, history);
    spdlog::info("scan {}: strain {:.4g}, solid fraction {:.4f} (void ratio {:.4f}), {} touching contacts, {} near", k,
                 eps, truth.solid_fraction, truth.void_ratio, touching, truth.contacts.size() - touching);
    nlohmann::json row{{sr::scan, scan_name("scan", k)},
                       {sr::truth, scan_name("truth", k)},
                       {sr::axial_strain, eps},
                       {"sample_height_m", height_k},
                       {"solid_fraction", truth.solid_fraction},
                       {"void_ratio", truth.void_ratio},
                       {"grains", poses.size()},
                       {"touching_contacts", touching},
                       {"near_contacts", truth.contacts.size() - touching},
                       {"max_overlap_m", state.max_overlap}};
    if (state.simulated) {
      row["stress_ratio"] = state.stress_ratio;
      row["volumetric_strain"] = state.volumetric_strain;
      row["force_pairs"] = state.forces.size();
    }
    series[sr::scans].push_back(row);
    throw_if_interrupted();
  }
  SeriesSummary summary;
  summary.grains = grains.diameters.size();
  summary.non_star_grains = static_cast<std::size_t>(std::count_if(
      grains.non_star.begin(), grains.non_star.end(), [&](const NonStarMeasures& m) { return misses_much(m, voxel); }));
  summary.packed_solid_fraction = report.solid_fraction;
  series[sr::packing] = {{"solid_fraction", report.solid_fraction},
                       {"shell_edges_m", std::vector<double>(shell_edges.begin(), shell_edges.end() - 1)},
                       {"shell_solid_fractions", shells},
                       {"max_overlap_m", report.max_overlap},
                       {"sweeps", report.sweeps},
                       {"seconds", report.seconds}};
  series[sr::loading] = enum_name(kLoadingKindNames, p.simulate ? LoadingKind::simulated : LoadingKind::prescribed);
  series["grains"] = summary.grains;
  if (!grains.solids.empty()) series["non_star_grains"] = summary.non_star_grains;
  series["voxels_per_d50"] = d_ref / voxel;
  series["shape_zyx"] = shape;
  series[sr::history] = history;
  std::ofstream(dir / sr::file_name) << series.dump(2) << "\n";
  return summary;
}

}  // namespace graintwin::synth
