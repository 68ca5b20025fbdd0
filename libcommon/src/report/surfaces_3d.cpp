#include "graintwin/report/surfaces_3d.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

#include "graintwin/core/parallel.hpp"
#include "graintwin/fdem/model_file.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/schema.hpp"

namespace graintwin::report {

TriangleSurface cluster_vertices(std::span<const Eigen::Vector3d> vertices, std::span<const std::array<std::uint32_t, 3>> triangles,
                                 double cell) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  for (const auto& t : triangles)
    for (std::uint32_t v : t) lo = lo.cwiseMin(vertices[v]);
  constexpr std::uint32_t kUnset = std::numeric_limits<std::uint32_t>::max();
  std::vector<std::uint32_t> cluster(vertices.size(), kUnset);
  std::unordered_map<std::uint64_t, std::uint32_t> cluster_of_cell;
  std::vector<Eigen::Vector3d> sum;
  std::vector<double> count;
  const auto cell_key = [&](const Eigen::Vector3d& p) {
    std::uint64_t key = 0;
    for (int a = 0; a < 3; ++a) key = key << 21 | std::min<std::uint64_t>(std::uint64_t((p[a] - lo[a]) / cell), (1u << 21) - 1);
    return key;
  };
  TriangleSurface out;
  for (const auto& t : triangles) {
    std::array<std::uint32_t, 3> c{};
    for (int k = 0; k < 3; ++k) {
      std::uint32_t& id = cluster[t[k]];
      if (id == kUnset) {
        const auto [it, added] = cluster_of_cell.try_emplace(cell_key(vertices[t[k]]), std::uint32_t(sum.size()));
        if (added) sum.push_back(Eigen::Vector3d::Zero()), count.push_back(0.0);
        id = it->second;
        sum[id] += vertices[t[k]], count[id] += 1.0;
      }
      c[k] = id;
    }
    if (c[0] != c[1] && c[1] != c[2] && c[2] != c[0]) out.triangles.push_back(c);
  }
  for (std::size_t i = 0; i < sum.size(); ++i) out.vertices.push_back(sum[i] / count[i]);
  return out;
}

double clustering_cell(double area, std::size_t target) { return std::sqrt(2.0 * area / double(std::max<std::size_t>(target, 1))); }

double surface_area(std::span<const Eigen::Vector3d> vertices, std::span<const std::array<std::uint32_t, 3>> triangles) {
  double area = 0.0;
  for (const auto& t : triangles) area += 0.5 * (vertices[t[1]] - vertices[t[0]]).cross(vertices[t[2]] - vertices[t[0]]).norm();
  return area;
}

Eigen::Vector3d enclosed_centroid(std::span<const Eigen::Vector3d> vertices, std::span<const std::array<std::uint32_t, 3>> triangles) {
  // The tetrahedra from a corner of the surface to each triangle, signed: their volume-weighted
  // centroids sum to the enclosed solid's. About a vertex of it, not the origin, for the digits.
  const Eigen::Vector3d o = vertices[triangles.front()[0]];
  double volume = 0.0;
  Eigen::Vector3d first = Eigen::Vector3d::Zero();
  for (const auto& t : triangles) {
    const Eigen::Vector3d a = vertices[t[0]] - o, b = vertices[t[1]] - o, c = vertices[t[2]] - o;
    const double v = a.dot(b.cross(c)) / 6.0;
    volume += v;
    first += v * (a + b + c) / 4.0;
  }
  return o + first / volume;
}

std::vector<Eigen::Vector3d> grain_surface_centroids(const fdem::Model& model) {
  std::vector<Eigen::Vector3d> centroid(model.grains.size());
  parallel_for_each_index(model.grains.size(), [&](std::size_t g) {
    const fdem::Grain& grain = model.grains[g];
    std::span<const std::array<std::uint32_t, 3>> triangles(model.triangles.data() + grain.triangle_begin, grain.triangle_end - grain.triangle_begin);
    centroid[g] = enclosed_centroid(model.nodes, triangles);
  });
  return centroid;
}

