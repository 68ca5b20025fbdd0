#include "graintwin/mesh/twin.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <tuple>
#include <utility>

#include "graintwin/core/error.hpp"
#include "graintwin/core/interrupt.hpp"
#include "graintwin/io/schema.hpp"

namespace graintwin::mesh {

bool ScanCylinder::bounded() const { return std::isfinite(radius) && radius > 0; }

InscribedGrains inscribed_grains(const std::vector<shape::GrainShape>& grains, const Volume<std::uint32_t>& labels,
                                 double membrane_thickness) {
  InscribedGrains in;
  in.cylinder = inscribed_cylinder(labels, membrane_thickness);
  const auto held = labels_within(labels, in.cylinder.axis_xy, in.cylinder.radius, labels.voxel_size()[2]);
  for (const auto& g : grains)
    if (held.count(g.label)) in.grains.push_back(&g);
  return in;
}

double height_in_scan(const ScanCylinder& region, const Volume<std::uint32_t>& labels) {
  const double z0 = labels.position_xyz(0, 0, 0)[2];
  const double z1 = labels.position_xyz(static_cast<double>(labels.shape()[0] - 1), 0, 0)[2];
  const double half = 0.5 * labels.voxel_size()[0];
  return std::min(region.z_max, std::max(z0, z1) + half) - std::max(region.z_min, std::min(z0, z1) - half);
}

double solid_fraction(const std::vector<shape::GrainShape>& grains, double radius, double height) {
  double solid = 0.0;
  for (const auto& g : grains) solid += g.volume;
  return solid / (M_PI * radius * radius * height);
}

EquivalentPackingOptions scan_packing_options(EquivalentPackingOptions options, const std::vector<shape::GrainShape>& grains,
                                              const ScanLabels* scan, const std::string& labels_name) {
  // The scan's sample: ct2labels' cylinder, over the whole scan height unless bounded in z.
  const bool bounded = scan && scan->region.bounded();
  const double height = bounded ? height_in_scan(scan->region, *scan->image) : 0.0;
  if (!bounded && options.solid_fraction == 0.0)
    throw UsageError(labels_name + " has no bounded sample cylinder to take the solid fraction from; give --solid-fraction");
  if (options.solid_fraction == 0.0) {
    options.solid_fraction = solid_fraction(grains, scan->region.radius, height);
    if (options.solid_fraction > synth::kDensestPacking)
      throw DataError(fmt::format("the scan's solid fraction comes out at {:.3f} from {}, above what packs; give --solid-fraction",
                                  options.solid_fraction, labels_name));
  }
  if (options.aspect == 0.0) options.aspect = bounded ? height / (2.0 * scan->region.radius) : 1.0;
  return options;
}

EquivalentTwin pack_equivalent_twin(const std::vector<const shape::GrainShape*>& library, int degree,
                                    const EquivalentPackingOptions& options, const synth::PackingObserver& observe) {
  EquivalentTwin twin;
  try {
    twin.sample = pack_equivalent_sample(library, degree, options, observe);
  } catch (const DataError& e) {
    throw DataError(fmt::format("the equivalent sample did not pack at solid fraction {:.3f} ({}); lower --solid-fraction, "
                                "draw more grains with --grains for a wider cylinder (rough grains jam near 0.58 in "
                                "cylinders a few d50 across), or try another --seed or --aspect: near jamming, "
                                "whether a draw packs depends on the draw",
                                options.solid_fraction, e.message()));
  }
  throw_if_interrupted();
  for (const std::size_t source : twin.sample.source) {
    twin.grains.push_back(*library[source]);
    twin.grains.back().centroid.setZero();
  }
  return twin;
}

TwinGrains grains_in_place(const std::vector<const shape::GrainShape*>& grains) {
  TwinGrains twin;
  twin.shapes = grains;
  for (const shape::GrainShape* g : grains) twin.label.push_back(g->label);
  twin.source_label = twin.label;
  return twin;
}

TwinGrains grains_of_sample(const EquivalentTwin& twin, const std::vector<const shape::GrainShape*>& library) {
  TwinGrains out;
  for (std::size_t i = 0; i < twin.grains.size(); ++i) {
    out.shapes.push_back(&twin.grains[i]);
    out.label.push_back(static_cast<std::uint32_t>(i + 1));
    out.source_label.push_back(library[twin.sample.source[i]]->label);
  }
  out.poses = twin.sample.poses;
  return out;
}

std::vector<GrainMeshResult> mesh_twin_grains(const TwinGrains& grains, const ShSurfaceBasis& basis, const ScanLabels* scan,
                                              const GrainMeshOptions& options, const std::function<void()>& grain_done) {
  const std::size_t count = grains.size();
  const bool placed = !grains.poses.empty();
  // Voxel surfaces exist only where the grains are, in the scan.
  const Volume<std::uint32_t>* labels = scan && !placed ? scan->image : nullptr;
  std::vector<GrainMeshResult> results(count);
  std::vector<std::string> failures(count);
  // Largest grains first, one at a time to whichever thread is free: the costly ones (big voxel
  // surfaces, rough SH surfaces) start early and the small ones fill in, so no worker idles at
  // the end while another still has a long grain (a grain is bounded by its gmsh budget).
  std::vector<std::size_t> order(count);
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return grains.shapes[a]->equivalent_diameter > grains.shapes[b]->equivalent_diameter;
  });
