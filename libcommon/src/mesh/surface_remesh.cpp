// CGAL's isotropic remeshing and AABB tree (Debian's libcgal-dev 5.5, header-only), kept to this
// one file: compiling CGAL is slow, and nothing else needs it.
#include "graintwin/mesh/surface_remesh.hpp"

#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/remesh.h>
#include <CGAL/Surface_mesh.h>

#include <memory>

#include <fmt/format.h>

#include "graintwin/core/error.hpp"

namespace graintwin::mesh {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;

Mesh to_cgal(const TriangleSurface& s) {
  Mesh m;
  std::vector<Mesh::Vertex_index> v;
  v.reserve(s.vertices.size());
  for (const auto& p : s.vertices) v.push_back(m.add_vertex(Point(p.x(), p.y(), p.z())));
  for (const auto& t : s.triangles)
    if (m.add_face(v[static_cast<std::size_t>(t[0])], v[static_cast<std::size_t>(t[1])], v[static_cast<std::size_t>(t[2])]) ==
        Mesh::null_face())
      throw DataError("remesh_isotropic: the surface is not a closed oriented manifold (a triangle could not be added); check_surface it first");
  return m;
}

TriangleSurface from_cgal(const Mesh& m) {
  TriangleSurface s;
  std::vector<int> index(m.number_of_vertices() + m.number_of_removed_vertices(), -1);
  for (const auto v : m.vertices()) {
    index[v.idx()] = static_cast<int>(s.vertices.size());
    const Point& p = m.point(v);
    s.vertices.emplace_back(p.x(), p.y(), p.z());
  }
  for (const auto f : m.faces()) {
    std::array<int, 3> t{};
    int k = 0;
    for (const auto v : CGAL::vertices_around_face(m.halfedge(f), m)) {
      if (k == 3) throw DataError("remesh_isotropic: CGAL returned a face that is not a triangle");
      t[static_cast<std::size_t>(k++)] = index[v.idx()];
    }
    s.triangles.push_back(t);
  }
  return s;
}

}  // namespace

TriangleSurface remesh_isotropic(const TriangleSurface& surface, double edge, int iterations) {
  if (!(edge > 0.0) || iterations < 1)
    throw UsageError(fmt::format("remesh_isotropic: the edge length must be positive and the iterations at least 1 (got {} and {})", edge, iterations));
  Mesh m = to_cgal(surface);
  CGAL::Polygon_mesh_processing::isotropic_remeshing(faces(m), edge, m, CGAL::parameters::number_of_iterations(static_cast<unsigned>(iterations)));
  return from_cgal(m);
}

std::function<Eigen::Vector3d(const Eigen::Vector3d&)> closest_point_on(const TriangleSurface& surface) {
  using Primitive = CGAL::AABB_face_graph_triangle_primitive<Mesh>;
  using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;
  struct Held {
    Mesh mesh;
    Tree tree;
  };
  auto held = std::make_shared<Held>();
  held->mesh = to_cgal(surface);
  held->tree.insert(faces(held->mesh).first, faces(held->mesh).second, held->mesh);
  held->tree.accelerate_distance_queries();
  return [held](const Eigen::Vector3d& p) {
    const Point q = held->tree.closest_point(Point(p.x(), p.y(), p.z()));
    return Eigen::Vector3d(q.x(), q.y(), q.z());
  };
}

}  // namespace graintwin::mesh
