#include "graintwin/fdem/model_file.hpp"

#include <cmath>
#include <fstream>
#include <limits>
#include <string_view>

#include <fmt/format.h>

#include "graintwin/core/error.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"

namespace graintwin::fdem {
namespace sm = schema::fdem_model;
using io::units;

namespace {

constexpr std::uint32_t kPadding = std::numeric_limits<std::uint32_t>::max();

/// The numeric material columns, one dataset each under /materials, with the physical range every
/// value must lie in (scenes and model files alike, material_range_problem; docs/formats.md).
struct MaterialColumn {
  const char* name;
  const char* unit;
  double Material::*field;
  double low, high;
  bool low_open, high_open;  ///< the bound itself is excluded
};
constexpr MaterialColumn kMaterialColumns[] = {
    // Up to ten million times rock's density, for mass scaling.
    {"density", "kg/m^3", &Material::density, 1, 1e10, false, false},
    // From soft rubber to diamond and beyond.
    {"young", "Pa", &Material::young, 1e3, 1e13, false, false},
    {"poisson", "1", &Material::poisson, -1, 0.5, true, true},
    {"friction", "1", &Material::friction, 0, 10, false, false},
    // p = k E / h reaches 1e24 only for k = 100, E = 1e13 Pa and h = 1 um.
    {"normal_penalty", "N/m^3", &Material::normal_penalty, 0, 1e24, true, false},
    {"tangential_penalty", "N/m^3", &Material::tangential_penalty, 0, 1e24, true, false},
    {"damping_ratio", "1", &Material::damping_ratio, 0, 1, false, true},
};

std::string material_path(const char* column) { return std::string(sm::materials) + "/" + column; }

std::vector<double> flatten(const std::vector<Eigen::Vector3d>& v) {
  std::vector<double> out(3 * v.size());
  for (std::size_t i = 0; i < v.size(); ++i)
    for (int k = 0; k < 3; ++k) out[3 * i + static_cast<std::size_t>(k)] = v[i][k];
  return out;
}

std::vector<std::uint32_t> ranges(const std::vector<Grain>& grains, std::uint32_t Grain::*begin, std::uint32_t Grain::*end) {
  std::vector<std::uint32_t> out;
  out.reserve(2 * grains.size());
  for (const Grain& g : grains) out.insert(out.end(), {g.*begin, g.*end});
  return out;
}

/// Checks that the grains' [begin, end) ranges tile [0, total) in grain order.
void check_tiling(const Model& m, std::uint32_t Grain::*begin, std::uint32_t Grain::*end, std::size_t total,
                  const char* what, const std::string& where) {
  std::uint32_t next = 0;
  for (std::size_t g = 0; g < m.grains.size(); ++g) {
    if (m.grains[g].*begin != next || m.grains[g].*end < next)
      throw DataError(fmt::format("{}: the {} ranges of the grains do not follow each other (grain {}); rebuild the model",
                                  where, what, g));
    next = m.grains[g].*end;
  }
  if (next != total)
    throw DataError(fmt::format("{}: the grains own {} {} but the model has {}; rebuild the model", where, next, what, total));
}

/// Whether every coordinate of v is finite.
bool finite(const Eigen::Vector3d& v) { return v.allFinite(); }

}  // namespace

std::string material_range_problem(const Material& material) {
  for (const MaterialColumn& c : kMaterialColumns) {
    const double v = material.*c.field;
    const bool above_low = c.low_open ? v > c.low : v >= c.low;
    const bool below_high = c.high_open ? v < c.high : v <= c.high;
    if (std::isfinite(v) && above_low && below_high) continue;
    const std::string unit = std::string_view(c.unit) == "1" ? std::string() : " " + std::string(c.unit);
    return fmt::format("{} must lie in {}{:g}, {:g}{}{} (got {:g}{})", c.name, c.low_open ? '(' : '[', c.low, c.high,
                       c.high_open ? ')' : ']', unit, v, unit);
  }
  return {};
}

void validate_model(const Model& m, const std::string& where) {
  // Values first: a damaged or hand-edited file must not reach the solver as NaN or a zero modulus.
  for (std::size_t i = 0; i < m.nodes.size(); ++i)
    if (!finite(m.nodes[i]))
      throw DataError(fmt::format("{}: node {} has a coordinate that is not a finite number; rebuild the model", where, i));
  for (const Material& mat : m.materials)
    if (const std::string problem = material_range_problem(mat); !problem.empty())
      throw DataError(fmt::format("{}: material '{}': {}; the model is damaged or was edited, rebuild it", where, mat.name,
                                  problem));
  for (const Platen& p : m.platens)
    if (!finite(p.point) || !finite(p.normal) || std::abs(p.normal.norm() - 1) > 1e-6 || !(p.friction >= 0 && p.friction <= 10))
      throw DataError(fmt::format("{}: platen '{}' needs a finite point, a unit normal and a friction in [0, 10] (got "
                                  "normal length {:g}, friction {:g}); rebuild the model",
                                  where, p.name, p.normal.norm(), p.friction));
  if (const auto& s = m.sample;
      s && !(s->axis_xy.allFinite() && s->radius > 0 && std::isfinite(s->radius) && std::isfinite(s->z_min) &&
             std::isfinite(s->z_max) && s->z_min < s->z_max && s->membrane_thickness >= 0 &&
             std::isfinite(s->membrane_thickness)))
    throw DataError(fmt::format("{}: the sample cylinder needs a finite axis, a positive radius, z_min < z_max and a "
                                "membrane thickness of at least 0 (got radius {:g} m, z from {:g} to {:g} m, thickness "
                                "{:g} m); rebuild the model",
                                where, s->radius, s->z_min, s->z_max, s->membrane_thickness));
  const std::size_t ne = m.element_grain.size();
  if (m.element_offset.size() != ne + 1 || m.element_offset.front() != 0 || m.element_offset.back() != m.element_nodes.size())
    throw DataError(where + ": the element offsets do not match the element list; rebuild the model");
  if (m.triangle_grain.size() != m.triangles.size())
    throw DataError(where + ": the surface triangles and their grain indices differ in number; rebuild the model");
  check_tiling(m, &Grain::node_begin, &Grain::node_end, m.nodes.size(), "nodes", where);
  check_tiling(m, &Grain::element_begin, &Grain::element_end, ne, "elements", where);
  check_tiling(m, &Grain::triangle_begin, &Grain::triangle_end, m.triangles.size(), "triangles", where);
  for (std::size_t g = 0; g < m.grains.size(); ++g) {
    const Grain& gr = m.grains[g];
    if (gr.material >= m.materials.size())
      throw DataError(fmt::format("{}: grain {} uses material {} of {}; rebuild the model", where, g, gr.material, m.materials.size()));
    if (static_cast<std::uint8_t>(gr.kind) > 2)
      throw DataError(fmt::format("{}: grain {} has an unknown kind; rebuild the model", where, g));
    const auto owned = [&](std::uint32_t node) { return node >= gr.node_begin && node < gr.node_end; };
    for (std::uint32_t e = gr.element_begin; e < gr.element_end; ++e) {
      const std::size_t n = m.nodes_of(e);
      if ((n != 4 && n != 10) || m.element_grain[e] != g)
        throw DataError(fmt::format("{}: element {} has {} nodes or belongs to another grain; rebuild the model", where, e, n));
      for (std::uint32_t k = m.element_offset[e]; k < m.element_offset[e + 1]; ++k)
        if (!owned(m.element_nodes[k]))
          throw DataError(fmt::format("{}: element {} uses a node outside grain {}; rebuild the model", where, e, g));
    }
    for (std::uint32_t t = gr.triangle_begin; t < gr.triangle_end; ++t)
      if (m.triangle_grain[t] != g || !owned(m.triangles[t][0]) || !owned(m.triangles[t][1]) || !owned(m.triangles[t][2]))
        throw DataError(fmt::format("{}: surface triangle {} does not lie on grain {}; rebuild the model", where, t, g));
  }
}

void write_model_file(const std::filesystem::path& path, const Model& m, const std::vector<std::string>& history,
                      const std::function<void(io::H5File&)>& extra) {
  validate_model(m, "write_model_file");
  const hsize_t ne = m.element_count(), nt = m.triangles.size(), ng = m.grains.size();
  hsize_t width = 4;
  for (std::size_t e = 0; e < ne; ++e)
    if (m.nodes_of(e) == 10) width = 10;
  std::vector<std::uint32_t> elements(ne * width, kPadding);
  std::vector<std::uint8_t> element_nodes(ne);
  for (std::size_t e = 0; e < ne; ++e) {
    element_nodes[e] = static_cast<std::uint8_t>(m.nodes_of(e));
    std::copy(m.element_nodes.begin() + m.element_offset[e], m.element_nodes.begin() + m.element_offset[e + 1],
              elements.begin() + static_cast<std::ptrdiff_t>(e * width));
  }
  std::vector<std::uint32_t> triangles(3 * nt), label(ng), material(ng);
  std::vector<std::uint8_t> kind(ng);
  for (std::size_t t = 0; t < nt; ++t)
    for (int k = 0; k < 3; ++k) triangles[3 * t + static_cast<std::size_t>(k)] = m.triangles[t][static_cast<std::size_t>(k)];
  for (std::size_t g = 0; g < ng; ++g) {
    label[g] = m.grains[g].label;
    kind[g] = static_cast<std::uint8_t>(m.grains[g].kind);
    material[g] = m.grains[g].material;
  }

  io::H5File f = io::H5File::create(path);
  io::write_root_attrs(f, schema::kind::fdem_model);
  f.write(sm::nodes, flatten(m.nodes).data(), {m.nodes.size(), 3}, units("m"));
  f.write(sm::elements, elements.data(), {ne, width});
  f.set_attr(sm::elements, "node_order", std::string("gmsh: corners 0-3, then mid-edge nodes of 01, 12, 20, 30, 32, 31; "
                                                     "4-node rows padded with 4294967295"));
  f.write(sm::element_nodes, element_nodes);
  f.write(sm::element_grain, m.element_grain);
  f.write(sm::triangles, triangles.data(), {nt, 3});
  f.write(sm::triangle_grain, m.triangle_grain);
  f.write(sm::grain_label, label);
  f.write(sm::grain_kind, kind);
  f.set_attr(sm::grain_kind, "codes", std::string("0 rigid, 1 tet4, 2 tet10"));
  f.write(sm::grain_material, material);
  f.write(sm::grain_nodes, ranges(m.grains, &Grain::node_begin, &Grain::node_end).data(), {ng, 2});
  f.write(sm::grain_elements, ranges(m.grains, &Grain::element_begin, &Grain::element_end).data(), {ng, 2});
  f.write(sm::grain_triangles, ranges(m.grains, &Grain::triangle_begin, &Grain::triangle_end).data(), {ng, 2});

  std::vector<std::string> names;
  for (const Material& mat : m.materials) names.push_back(mat.name);
  f.write_strings(sm::material_name, names);
  for (const MaterialColumn& c : kMaterialColumns) {
    std::vector<double> v;
    for (const Material& mat : m.materials) v.push_back(mat.*c.field);
    f.write(material_path(c.name), v, units(c.unit));
  }

  std::vector<std::string> platen_names;
  std::vector<Eigen::Vector3d> points, normals;
  std::vector<double> friction;
  for (const Platen& p : m.platens) {
    platen_names.push_back(p.name);
    points.push_back(p.point);
    normals.push_back(p.normal);
    friction.push_back(p.friction);
  }
  const hsize_t np = m.platens.size();
  f.write_strings(sm::platen_name, platen_names);
  f.write(sm::platen_point, flatten(points).data(), {np, 3}, units("m"));
  f.write(sm::platen_normal, flatten(normals).data(), {np, 3}, units("1"));
  f.write(sm::platen_friction, friction, units("1"));

  if (m.sample) {
    f.ensure_group(sm::sample);
    f.set_attr(sm::sample, sm::sample_axis_xy, std::vector<double>{m.sample->axis_xy.x(), m.sample->axis_xy.y()});
    f.set_attr(sm::sample, sm::sample_radius, m.sample->radius);
    f.set_attr(sm::sample, sm::sample_z_range, std::vector<double>{m.sample->z_min, m.sample->z_max});
    f.set_attr(sm::sample, sm::membrane_thickness, m.sample->membrane_thickness);
  }
  if (extra) extra(f);
  io::write_history(f, history);
}

Model read_model_file(const std::filesystem::path& path) {
  const io::H5File f = io::open_kind(path, schema::kind::fdem_model, "pass the output of shapes2mesh");
  const std::string where = path.string();
  const auto table = [&](const char* name, hsize_t columns) {
    std::vector<hsize_t> dims;
    auto v = f.read<double>(name, &dims);
    if (!(dims.size() == 2 && dims[1] == columns) && !v.empty())
      throw DataError(fmt::format("{}: {} is not a table of {} columns; rebuild the model", where, name, columns));
    std::vector<Eigen::Vector3d> out(v.size() / 3);
    for (std::size_t i = 0; i < out.size(); ++i) out[i] = {v[3 * i], v[3 * i + 1], v[3 * i + 2]};
    return out;
  };
  Model m;
  m.nodes = table(sm::nodes, 3);

  std::vector<hsize_t> dims;
  const auto elements = f.read<std::uint32_t>(sm::elements, &dims);
  const auto element_nodes = f.read<std::uint8_t>(sm::element_nodes);
  const std::size_t ne = element_nodes.size();
  const std::size_t width = dims.size() == 2 ? dims[1] : 0;
  if (dims.size() != 2 || dims[0] != ne || (width != 4 && width != 10))
    throw DataError(where + ": /elements is not one row of 4 or 10 nodes per entry of /element_nodes; rebuild the model");
  m.element_offset.assign(1, 0);
  for (std::size_t e = 0; e < ne; ++e) {
    if (element_nodes[e] > width)
      throw DataError(fmt::format("{}: element {} has more nodes than /elements has columns; rebuild the model", where, e));
    m.element_nodes.insert(m.element_nodes.end(), elements.begin() + static_cast<std::ptrdiff_t>(e * width),
                           elements.begin() + static_cast<std::ptrdiff_t>(e * width + element_nodes[e]));
    m.element_offset.push_back(static_cast<std::uint32_t>(m.element_nodes.size()));
  }
  m.element_grain = f.read<std::uint32_t>(sm::element_grain);
  const auto triangles = f.read<std::uint32_t>(sm::triangles);
  m.triangles.resize(triangles.size() / 3);
  for (std::size_t t = 0; t < m.triangles.size(); ++t) m.triangles[t] = {triangles[3 * t], triangles[3 * t + 1], triangles[3 * t + 2]};
  m.triangle_grain = f.read<std::uint32_t>(sm::triangle_grain);

  const auto label = f.read<std::uint32_t>(sm::grain_label);
  const auto kind = f.read<std::uint8_t>(sm::grain_kind);
  const auto material = f.read<std::uint32_t>(sm::grain_material);
  const auto nodes = f.read<std::uint32_t>(sm::grain_nodes);
  const auto elems = f.read<std::uint32_t>(sm::grain_elements);
  const auto tris = f.read<std::uint32_t>(sm::grain_triangles);
  const std::size_t ng = label.size();
  if (kind.size() != ng || material.size() != ng || nodes.size() != 2 * ng || elems.size() != 2 * ng || tris.size() != 2 * ng)
    throw DataError(where + ": the /grains columns differ in length; rebuild the model");
  m.grains.resize(ng);
  for (std::size_t g = 0; g < ng; ++g) {
    if (kind[g] > 2) throw DataError(fmt::format("{}: grain {} has the unknown kind {}; rebuild the model", where, g, kind[g]));
    m.grains[g] = Grain{label[g], static_cast<GrainKind>(kind[g]), material[g], nodes[2 * g], nodes[2 * g + 1],
                        elems[2 * g], elems[2 * g + 1], tris[2 * g], tris[2 * g + 1]};
  }

  const auto names = f.read_strings(sm::material_name);
  m.materials.assign(names.size(), Material{});
  for (std::size_t k = 0; k < names.size(); ++k) m.materials[k].name = names[k];
  for (const MaterialColumn& c : kMaterialColumns) {
    const auto v = f.read<double>(material_path(c.name));
    if (v.size() != names.size())
      throw DataError(fmt::format("{}: {} does not have one value per material; rebuild the model", where, material_path(c.name)));
    for (std::size_t k = 0; k < v.size(); ++k) m.materials[k].*c.field = v[k];
  }

  const auto platen_names = f.read_strings(sm::platen_name);
  const auto points = table(sm::platen_point, 3), normals = table(sm::platen_normal, 3);
  const auto friction = f.read<double>(sm::platen_friction);
  if (points.size() != platen_names.size() || normals.size() != platen_names.size() || friction.size() != platen_names.size())
    throw DataError(where + ": the /platens columns differ in length; rebuild the model");
  for (std::size_t p = 0; p < platen_names.size(); ++p) m.platens.push_back({platen_names[p], points[p], normals[p], friction[p]});

  if (f.exists(sm::sample)) {
    const auto axis = f.attr_doubles(sm::sample, sm::sample_axis_xy), z = f.attr_doubles(sm::sample, sm::sample_z_range);
    const auto radius = f.attr_doubles(sm::sample, sm::sample_radius);
    const auto thickness = f.attr_doubles(sm::sample, sm::membrane_thickness);
    if (axis.size() != 2 || z.size() != 2 || radius.size() != 1 || thickness.size() != 1)
      throw DataError(where + ": /sample lacks its axis_xy, radius, z_range or membrane_thickness attribute; rebuild the model");
    m.sample = SampleCylinder{{axis[0], axis[1]}, radius[0], z[0], z[1], thickness[0]};
  }
  validate_model(m, where);
  return m;
}

namespace {

/// Rows of the first column of `t` whose length differs from its labels', if any.
std::optional<std::size_t> mismatched_rows(const MeshQualityTable& t) {
  for (const std::size_t size : {t.min_dihedral.size(), t.min_altitude.size(), t.median_altitude.size(), t.worst_element.size(),
                                 t.step_ratio.size(), t.below_thresholds.size()})
    if (size != t.label.size()) return size;
  return std::nullopt;
}

}  // namespace

void write_mesh_quality(io::H5File& f, const MeshQualityTable& t) {
  namespace q = schema::fdem_model::mesh_quality;
  if (const auto rows = mismatched_rows(t))
    throw UsageError(fmt::format("write_mesh_quality: a column of {} rows beside {} labels", *rows, t.label.size()));
  f.write(q::label, t.label);
  f.write(q::min_dihedral, t.min_dihedral, units("degree"));
  f.write(q::min_altitude, t.min_altitude, units("m"));
  f.write(q::median_altitude, t.median_altitude, units("m"));
  f.write(q::worst_element, t.worst_element);
  f.write(q::step_ratio, t.step_ratio, units("1"));
  f.write(q::below_thresholds, t.below_thresholds);
  f.set_attr(q::group, q::min_dihedral_threshold, t.min_dihedral_threshold);
  f.set_attr(q::group, q::min_altitude_ratio_threshold, t.min_altitude_ratio_threshold);
}

std::optional<MeshQualityTable> read_mesh_quality(const std::filesystem::path& path) {
  namespace q = schema::fdem_model::mesh_quality;
  const io::H5File f = io::open_kind(path, schema::kind::fdem_model, "pass the output of shapes2mesh");
  if (!f.exists(q::group)) return std::nullopt;
  MeshQualityTable t;
  t.label = f.read<std::uint32_t>(q::label);
  t.min_dihedral = f.read<double>(q::min_dihedral);
  t.min_altitude = f.read<double>(q::min_altitude);
  t.median_altitude = f.read<double>(q::median_altitude);
  t.worst_element = f.read<std::uint64_t>(q::worst_element);
  t.step_ratio = f.read<double>(q::step_ratio);
  t.below_thresholds = f.read<std::uint64_t>(q::below_thresholds);
  t.min_dihedral_threshold = f.attr_double(q::group, q::min_dihedral_threshold);
  t.min_altitude_ratio_threshold = f.attr_double(q::group, q::min_altitude_ratio_threshold);
  if (const auto rows = mismatched_rows(t))
    throw DataError(fmt::format("{}: /mesh/quality has a column of {} rows beside {} labels; rebuild the model with shapes2mesh",
                                path.string(), *rows, t.label.size()));
  return t;
}

io::VtkUnstructuredGrid model_grid(const Model& m, std::span<const Eigen::Vector3d> positions) {
  if (!positions.empty() && positions.size() != m.nodes.size())
    throw UsageError(fmt::format("model_grid: {} positions for {} nodes", positions.size(), m.nodes.size()));
  const std::span<const Eigen::Vector3d> x = positions.empty() ? std::span<const Eigen::Vector3d>(m.nodes) : positions;
  io::VtkUnstructuredGrid g;
  g.points.reserve(3 * x.size());
  for (const Eigen::Vector3d& p : x) g.points.insert(g.points.end(), {p.x(), p.y(), p.z()});
  io::VtkArray node_grain{"grain", 1, std::vector<double>(x.size())};
  io::VtkArray cell_grain{"grain", 1, {}}, cell_label{"label", 1, {}};
  for (std::size_t gi = 0; gi < m.grains.size(); ++gi) {
    const Grain& gr = m.grains[gi];
    std::fill(node_grain.values.begin() + gr.node_begin, node_grain.values.begin() + gr.node_end, static_cast<double>(gi));
  }
  g.connectivity.reserve(m.element_nodes.size());
  for (std::size_t e = 0; e < m.element_count(); ++e) {
    const std::uint32_t* n = m.element_nodes.data() + m.element_offset[e];
    const bool quadratic = m.nodes_of(e) == 10;
    for (std::size_t k = 0; k < m.nodes_of(e); ++k) g.connectivity.push_back(n[quadratic ? io::kGmshToVtkTet10[k] : k]);
    g.offsets.push_back(static_cast<std::int64_t>(g.connectivity.size()));
    g.types.push_back(quadratic ? io::kVtkQuadraticTetra : io::kVtkTetra);
    cell_grain.values.push_back(m.element_grain[e]);
    cell_label.values.push_back(m.grains[m.element_grain[e]].label);
  }
  g.point_data.push_back(std::move(node_grain));
  g.cell_data.push_back(std::move(cell_grain));
  g.cell_data.push_back(std::move(cell_label));
  return g;
}

void write_model_msh(const std::filesystem::path& path, const Model& m) {
  std::ofstream out(path);
  out << "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n" << m.nodes.size() << "\n";
  for (std::size_t i = 0; i < m.nodes.size(); ++i)
    out << fmt::format("{} {:.17g} {:.17g} {:.17g}\n", i + 1, m.nodes[i].x(), m.nodes[i].y(), m.nodes[i].z());
  out << "$EndNodes\n$Elements\n" << m.element_count() + m.triangles.size() << "\n";
  std::size_t id = 1;
  for (std::size_t e = 0; e < m.element_count(); ++e) {
    const std::uint32_t g = m.element_grain[e];
    out << fmt::format("{} {} 2 {} {}", id++, m.nodes_of(e) == 10 ? 11 : 4, m.grains[g].label, g + 1);
    for (std::uint32_t k = m.element_offset[e]; k < m.element_offset[e + 1]; ++k) out << ' ' << m.element_nodes[k] + 1;
    out << '\n';
  }
  for (std::size_t t = 0; t < m.triangles.size(); ++t) {
    const std::uint32_t g = m.triangle_grain[t];
    out << fmt::format("{} 2 2 {} {} {} {} {}\n", id++, m.grains[g].label, g + 1, m.triangles[t][0] + 1,
                       m.triangles[t][1] + 1, m.triangles[t][2] + 1);
  }
  out << "$EndElements\n";
  if (!out) throw DataError(path.string() + ": cannot write the gmsh file; check that the folder is writable");
}

}  // namespace graintwin::fdem
