#include "graintwin/shape/isosurface.hpp"

#include <Eigen/Geometry>

namespace graintwin::shape {
namespace {

// Cube corner c has offset (c & 1, (c >> 1) & 1, (c >> 2) & 1) in (x, y, z). The six Kuhn
// tetrahedra walk from corner 0 to corner 7 adding one axis at a time, in each axis order.
constexpr std::array<std::array<int, 4>, 6> kTets{{
    {0, 1, 3, 7}, {0, 1, 5, 7}, {0, 2, 3, 7}, {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 4, 6, 7},
}};

struct Corner {
  Eigen::Vector3d p;
  double f;
};

Eigen::Vector3d cut(const Corner& in, const Corner& out, double iso) {
  const double t = (iso - in.f) / (out.f - in.f);
  return in.p + t * (out.p - in.p);
}

/// Adds triangle (a, b, c), flipped if needed so its normal points from `inside` to `outside`.
void add(Eigen::Vector3d a, Eigen::Vector3d b, Eigen::Vector3d c, const Eigen::Vector3d& inside,
         const Eigen::Vector3d& outside, IsoMeasures& m, const std::function<void(const Triangle&)>& emit) {
  Eigen::Vector3d n = (b - a).cross(c - a);
  if (n.dot(outside - inside) < 0) {
    std::swap(b, c);
    n = -n;
  }
  m.area += 0.5 * n.norm();
  m.volume += a.dot(n) / 6.0;  // signed volume of the tetrahedron (0, a, b, c)
  ++m.triangles;
  if (emit) emit({a, b, c});
}

void march_tet(const std::array<Corner, 4>& v, double iso, IsoMeasures& m,
               const std::function<void(const Triangle&)>& emit) {
  std::array<int, 4> in{}, out{};
  int ni = 0, no = 0;
  for (int k = 0; k < 4; ++k) (v[k].f >= iso ? in[ni++] : out[no++]) = k;
  if (ni == 0 || no == 0) return;
  if (ni == 1 || no == 1) {
    // One vertex alone on its side: one triangle around it.
    const bool lone_inside = ni == 1;
    const Corner& lone = v[lone_inside ? in[0] : out[0]];
    const auto& others = lone_inside ? out : in;
    Eigen::Vector3d p[3];
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (int k = 0; k < 3; ++k) {
      p[k] = lone_inside ? cut(lone, v[others[k]], iso) : cut(v[others[k]], lone, iso);
      centre += v[others[k]].p / 3.0;
    }
    if (lone_inside) add(p[0], p[1], p[2], lone.p, centre, m, emit);
    else add(p[0], p[1], p[2], centre, lone.p, m, emit);
    return;
  }
  // Two inside (a, b), two outside (c, d): the quad a-c, a-d, b-d, b-c.
  const Corner &a = v[in[0]], &b = v[in[1]], &c = v[out[0]], &d = v[out[1]];
  const Eigen::Vector3d ac = cut(a, c, iso), ad = cut(a, d, iso), bd = cut(b, d, iso), bc = cut(b, c, iso);
  const Eigen::Vector3d inside = 0.5 * (a.p + b.p), outside = 0.5 * (c.p + d.p);
  add(ac, ad, bd, inside, outside, m, emit);
  add(ac, bd, bc, inside, outside, m, emit);
}

}  // namespace

IsoMeasures isosurface(const Volume<float>& field, float iso, const std::function<void(const Triangle&)>& emit) {
  IsoMeasures m;
  const Shape3& s = field.shape();
  if (s[0] < 2 || s[1] < 2 || s[2] < 2) return m;
  for (std::size_t z = 0; z + 1 < s[0]; ++z)
    for (std::size_t y = 0; y + 1 < s[1]; ++y)
      for (std::size_t x = 0; x + 1 < s[2]; ++x) {
        std::array<double, 8> f;
        int inside = 0;
        for (int k = 0; k < 8; ++k) {
          f[k] = field(z + ((k >> 2) & 1), y + ((k >> 1) & 1), x + (k & 1));
          inside += f[k] >= iso;
        }
        if (inside == 0 || inside == 8) continue;  // most cubes: positions are only needed on the surface
        std::array<Corner, 8> c;
        for (int k = 0; k < 8; ++k) {
          const Vec3 p = field.position_xyz(static_cast<double>(z + ((k >> 2) & 1)), static_cast<double>(y + ((k >> 1) & 1)),
                                            static_cast<double>(x + (k & 1)));
          c[k] = {Eigen::Vector3d(p[0], p[1], p[2]), f[k]};
        }
        for (const auto& t : kTets) march_tet({c[t[0]], c[t[1]], c[t[2]], c[t[3]]}, iso, m, emit);
      }
  return m;
}

}  // namespace graintwin::shape
