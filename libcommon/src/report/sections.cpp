#include "graintwin/report/sections.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <unordered_map>

#include "graintwin/core/error.hpp"
#include "graintwin/core/parallel.hpp"
#include "graintwin/fdem/element.hpp"
#include "graintwin/fdem/model_file.hpp"
#include "graintwin/fdem/results_file.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/micro/simulation.hpp"

namespace graintwin::report {

int normal_axis(SectionPlane plane) { return plane == SectionPlane::xz ? 1 : 2; }

std::array<int, 2> plane_axes(SectionPlane plane) { return plane == SectionPlane::xz ? std::array{0, 2} : std::array{0, 1}; }

std::vector<std::vector<Eigen::Vector2d>> cut_surface(std::span<const Eigen::Vector3d> vertices,
                                                      std::span<const std::array<std::uint32_t, 3>> triangles, SectionPlane plane,
                                                      double offset) {
  const int n = normal_axis(plane);
  const auto [a, b] = plane_axes(plane);
  const auto above = [&](std::uint32_t i) { return vertices[i][n] >= offset; };
  const auto key = [](std::uint32_t i, std::uint32_t j) { return std::uint64_t(std::min(i, j)) << 32 | std::max(i, j); };
  // Every crossed edge is a node of a graph whose links are the triangles' segments: a closed
  // surface makes each node meet two links, so the graph is a set of cycles.
  std::map<std::uint64_t, std::vector<std::uint64_t>> links;
  for (const auto& t : triangles) {
    std::uint64_t crossed[2];
    int count = 0;
    for (int e = 0; e < 3; ++e)
      if (above(t[e]) != above(t[(e + 1) % 3]) && count < 2) crossed[count++] = key(t[e], t[(e + 1) % 3]);
    if (count < 2) continue;
    links[crossed[0]].push_back(crossed[1]);
    links[crossed[1]].push_back(crossed[0]);
  }
  const auto point = [&](std::uint64_t edge) {
    const Eigen::Vector3d& p = vertices[edge >> 32];
    const Eigen::Vector3d& q = vertices[edge & 0xffffffffu];
    const Eigen::Vector3d x = p + (offset - p[n]) / (q[n] - p[n]) * (q - p);
    return Eigen::Vector2d(x[a], x[b]);
  };
  std::vector<std::vector<Eigen::Vector2d>> loops;
  std::map<std::uint64_t, bool> visited;
  const auto walk = [&](std::uint64_t start) {
    std::vector<Eigen::Vector2d> loop;
    for (std::optional<std::uint64_t> at = start; at;) {
      visited[*at] = true;
      loop.push_back(point(*at));
      std::optional<std::uint64_t> next;
      for (std::uint64_t m : links[*at])
        if (!visited[m]) {
          next = m;
          break;
        }
      at = next;
    }
    loops.push_back(std::move(loop));
  };
  // Open chains (an open surface) from their ends first, then the cycles.
  for (const auto& [edge, to] : links)
    if (to.size() == 1 && !visited[edge]) walk(edge);
  for (const auto& [edge, to] : links)
    if (!visited[edge]) walk(edge);
  return loops;
}

TwinSurfaces::TwinSurfaces(const fdem::Model& model) : model_(model) {
  for (const fdem::Grain& grain : model.grains) {
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
    for (std::uint32_t v = grain.node_begin; v < grain.node_end; ++v) lo = lo.cwiseMin(model.nodes[v]), hi = hi.cwiseMax(model.nodes[v]);
    reach_.push_back(grain.node_end > grain.node_begin ? (hi - lo).norm() : 0.0);
  }
  centroid_.resize(model.grains.size(), Eigen::Vector3d::Zero());
  known_.resize(model.grains.size(), 0);
}

void TwinSurfaces::prepare(const std::vector<std::size_t>& grains) {
  std::vector<std::size_t> missing;
  for (std::size_t g : grains)
    if (!known_[g]) missing.push_back(g), known_[g] = 1;
  parallel_for_each_index(missing.size(), [&](std::size_t i) { centroid_[missing[i]] = fdem::body_properties(model_, missing[i]).centroid; });
}

std::vector<GrainOutline> twin_section(TwinSurfaces& surfaces, std::span<const Eigen::Vector3d> centroid,
                                       std::span<const Eigen::Vector4d> rotation, SectionPlane plane, double offset) {
  const fdem::Model& model = surfaces.model();
  const int n = normal_axis(plane);
  std::vector<std::size_t> near;
  for (std::size_t g = 0; g < model.grains.size(); ++g)
    if (std::abs(centroid[g][n] - offset) <= surfaces.reach(g)) near.push_back(g);
  surfaces.prepare(near);
  std::vector<GrainOutline> out;
  std::vector<Eigen::Vector3d> posed;
  std::vector<std::array<std::uint32_t, 3>> local;
  for (std::size_t g : near) {
    pose_grain(model, g, surfaces.reference_centroid(g), centroid[g], rotation[g], posed, local);
    auto loops = cut_surface(posed, local, plane, offset);
    if (!loops.empty()) out.push_back({model.grains[g].label, std::move(loops)});
  }
  return out;
}

void pose_grain(const fdem::Model& model, std::size_t g, const Eigen::Vector3d& reference_centroid, const Eigen::Vector3d& centroid,
                const Eigen::Vector4d& rotation, std::vector<Eigen::Vector3d>& vertices, std::vector<std::array<std::uint32_t, 3>>& triangles) {
  const fdem::Grain& grain = model.grains[g];
  const Eigen::Matrix3d r = Eigen::Quaterniond(rotation[0], rotation[1], rotation[2], rotation[3]).normalized().toRotationMatrix();
  vertices.clear();
  for (std::uint32_t v = grain.node_begin; v < grain.node_end; ++v)
    vertices.push_back(centroid + r * (model.nodes[v] - reference_centroid));
  triangles.clear();
  for (std::uint32_t t = grain.triangle_begin; t < grain.triangle_end; ++t) {
    const auto& tri = model.triangles[t];
    triangles.push_back({tri[0] - grain.node_begin, tri[1] - grain.node_begin, tri[2] - grain.node_begin});
  }
}

std::vector<std::size_t> model_rows(const fdem::Model& model, const fs::path& model_file, const fs::path& simulation_file) {
  const micro::SimulationGrains grains = micro::read_simulation_grains(simulation_file);
  if (grains.label.size() != model.grains.size())
    throw DataError(simulation_file.string() + " holds " + std::to_string(grains.label.size()) + " grains but the model " +
                    model_file.string() + " " + std::to_string(model.grains.size()) +
                    "; they are not of one run: rerun the simulate stage on this model");
  std::vector<std::size_t> rows;
  for (const fdem::Grain& g : model.grains) {
    const auto it = grains.row.find(g.label);
    if (it == grains.row.end())
      throw DataError(simulation_file.string() + " has no grain of label " + std::to_string(g.label) + " of the model " +
                      model_file.string() + "; they are not of one run: rerun the simulate stage on this model");
    rows.push_back(it->second);
  }
  return rows;
}

FramePose frame_pose(const fdem::ResultsFrame& frame, const std::vector<std::size_t>& rows) {
  FramePose p;
  for (std::size_t r : rows) {
    p.centroid.emplace_back(frame.centroid[3 * r], frame.centroid[3 * r + 1], frame.centroid[3 * r + 2]);
    p.rotation.emplace_back(frame.rotation[4 * r], frame.rotation[4 * r + 1], frame.rotation[4 * r + 2], frame.rotation[4 * r + 3]);
  }
  return p;
}

std::array<double, 2> colour_range(const std::vector<double>& values, bool log) {
  std::vector<double> v;
  for (double x : values)
    if (std::isfinite(x) && (!log || x > 0.0)) v.push_back(x);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (v.empty()) return {nan, nan};
  std::sort(v.begin(), v.end());
  const auto at = [&](double q) { return v[std::size_t(std::llround(q * double(v.size() - 1)))]; };
  double lo = at(0.01), hi = at(0.99);
  if (lo == hi) {
    if (log) return {lo / std::sqrt(10.0), hi * std::sqrt(10.0)};
    const double span = lo != 0.0 ? 0.5 * std::abs(lo) : 1.0;
    return {lo - span, hi + span};
  }
  return {lo, hi};
}

std::size_t slice_index(double position, double origin, double size, std::size_t count) {
  const double i = std::round((position - origin) / size);
  if (!(i > 0.0)) return 0;
  return std::min(std::size_t(i), count - 1);
}

ScanPlanes scan_planes(const fs::path& labels_file) {
  const io::H5File f = io::H5File::open(labels_file);
  const io::ImageHeader h = io::read_image_header(f, "/labels");
  ScanPlanes p;
  // Header arrays are (z, y, x); the extent runs over voxel edges, x first.
  for (int axis = 0; axis < 3; ++axis) {
    const int zyx = 2 - axis;
    p.extent[2 * axis] = h.origin[zyx] - 0.5 * h.voxel_size[zyx];
    p.extent[2 * axis + 1] = h.origin[zyx] + (double(h.shape[zyx]) - 0.5) * h.voxel_size[zyx];
  }
  p.axis_y = 0.5 * (p.extent[2] + p.extent[3]);
  p.mid_z = 0.5 * (p.extent[4] + p.extent[5]);
  const auto attrs = [&](const char* name) { return f.has_attr("/sample", name) ? f.attr_doubles("/sample", name) : std::vector<double>{}; };
  const std::vector<double> radius = attrs("cylinder_radius"), centre = attrs("cylinder_centre_xy"), z_range = attrs("cylinder_z_range");
  if (radius.size() == 1 && std::isfinite(radius[0]) && centre.size() == 2 && std::isfinite(centre[1])) p.axis_y = centre[1];
  if (z_range.size() == 2 && std::isfinite(z_range[0]) && std::isfinite(z_range[1])) p.mid_z = 0.5 * (z_range[0] + z_range[1]);
  p.y_index = slice_index(p.axis_y, h.origin[1], h.voxel_size[1], h.shape[1]);
  p.z_index = slice_index(p.mid_z, h.origin[0], h.voxel_size[0], h.shape[0]);
  return p;
}

namespace {

std::string mm(double metres) { return fmt::format("{:.2f} mm", 1e3 * metres); }

std::string percent(double strain) { return fmt::format("{:.1f} %", 100.0 * strain); }

/// ", axial strain A" (or "A -> B"), or nothing when a strain is not known (a single scan without
/// --scan-strains or tracks; a frame of a scene without a triaxial test).
std::string strains(double from, double to = 0.0, bool increment = false) {
  if (!std::isfinite(from) || (increment && !std::isfinite(to))) return "";
  return ", axial strain " + percent(from) + (increment ? " -> " + percent(to) : "");
}

/// The frame (u0, u1, v0, v1) of a plane in an image's extent (x0, x1, y0, y1, z0, z1).
std::array<double, 4> image_frame(const std::array<double, 6>& e, SectionPlane plane) {
  const auto [a, b] = plane_axes(plane);
  return {e[2 * a], e[2 * a + 1], e[2 * b], e[2 * b + 1]};
}

void grow(std::array<double, 4>& frame, const std::array<double, 4>& more) {
  frame = {std::min(frame[0], more[0]), std::max(frame[1], more[1]), std::min(frame[2], more[2]), std::max(frame[3], more[3])};
}

std::array<double, 4> empty_frame() {
  const double inf = std::numeric_limits<double>::infinity();
  return {inf, -inf, inf, -inf};
}

/// The twin at one frame, posed: its outlines on both planes and the frame's strain.
struct TwinFrame {
  std::vector<GrainOutline> vertical, horizontal;
  double horizontal_z = 0.0;
  double axial_strain = 0.0;
};

/// The model, its grains in the results' order, and the frames posed on demand (each once).
class Twin {
 public:
  Twin(const RunFiles& files, double axis_y)
      : files_(files), model_(fdem::read_model_file(files.model)), surfaces_(model_), row_(model_rows(model_, files.model, files.simulation)) {
    axis_y_ = model_.sample ? model_.sample->axis_xy.y() : axis_y;
  }
  double axis_y() const { return axis_y_; }
  /// The log axial strain of frame k (NaN when the frame has none).
  double axial_strain(std::size_t k) {
    const auto it = frames_.find(k);
    return it != frames_.end() ? it->second.axial_strain : fdem::read_results_frame(files_.simulation, k).axial_strain;
  }