#pragma omp parallel for schedule(dynamic, 1)
  for (std::size_t k = 0; k < count; ++k) {
    const std::size_t i = order[k];
    if (interrupted()) continue;
    const shape::GrainShape& grain = *grains.shapes[i];
    const auto box = labels ? scan->bbox.at(grain.label) : std::array<std::size_t, 6>{};
    try {
      results[i] = mesh_grain(grain, basis, labels, box, options);
      if (placed) place_mesh(results[i].mesh, grains.poses[i]);
    } catch (const Error& e) {
      failures[i] = e.message();
    }
    if (grain_done) grain_done();
  }
  throw_if_interrupted();
  for (std::size_t i = 0; i < count; ++i)
    if (!failures[i].empty())
      throw DataError("grain " + std::to_string(grains.source_label[i]) + " could not be meshed: " + failures[i]);
  return results;
}

void MeshTable::add(std::uint32_t l, std::uint32_t source, const GrainMeshResult& r) {
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
  gmsh_seconds.push_back(r.gmsh.seconds);
  seconds.push_back(r.seconds);
  note.push_back(r.note);
}

TwinModel assemble_twin(const TwinGrains& grains, const std::vector<GrainMeshResult>& results, const SliverThresholds& slivers) {
  TwinModel twin;
  TwinCounts& c = twin.counts;
  fdem::MeshQualityTable& q = twin.quality;
  q.min_dihedral_threshold = slivers.min_dihedral_degrees;
  q.min_altitude_ratio_threshold = slivers.min_altitude_ratio;
  for (std::size_t i = 0; i < grains.size(); ++i) {
    const GrainMeshResult& r = results[i];
    const std::size_t first_element = twin.model.element_count();
    append_grain(twin.model, r.mesh, grains.label[i], r.kind);
    twin.table.add(grains.label[i], grains.source_label[i], r);
    q.label.push_back(grains.label[i]);
    q.min_dihedral.push_back(r.quality.min_dihedral);
    q.min_altitude.push_back(r.quality.min_altitude);
    q.median_altitude.push_back(r.quality.median_altitude);
    q.worst_element.push_back(first_element + r.quality.worst_element);
    q.step_ratio.push_back(r.quality.median_altitude > 0.0 ? r.quality.min_altitude / r.quality.median_altitude : 0.0);
    q.below_thresholds.push_back(r.quality.below_thresholds);
    // Rigid grains carry no stress and set no element step.
    if (r.kind != fdem::GrainKind::rigid && r.quality.below_thresholds > 0) ++c.below_thresholds, c.sliver_elements += r.quality.below_thresholds;
    c.slivers_before += r.gmsh.slivers.before;
    c.slid += r.gmsh.slivers.slid, c.slid_volume += r.gmsh.slivers.slid_volume;
    c.peeled += r.gmsh.slivers.peeled, c.peeled_volume += r.gmsh.slivers.peeled_volume;
    c.sliver_seconds += r.gmsh.slivers.seconds;
    ++c.origin[static_cast<int>(r.origin)];
    ++c.path[static_cast<int>(r.path)];
    c.overran += r.overran;
    c.rigid += r.kind == fdem::GrainKind::rigid;
    c.remeshed += r.remeshed;
    c.optimized += r.gmsh.optimized;
    c.curving_inverted += r.gmsh.inverted_after_curving > 0;
    c.below_floor += r.quality.below_floor > 0 || r.quality.inverted > 0;
    c.gmsh_seconds += r.gmsh.seconds;
    c.seconds += r.seconds;
  }
  return twin;
}