SurfacesView posed_surfaces(const fdem::Model& model, const std::vector<Eigen::Vector3d>& reference_centroid, const FramePose& pose,
                            const FrontQuarter& cut, std::size_t budget) {
  std::vector<std::size_t> drawn;
  for (std::size_t g = 0; g < model.grains.size(); ++g)
    if (!cut.holds(pose.centroid[g].x(), pose.centroid[g].y())) drawn.push_back(g);
  // A floor of a dozen triangles keeps even the smallest share a closed, recognisable grain.
  const std::size_t per_grain = std::max<std::size_t>(budget / std::max<std::size_t>(drawn.size(), 1), 12);
  std::vector<TriangleSurface> parts(drawn.size());
  std::vector<std::size_t> source(drawn.size());
  parallel_for_each_index(drawn.size(), [&](std::size_t i) {
    const std::size_t g = drawn[i];
    TriangleSurface& s = parts[i];
    pose_grain(model, g, reference_centroid[g], pose.centroid[g], pose.rotation[g], s.vertices, s.triangles);
    source[i] = s.triangles.size();
    if (s.triangles.size() > per_grain)
      s = cluster_vertices(s.vertices, s.triangles, clustering_cell(surface_area(s.vertices, s.triangles), per_grain));
  });
  SurfacesView v;
  v.grains = drawn.size(), v.grains_cut = model.grains.size() - drawn.size();
  const double inf = std::numeric_limits<double>::infinity();
  v.bounds = {inf, -inf, inf, -inf, inf, -inf};
  for (std::size_t i = 0; i < drawn.size(); ++i) {
    const std::uint32_t first = std::uint32_t(v.vertices.size() / 3);
    for (const Eigen::Vector3d& p : parts[i].vertices)
      for (int a = 0; a < 3; ++a) {
        v.vertices.push_back(float(p[a]));
        v.bounds[2 * a] = std::min(v.bounds[2 * a], p[a]), v.bounds[2 * a + 1] = std::max(v.bounds[2 * a + 1], p[a]);
      }
    for (const auto& t : parts[i].triangles) {
      v.triangles.insert(v.triangles.end(), {first + t[0], first + t[1], first + t[2]});
      v.label.push_back(model.grains[drawn[i]].label);
    }
    v.source_triangles += source[i];
  }
  v.cut = {cut.x, cut.y};
  return v;
}

void write_surface_mesh(const SurfacesView& view, const std::filesystem::path& path) {
  io::H5File f = io::H5File::create(path);
  f.write("/vertices", view.vertices.data(), {view.vertices.size() / 3, 3});
  f.write("/triangles", view.triangles.data(), {view.triangles.size() / 3, 3});
  f.write("/label", view.label);
}

double membrane_ball_radius(const fs::path& simulation) {
  const io::H5File f = io::H5File::open(simulation);
  if (!f.exists(schema::fdem_results::parameters)) return 0.0;
  const nlohmann::json p = nlohmann::json::parse(f.read_string(schema::fdem_results::parameters), nullptr, false);
  if (!p.is_object() || !p.contains("triaxial") || !p["triaxial"].is_object() || !p["triaxial"].contains("ball_radius")) return 0.0;
  const nlohmann::json& r = p["triaxial"]["ball_radius"];
  return r.is_number() && r.get<double>() > 0.0 ? r.get<double>() : 0.0;
}

namespace {

/// The axis of the cutaway: the model's sample cylinder, else the middle of its nodes.
FrontQuarter model_axis(const fdem::Model& model) {
  if (model.sample) return {model.sample->axis_xy.x(), model.sample->axis_xy.y()};
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const Eigen::Vector3d& x : model.nodes) lo = lo.cwiseMin(x), hi = hi.cwiseMax(x);
  return {0.5 * (lo.x() + hi.x()), 0.5 * (lo.y() + hi.y())};
}

std::string triangles_note(const SurfacesView& v) {
  return fmt::format("{} grains drawn, {} in the front quarter cut away; {} triangles{}.", v.grains, v.grains_cut, v.triangles.size() / 3,
                     v.source_triangles > v.triangles.size() / 3 ? fmt::format(" (of {}: the larger grains simplified by vertex clustering)", v.source_triangles) : "");
}

}  // namespace