  const TwinFrame& frame(std::size_t k) {
    auto it = frames_.find(k);
    if (it != frames_.end()) return it->second;
    const fdem::ResultsFrame f = fdem::read_results_frame(files_.simulation, k);
    const auto [centroid, rotation] = frame_pose(f, row_);
    double z_lo = std::numeric_limits<double>::infinity(), z_hi = -z_lo;
    for (const Eigen::Vector3d& c : centroid) z_lo = std::min(z_lo, c.z()), z_hi = std::max(z_hi, c.z());
    TwinFrame t;
    t.axial_strain = f.axial_strain;
    // Through the centre of the grain nearest mid-height, so the plane cuts grains even in a
    // regular packing whose layers leave a gap at mid-height.
    t.horizontal_z = centroid.front().z();
    for (const Eigen::Vector3d& c : centroid)
      if (std::abs(c.z() - 0.5 * (z_lo + z_hi)) < std::abs(t.horizontal_z - 0.5 * (z_lo + z_hi))) t.horizontal_z = c.z();
    t.vertical = twin_section(surfaces_, centroid, rotation, SectionPlane::xz, axis_y_);
    t.horizontal = twin_section(surfaces_, centroid, rotation, SectionPlane::xy, t.horizontal_z);
    return frames_.emplace(k, std::move(t)).first->second;
  }

