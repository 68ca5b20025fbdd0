#include "graintwin/mesh/gmsh_adapter.hpp"

#include <gmsh.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <mutex>

#include <fmt/format.h>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/element.hpp"
#include "gmsh_request.hpp"

namespace graintwin::mesh {
namespace {

std::mutex& gmsh_lock() {
  static std::mutex m;
  return m;
}

/// gmsh::initialize once per process, quiet; never finalised (gmsh's own statics outlive ours).
void ensure_initialized() {
  static const bool done = [] {
    gmsh::initialize(0, nullptr, false);
    gmsh::option::setNumber("General.Terminal", 0);
    gmsh::option::setNumber("General.Verbosity", 1);
    gmsh::option::setNumber("General.NumThreads", 1);
    return true;
  }();
  (void)done;
}

std::string last_gmsh_error() {
  std::string e;
  try {
    gmsh::logger::getLastError(e);
  } catch (...) {
  }
  return e.empty() ? "no message" : e;
}

/// The current gmsh model's 3-D elements of `order` as a TetMesh (nodes used by them only, in tag
/// order), every element turned to positive orientation.
TetMesh extract(int order) {
  const int type = order == 2 ? 11 : 4;
  std::vector<std::size_t> element_tags, element_nodes;
  gmsh::model::mesh::getElementsByType(type, element_tags, element_nodes, -1);
  std::vector<std::size_t> node_tags;
  std::vector<double> coords, parametric;
  gmsh::model::mesh::getNodes(node_tags, coords, parametric, -1, -1, false, false);
  std::map<std::size_t, std::size_t> row;  // tag -> row of coords
  for (std::size_t i = 0; i < node_tags.size(); ++i) row[node_tags[i]] = i;
  std::map<std::size_t, std::uint32_t> index;  // used tags -> compact index, in tag order
  for (std::size_t t : element_nodes) index.emplace(t, 0);
  TetMesh m;
  m.nodes_per_element = order == 2 ? 10 : 4;
  for (auto& [tag, i] : index) {
    const auto r = row.find(tag);
    if (r == row.end()) throw DataError("gmsh returned an element with an unknown node");
    i = static_cast<std::uint32_t>(m.nodes.size());
    m.nodes.emplace_back(coords[3 * r->second], coords[3 * r->second + 1], coords[3 * r->second + 2]);
  }
  m.elements.reserve(element_nodes.size());
  for (std::size_t t : element_nodes) m.elements.push_back(index[t]);
  for (std::size_t e = 0; e < m.element_count(); ++e) {
    std::uint32_t* n = m.elements.data() + e * static_cast<std::size_t>(m.nodes_per_element);
    const Eigen::Vector3d& a = m.nodes[n[0]];
    if ((m.nodes[n[1]] - a).cross(m.nodes[n[2]] - a).dot(m.nodes[n[3]] - a) < 0) {
      // Swapping corners 1 and 2 swaps the mid-edge nodes of 01/20 and 31/32 (gmsh order).
      std::swap(n[1], n[2]);
      if (m.nodes_per_element == 10) std::swap(n[4], n[6]), std::swap(n[8], n[9]);
    }
  }
  return m;
}

std::size_t count_inverted(const TetMesh& m) {
  std::size_t n = 0;
  for (std::size_t e = 0; e < m.element_count(); ++e) n += jacobian_ratio(m, e) <= 0.0;
  return n;
}

double corner_six_volume(const TetMesh& m, std::size_t e) {
  const std::uint32_t* n = m.element(e);
  const Eigen::Vector3d& a = m.nodes[n[0]];
  return (m.nodes[n[1]] - a).cross(m.nodes[n[2]] - a).dot(m.nodes[n[3]] - a);
}

/// Moves every boundary node of `m` onto the exact surface. An element whose corners that leaves
/// flat or inverted gets its corners back where gmsh put them (on the triangulated surface, a
/// small fraction of h away); then, for 10-node elements, mid-edge nodes are pulled back where the
/// curving distorts an element.
void snap_to_surface(TetMesh& m, const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& project, TetReport& report) {
  const std::vector<Eigen::Vector3d> before = m.nodes;
  std::vector<char> moved(m.nodes.size(), 0);
  for (const auto& t : boundary_triangles(m))
    for (std::uint32_t v : t) moved[v] = 1;
  for (std::size_t v = 0; v < m.nodes.size(); ++v)
    if (moved[v]) m.nodes[v] = project(m.nodes[v]);
  for (bool again = true; again;) {  // restoring a corner can flatten a neighbour, rarely
    again = false;
    for (std::size_t e = 0; e < m.element_count(); ++e) {
      if (corner_six_volume(m, e) > 0.0) continue;
      for (int k = 0; k < 4; ++k) {
        const std::uint32_t v = m.element(e)[k];
        if (moved[v]) m.nodes[v] = before[v], moved[v] = 0, ++report.unsnapped, again = true;
      }
    }
  }
  report.inverted_after_curving = count_inverted(m);
  if (m.nodes_per_element == 10)
    report.straightened = pull_back_curved(m);
  report.inverted = count_inverted(m);
}

/// Meshes the current gmsh model's volume at the request's size and order, with the Jacobian check.
TetMesh generate(const detail::GmshRequest& q, TetReport& report) {
  // gmsh clamps every size, the callback's too, to [MeshSizeMin, MeshSizeMax].
  gmsh::option::setNumber("Mesh.MeshSizeMin", q.size_at ? 0.0 : q.size);
  gmsh::option::setNumber("Mesh.MeshSizeMax", q.size);
  gmsh::option::setNumber("Mesh.MeshSizeFromCurvature", 0);
  gmsh::option::setNumber("Mesh.Algorithm3D", 1);
  if (q.size_at) {
    gmsh::model::mesh::setSizeCallback(
        [&q](int, int, double x, double y, double z) { return std::min(q.size, q.size_at(Eigen::Vector3d(x, y, z))); });
    struct Unset {  // the callback refers to q: gone before q is, even when generate throws
      ~Unset() {
        try {
          gmsh::model::mesh::removeSizeCallback();
        } catch (...) {
        }
      }
    } unset;
    gmsh::model::mesh::generate(3);
  } else {
    gmsh::model::mesh::generate(3);
  }
  if (q.order == 1) return extract(1);
  if (q.straight) {
    gmsh::option::setNumber("Mesh.SecondOrderLinear", 1);
    gmsh::model::mesh::setOrder(2);
    gmsh::option::setNumber("Mesh.SecondOrderLinear", 0);
    return extract(2);
  }
  gmsh::model::mesh::setOrder(2);
  TetMesh m = extract(2);
  report.inverted_after_curving = count_inverted(m);
  if (report.inverted_after_curving > 0 && q.fix_inverted) {
    report.optimized = true;
    try {
      gmsh::model::mesh::optimize("HighOrder");
    } catch (...) {
      // It throws when it cannot reach its target everywhere but still improves the mesh; what is
      // left inverted is straightened below.
    }
    m = extract(2);
  }
  if (count_inverted(m) > 0) report.straightened = straighten_distorted(m, 1e-300, 1.0, 4);
  report.inverted = count_inverted(m);
  return m;
}

/// Sets up the request's body in the current (empty) model.
void build(const detail::GmshRequest& q) {
  if (q.body == detail::GmshRequest::Body::ellipsoid) {
    const int v = gmsh::model::occ::addSphere(0, 0, 0, 1);
    if (q.semi_axes != Eigen::Vector3d::Ones())
      gmsh::model::occ::dilate({{3, v}}, 0, 0, 0, q.semi_axes.x(), q.semi_axes.y(), q.semi_axes.z());
    gmsh::model::occ::synchronize();
    return;
  }
  const TriangleSurface& surface = q.surface;
  const int s = gmsh::model::addDiscreteEntity(2);
  std::vector<std::size_t> tags(surface.vertices.size());
  std::vector<double> xyz;
  xyz.reserve(3 * tags.size());
  for (std::size_t i = 0; i < tags.size(); ++i) {
    tags[i] = i + 1;
    xyz.insert(xyz.end(), {surface.vertices[i].x(), surface.vertices[i].y(), surface.vertices[i].z()});
  }
  gmsh::model::mesh::addNodes(2, s, tags, xyz);
  std::vector<std::size_t> connectivity;
  connectivity.reserve(3 * surface.triangles.size());
  for (const auto& t : surface.triangles)
    for (int k : t) connectivity.push_back(static_cast<std::size_t>(k) + 1);
  gmsh::model::mesh::addElementsByType(s, 2, {}, connectivity);
  if (!q.keep_surface) {
    // forReparametrization splits the closed surface into patches that each have one map.
    gmsh::model::mesh::classifySurfaces(40.0 * M_PI / 180.0, true, true, M_PI);
    gmsh::model::mesh::createGeometry();
  }
  gmsh::vectorpair surfaces;
  gmsh::model::getEntities(surfaces, 2);
  std::vector<int> loop;
  for (const auto& [dim, tag] : surfaces) loop.push_back(tag);
  const int l = gmsh::model::geo::addSurfaceLoop(loop);
  gmsh::model::geo::addVolume({l});
  gmsh::model::geo::synchronize();
}

void check_options(const TetOptions& o) {
  if (!(o.size > 0.0) || (o.order != 1 && o.order != 2))
    throw UsageError(fmt::format("tetrahedralize: the element size must be positive and the order 1 or 2 (got {} and {})", o.size, o.order));
}

/// Runs the request (here or in a worker), then snaps onto the exact surface when asked and removes slivers.
TetMesh run(detail::GmshRequest& q, const TetOptions& o, TetReport* report, GmshWorkers* workers,
            const std::function<void(TetMesh&)>& place) {
  TetReport local;
  TetReport& r = report ? *report : local;
  r = TetReport{};
  q.size = o.size, q.order = o.order, q.fix_inverted = o.fix_inverted, q.straight = o.order == 2 && o.project;
  q.keep_surface = o.keep_surface && q.body == detail::GmshRequest::Body::surface;
  if (q.size_at && workers) throw UsageError("tetrahedralize: graded sizes (size_at) run in this process only, not in gmsh workers");
  if (!workers && std::chrono::steady_clock::now() >= o.deadline)
    throw GmshOverrun("the grain's time budget was spent before gmsh could start");
  TetMesh m = workers ? workers->run(q, r, o.deadline) : detail::run_gmsh(q, r);
  if (place) place(m);
  if (o.project) snap_to_surface(m, o.project, r);
  r.slivers = remove_slivers(m, o.slivers, o.project);
  return m;
}

}  // namespace

namespace detail {

TetMesh run_gmsh_unlocked(const GmshRequest& q, TetReport& r) {
  ensure_initialized();
  const char* what = q.body == GmshRequest::Body::ellipsoid ? "the ellipsoid" : "the surface";
  const auto t0 = std::chrono::steady_clock::now();
  gmsh::model::add("graintwin");
  TetMesh m;
  try {
    build(q);
    m = generate(q, r);
    gmsh::model::remove();
  } catch (...) {
    const std::string message = last_gmsh_error();
    try {
      gmsh::model::remove();
    } catch (...) {
    }
    throw DataError(fmt::format("gmsh could not mesh {} ({}); check the surface or try another element size", what, message));
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (m.element_count() == 0)
    throw DataError(fmt::format("gmsh made no tetrahedra for {}; the element size may be larger than the body", what));
  return m;
}

TetMesh run_gmsh(const GmshRequest& q, TetReport& r) {
  std::lock_guard lock(gmsh_lock());
  return run_gmsh_unlocked(q, r);
}

}  // namespace detail

TetMesh tetrahedralize(const TriangleSurface& surface, const TetOptions& options, TetReport* report, GmshWorkers* workers) {
  check_options(options);
  detail::GmshRequest q;
  q.surface = surface;
  q.size_at = options.size_at;
  return run(q, options, report, workers, {});
}

TetMesh mesh_ellipsoid(const Eigen::Vector3d& centre, const Eigen::Vector3d& semi_axes, const Eigen::Quaterniond& rotation,
                       const TetOptions& options, TetReport* report, GmshWorkers* workers) {
  check_options(options);
  if (!(semi_axes.minCoeff() > 0.0)) throw UsageError("mesh_ellipsoid: the semi-axes must be positive");
  // Meshed as the body scaled to unit largest semi-axis so the size is in its own units, then
  // scaled back, rotated and placed (before any snapping, which works in place).
  const double scale = semi_axes.maxCoeff();
  detail::GmshRequest q;
  q.body = detail::GmshRequest::Body::ellipsoid;
  q.semi_axes = semi_axes / scale;
  TetOptions o = options;
  o.size = options.size / scale;
  const Eigen::Matrix3d turn = rotation.normalized().toRotationMatrix();
  if (options.size_at)
    q.size_at = [&](const Eigen::Vector3d& p) { return options.size_at(centre + turn * (scale * p)) / scale; };
  return run(q, o, report, workers, [&](TetMesh& m) {
    for (Eigen::Vector3d& p : m.nodes) p = centre + turn * (scale * p);
  });
}

}  // namespace graintwin::mesh