TwinSample twin_sample(const fdem::Model& model, double membrane_thickness, const synth::Container* container,
                       const fdem::SampleCylinder* inscribed, const ScanCylinder* region) {
  TwinSample s{enclosing_cylinder(model, membrane_thickness), "grains"};
  fdem::SampleCylinder& c = s.cylinder;
  if (container) {
    c.axis_xy.setZero();
    c.radius = container->radius;
    c.z_min = 0.0, c.z_max = container->height;
    s.source = "equivalent packing";
  } else if (inscribed) {
    c = *inscribed;
    s.source = "inscribed in the scan";
  } else if (region && region->bounded()) {
    c.axis_xy = region->axis_xy;
    c.radius = region->radius;
    if (std::isfinite(region->z_min) && std::isfinite(region->z_max)) c.z_min = region->z_min, c.z_max = region->z_max;
    s.source = "labels";
  }
  return s;
}

void write_mesh_table(io::H5File& f, const TwinModel& twin, const std::string& parameters) {
  namespace name = schema::fdem_model::mesh;
  const MeshTable& t = twin.table;
  using Codes = std::tuple<const char*, const std::vector<std::uint8_t>*, const char*>;
  for (const auto& [column, values, codes] :
       {Codes{name::surface_origin, &t.origin, "0 SH fit, 1 smoothed voxels, 2 inertia ellipsoid"},
        Codes{name::path, &t.path,
              "0 gmsh remeshes the surface, 1 surface remeshed to the element size and kept as the boundary, 2 ellipsoid"}}) {
    f.write(column, *values);
    f.set_attr(column, name::codes, std::string(codes));
  }
  using Flags = std::pair<const char*, const std::vector<std::uint8_t>*>;
  for (const auto& [column, values] : {Flags{name::overran_budget, &t.overran}, Flags{name::kind, &t.kind},
                                       Flags{name::optimized, &t.optimized}, Flags{name::remeshed, &t.remeshed}})
    f.write(column, *values);
  using Counts = std::pair<const char*, const std::vector<std::uint64_t>*>;
  for (const auto& [column, values] :
       {Counts{name::elements, &t.elements}, Counts{name::nodes, &t.nodes}, Counts{name::surface_nodes, &t.surface_nodes},
        Counts{name::inverted_after_curving, &t.inverted_after_curving}, Counts{name::inverted, &t.inverted}})
    f.write(column, *values);
  using Measures = std::tuple<const char*, const std::vector<double>*, const char*>;
  for (const auto& [column, values, unit] :
       {Measures{name::element_size, &t.size, "m"}, Measures{name::min_gamma, &t.min_gamma, "1"},
        Measures{name::mean_gamma, &t.mean_gamma, "1"}, Measures{name::min_jacobian_ratio, &t.min_jacobian, "1"},
        Measures{name::volume, &t.volume, "m^3"}, Measures{name::surface_volume, &t.surface_volume, "m^3"},
        Measures{name::volume_error, &t.volume_error, "1"}, Measures{name::cut_share, &t.cut_share, "1"},
        Measures{name::gmsh_seconds, &t.gmsh_seconds, "s"}, Measures{name::seconds, &t.seconds, "s"}})
    f.write(column, *values, io::units(unit));
  f.write(name::label, t.label);
  f.write(name::source_label, t.source_label);
  f.write_strings(name::note, t.note);
  f.write_strings(name::parameters, {parameters});
  fdem::write_mesh_quality(f, twin.quality);
}

}  // namespace graintwin::mesh