 private:
  const RunFiles& files_;
  fdem::Model model_;
  TwinSurfaces surfaces_;
  std::vector<std::size_t> row_;  ///< results row of each model grain
  double axis_y_ = 0.0;
  std::map<std::size_t, TwinFrame> frames_;
};

/// A view of the twin's outlines, and the frame they span.
SectionView outline_view(const std::vector<GrainOutline>& outlines, SectionPlane plane, double offset, std::array<double, 4>& frame) {
  SectionView v;
  v.plane = plane == SectionPlane::xz ? "xz" : "xy";
  v.offset = offset;
  for (const GrainOutline& g : outlines)
    for (const auto& loop : g.loops) {
      std::vector<double> flat;
      // Rounded to the nanometre (a thousandth of a pixel on any section drawn), so charts.json stays short.
      const auto nm = [](double m) { return std::round(m * 1e9) * 1e-9; };
      for (const Eigen::Vector2d& p : loop) {
        const double u = nm(p.x()), v = nm(p.y());
        flat.push_back(u), flat.push_back(v);
        grow(frame, {u, u, v, v});
      }
      v.outline_label.push_back(g.label);
      v.outline.push_back(std::move(flat));
    }
  return v;
}

SectionView image_view(const RunFiles& files, std::size_t scan, const ScanPlanes& planes, SectionPlane plane, double offset) {
  SectionView v;
  v.plane = plane == SectionPlane::xz ? "xz" : "xy";
  v.offset = offset;
  v.labels_file = files.labels[scan].string();
  if (!files.volumes.empty()) v.volume_file = files.volumes[scan].string();
  v.index = plane == SectionPlane::xz ? planes.y_index : planes.z_index;
  return v;
}

/// The scans' axial strain: applied where known, else from the tracks; NaN when neither.
double scan_strain(const ExperimentData& e, std::size_t t) {
  if (t < e.applied_axial_strain.size()) return e.applied_axial_strain[t];
  if (t < e.tracked_axial_strain.size()) return e.tracked_axial_strain[t];
  return std::numeric_limits<double>::quiet_NaN();
}

/// Each grain of a micro file's state `t` (label) with its value of increment k in `per_grain` (N x K).
void paint(SectionView& v, const MicroData& m, std::size_t t, std::size_t k, const std::vector<double>& per_grain) {
  const std::size_t states = m.states.size(), increments = m.increments.size();
  for (std::size_t n = 0; n < m.grains; ++n) {
    const std::uint32_t label = m.grain_label[n * states + t];
    if (label == 0) continue;
    v.value_label.push_back(label);
    v.value.push_back(per_grain[n * increments + k]);
  }
}

struct Quantity {
  const char* id;
  const char* name;
  const char* colour_label;
  bool log;
  std::vector<double> MicroData::*values;
  const char* meaning;
};

}  // namespace

std::vector<Panel> section_panels(const RunFiles& files, const ExperimentData& e, const SimulationData& s, const PanelOptions& options) {
  std::vector<ScanPlanes> planes;
  for (const fs::path& p : files.labels) planes.push_back(scan_planes(p));
  if (e.micro && e.micro->states.size() != planes.size())
    throw UsageError(files.micro.string() + " follows " + std::to_string(e.micro->states.size()) + " scans but the run has " +
                     std::to_string(planes.size()) + "; rerun the micro stage or name the scans' files explicitly");
  const double axis_y = planes[0].axis_y;  // the reference scan's axis, for every scan: one plane through the sample
  std::optional<Twin> twin;
  if (s.present && !files.model.empty()) twin.emplace(files, axis_y);
  const std::string twin_missing = !s.present ? kNoSimulation : kNoModel;

  // Grains keep the colour of their identity in the reference scan, through the tracks (the twin's
  // grains carry the reference scan's labels, so they match it too).
  std::vector<std::vector<std::uint32_t>> identity_label(planes.size()), identity(planes.size());
  if (e.micro)
    for (std::size_t n = 0; n < e.micro->grains; ++n) {
      const std::size_t states = e.micro->states.size();
      const std::uint32_t first = e.micro->grain_label[n * states];
      for (std::size_t t = 1; t < std::min(states, planes.size()); ++t)
        if (const std::uint32_t label = e.micro->grain_label[n * states + t]; label != 0 && first != 0)
          identity_label[t].push_back(label), identity[t].push_back(first);
    }

  std::vector<Panel> panels;
  std::array<double, 4> vertical_frame = empty_frame(), horizontal_frame = empty_frame();
  for (std::size_t t : pick_evenly(planes.size(), options.max_series)) {
    const std::string& scan = e.scans[t].name;
    Panel p{"section_" + scan, "Sections of " + scan + " and of the twin",
            "A horizontal section at mid-height and a vertical section through the sample's axis. Experiment: the slice of " +
                scan + "'s label image (ct2labels), each grain in its own colour" +
                (files.volumes.empty() ? "" : " over the scan's grey values, with the grains' boundaries") +
                "; a grain keeps its colour from scan to scan (tracks). Simulation: where the same planes cut the FDEM twin's "
                "grains at the frame of the same order, each the model's surface turned and moved to the frame's rotation and "
                "centroid, in the colour of the same grain in the reference scan.",
            {}, {}};
    Chart ce;
    ce.kind = "section", ce.panel = p.id, ce.file = p.id + "_experiment.png";
    ce.title = scan + strains(scan_strain(e, t));
    SectionView h = image_view(files, t, planes[t], SectionPlane::xy, planes[t].mid_z);
    SectionView v = image_view(files, t, planes[t], SectionPlane::xz, axis_y);
    h.title = "horizontal, z = " + mm(planes[t].mid_z), v.title = "vertical through the axis, y = " + mm(axis_y);
    grow(horizontal_frame, image_frame(planes[t].extent, SectionPlane::xy));
    grow(vertical_frame, image_frame(planes[t].extent, SectionPlane::xz));
    h.identity_label = v.identity_label = identity_label[t];
    h.identity = v.identity = identity[t];
    ce.sections = {std::move(h), std::move(v)};
    p.experiment = Side{std::move(ce), {}, {}};
    if (!twin) {
      p.simulation = Side{std::nullopt, twin_missing, {}};
    } else if (t >= s.frames) {
      p.simulation = Side{std::nullopt, fmt::format("The simulation has {} frames, none of the order of {}.", s.frames, scan), {}};
    } else {
      const TwinFrame& f = twin->frame(t);
      Chart cs;
      cs.kind = "section", cs.panel = p.id, cs.file = p.id + "_simulation.png";
      cs.title = fmt::format("frame {}{}", t, strains(f.axial_strain));
      SectionView th = outline_view(f.horizontal, SectionPlane::xy, f.horizontal_z, horizontal_frame);
      SectionView tv = outline_view(f.vertical, SectionPlane::xz, twin->axis_y(), vertical_frame);
      th.title = "horizontal, z = " + mm(f.horizontal_z), tv.title = "vertical through the axis, y = " + mm(twin->axis_y());
      cs.sections = {std::move(th), std::move(tv)};
      p.simulation = Side{std::move(cs), {}, {}};
    }
    panels.push_back(std::move(p));
  }

  const Quantity quantities[] = {
      {"d2min", "D2min", "D2min / d50^2", true, &MicroData::grain_d2min,
       "non-affine motion: the least-squares misfit of the grain's neighbourhood to an affine map over the increment, over d50^2"},
      {"eps_q", "eps_q", "eps_q", false, &MicroData::grain_eps_q,
       "the local deviatoric strain sqrt(2/3 e_dev : e_dev) of the grain's neighbourhood over the increment"}};
  const std::size_t exp_increments = e.micro ? e.micro->increments.size() : 0;
  const std::size_t sim_increments = s.micro ? s.micro->increments.size() : 0;
  const std::vector<std::size_t> shown = pick_evenly(std::max(exp_increments, sim_increments), options.max_series);
  for (const Quantity& q : quantities) {
    std::vector<SectionView*> painted;
    std::vector<double> all;
    const std::size_t first_panel = panels.size();
    for (std::size_t k : shown) {
      Panel p{fmt::format("section_{}_{}", q.id, k), fmt::format("{} on the vertical section, increment {}", q.name, k),
              std::string(q.name) + " of every grain (" + q.meaning +
                  "; tracks2micro), painted on the vertical section through the sample's axis at the increment's first state; "
                  "one colour scale for the scans and the simulation over every increment shown (1st to 99th percentile" +
                  (q.log ? ", logarithmic" : "") + "), grey where it is not defined. Experiment: micro.h5 on the slice of the "
                  "increment's first scan; simulation: simulation_micro.h5 on the twin's section at the increment's first frame.",
              {}, {}};
      if (!e.micro) {
        p.experiment = Side{std::nullopt, kNoMicro, {}};
      } else if (k >= exp_increments) {
        p.experiment = Side{std::nullopt, fmt::format("The scans have {} increments; this one exists in the simulation only.", exp_increments), {}};
      } else {
        const MicroIncrement& inc = e.micro->increments[k];
        const std::size_t t = inc.from;
        Chart c;
        c.kind = "section", c.panel = p.id, c.file = p.id + "_experiment.png";
        c.title = fmt::format("{} -> {}{}", e.scans[t].name, e.scans[inc.to].name, strains(scan_strain(e, t), scan_strain(e, inc.to), true));
        SectionView v = image_view(files, t, planes[t], SectionPlane::xz, axis_y);
        v.title = "vertical through the axis, y = " + mm(axis_y);
        paint(v, *e.micro, t, k, (*e.micro).*q.values);
        c.sections = {std::move(v)};
        p.experiment = Side{std::move(c), {}, {}};
      }
      if (!twin) {
        p.simulation = Side{std::nullopt, twin_missing, {}};
      } else if (!s.micro) {
        p.simulation = Side{std::nullopt, kNoSimulationMicro, {}};
      } else if (k >= sim_increments) {
        p.simulation = Side{std::nullopt, fmt::format("The simulation has {} increments; this one exists in the scans only.", sim_increments), {}};
      } else {
        const MicroIncrement& inc = s.micro->increments[k];
        const TwinFrame& f = twin->frame(inc.from);
        Chart c;
        c.kind = "section", c.panel = p.id, c.file = p.id + "_simulation.png";
        c.title = fmt::format("frame {} -> {}{}", inc.from, inc.to, strains(f.axial_strain, twin->axial_strain(inc.to), true));
        SectionView v = outline_view(f.vertical, SectionPlane::xz, twin->axis_y(), vertical_frame);
        v.title = "vertical through the axis, y = " + mm(twin->axis_y());
        paint(v, *s.micro, inc.from, k, (*s.micro).*q.values);
        c.sections = {std::move(v)};
        p.simulation = Side{std::move(c), {}, {}};
      }
      panels.push_back(std::move(p));
    }
    for (std::size_t i = first_panel; i < panels.size(); ++i)
      for (Side* side : {&panels[i].experiment, &panels[i].simulation})
        if (side->chart) {
          SectionView& v = side->chart->sections[0];
          all.insert(all.end(), v.value.begin(), v.value.end());
          painted.push_back(&v);
        }
    const auto [lo, hi] = colour_range(all, q.log);
    for (SectionView* v : painted) v->quantity = q.colour_label, v->colour_log = q.log, v->colour_min = lo, v->colour_max = hi;
  }

  // Both sides of every plane share one frame, so a grain is drawn at the same place on each.
  for (Panel& p : panels)
    for (Side* side : {&p.experiment, &p.simulation})
      if (side->chart)
        for (SectionView& v : side->chart->sections) v.extent = v.plane == "xz" ? vertical_frame : horizontal_frame;
  return panels;
}

}  // namespace graintwin::report