Panel grain_surface_panel(const RunFiles& files, const ExperimentData& e, const SimulationData& s) {
  Panel p{"grains_3d", "The grains in 3D: the reference scan and the twin at its last frame",
          "Every grain's own surface, in the colour of its label in the reference scan (as in the sections), the quarter of the "
          "sample in front of its axis cut away so the interior shows; one fixed camera along +y from 20 degrees above frames both. "
          "Experiment: the reference scan's grains as the mesh stage built them from it (model.h5's reference surfaces). "
          "Simulation: the same surfaces turned and moved to each grain's rotation and centroid at the simulation's last frame "
          "(a deformable grain at its best-fit rigid motion), with the membrane's balls (pale blue). Grains of more triangles "
          "than their share of a 1.5 million budget are simplified by vertex clustering.",
          {}, {}};
  if (files.model.empty()) {
    p.experiment = Side{std::nullopt, kNoModel, {}};
    p.simulation = Side{std::nullopt, s.present ? kNoModel : kNoSimulation, {}};
    return p;
  }
  const fdem::Model model = fdem::read_model_file(files.model);
  const std::vector<Eigen::Vector3d> reference = grain_surface_centroids(model);
  const FrontQuarter cut = model_axis(model);
  Chart ce;
  ce.kind = "surfaces", ce.panel = p.id, ce.file = p.id + "_experiment.png";
  ce.title = e.scans.front().name + "'s grains (the model's reference surfaces)";
  FramePose as_scanned;  // every grain where the model has it
  as_scanned.centroid = reference;
  as_scanned.rotation.assign(reference.size(), Eigen::Vector4d(1.0, 0.0, 0.0, 0.0));
  ce.surfaces = posed_surfaces(model, reference, as_scanned, cut, kSurfaceTriangleBudget);
  ce.surfaces->mesh_file = p.id + "_experiment.mesh.h5";
  std::array<double, 6> bounds = ce.surfaces->bounds;
  const std::string experiment_note = triangles_note(*ce.surfaces);
  p.experiment = Side{std::move(ce), {}, experiment_note};

  if (!s.present) {
    p.simulation = Side{std::nullopt, kNoSimulation, {}};
  } else if (s.frames == 0) {
    p.simulation = Side{std::nullopt, files.simulation.string() + " holds no frame: fdemrun saves frames at the scene's frame_strains.", {}};
  } else {
    const std::size_t last = s.frames - 1;
    const fdem::ResultsFrame f = fdem::read_results_frame(files.simulation, last);
    Chart cs;
    cs.kind = "surfaces", cs.panel = p.id, cs.file = p.id + "_simulation.png";
    cs.title = fmt::format("the twin at frame {}{}", last, std::isfinite(f.axial_strain) ? fmt::format(", axial strain {:.1f} %", 100.0 * f.axial_strain) : "");
    SurfacesView v = posed_surfaces(model, reference, frame_pose(f, model_rows(model, files.model, files.simulation)), cut, kSurfaceTriangleBudget);
    v.mesh_file = p.id + "_simulation.mesh.h5";
    v.membrane_radius = membrane_ball_radius(files.simulation);
    for (std::size_t b = 0; b + 2 < f.membrane_position.size(); b += 3) {
      const double* x = &f.membrane_position[b];
      if (cut.holds(x[0], x[1])) continue;
      v.membrane.insert(v.membrane.end(), {x[0], x[1], x[2]});
      for (int a = 0; a < 3; ++a)
        v.bounds[2 * a] = std::min(v.bounds[2 * a], x[a] - v.membrane_radius), v.bounds[2 * a + 1] = std::max(v.bounds[2 * a + 1], x[a] + v.membrane_radius);
    }
    for (int a = 0; a < 3; ++a) bounds[2 * a] = std::min(bounds[2 * a], v.bounds[2 * a]), bounds[2 * a + 1] = std::max(bounds[2 * a + 1], v.bounds[2 * a + 1]);
    const std::string note = triangles_note(v) + (v.membrane.empty() ? "" : fmt::format(" {} membrane balls.", v.membrane.size() / 3));
    cs.surfaces = std::move(v);
    p.simulation = Side{std::move(cs), {}, note};
  }
  for (Side* side : {&p.experiment, &p.simulation})
    if (side->chart) side->chart->surfaces->bounds = bounds;
  return p;
}

}  // namespace graintwin::report
