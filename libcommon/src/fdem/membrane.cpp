#include "graintwin/fdem/membrane.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "graintwin/core/error.hpp"

namespace graintwin::fdem {
namespace {

constexpr double kSqrt3 = 1.7320508075688772;
/// Fraction of the lattice's critical step that membrane_stable_time_step returns.
constexpr double kMembraneSafety = 0.8;

/// Ball centre moved towards the axis by the ball radius: a point of the inner surface.
Eigen::Vector3d inner_point(const Membrane& m, const Eigen::Vector3d& x) {
  Eigen::Vector2d rho(x[0] - m.axis_xy[0], x[1] - m.axis_xy[1]);
  const double len = rho.norm();
  if (len > 0) rho *= (len - m.ball_radius) / len;
  return {m.axis_xy[0] + rho[0], m.axis_xy[1] + rho[1], x[2]};
}

/// Below this many balls a parallel region costs more than the loop.
constexpr std::size_t kParallelBalls = 2048;

/// A polygon of at most 5 corners: a triangle clipped by two parallel planes. Fixed storage, so
/// the volumes, computed every step of a triaxial test, allocate nothing per triangle.
struct SlabPolygon {
  std::array<Eigen::Vector3d, 5> corner;
  std::size_t size = 0;
  std::span<const Eigen::Vector3d> points() const { return {corner.data(), size}; }
};

/// `poly` clipped to z >= z0 (keep_above) or z <= z0 (Sutherland-Hodgman).
SlabPolygon clip_at(const SlabPolygon& poly, double z0, bool keep_above) {
  SlabPolygon out;
  const auto inside = [&](const Eigen::Vector3d& p) { return keep_above ? p[2] >= z0 : p[2] <= z0; };
  for (std::size_t i = 0; i < poly.size; ++i) {
    const Eigen::Vector3d& a = poly.corner[i];
    const Eigen::Vector3d& b = poly.corner[(i + 1) % poly.size];
    if (inside(a)) out.corner[out.size++] = a;
    if (inside(a) != inside(b)) {
      Eigen::Vector3d c = a + (b - a) * ((z0 - a[2]) / (b[2] - a[2]));
      c[2] = z0;
      out.corner[out.size++] = c;
    }
  }
  return out;
}

/// A triangle of the inner surface clipped to z_bottom <= z <= z_top; points on a plane get exactly
/// that plane's z, so the cap edges can be recognised. A triangle inside the slab comes back as is.
SlabPolygon clip_to_slab(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c, double z_bottom,
                         double z_top) {
  SlabPolygon poly{{a, b, c}, 3};
  const auto within = [&](const Eigen::Vector3d& p) { return p[2] >= z_bottom && p[2] <= z_top; };
  if (within(a) && within(b) && within(c)) return poly;
  poly = clip_at(poly, z_bottom, true);
  if (poly.size >= 3) poly = clip_at(poly, z_top, false);
  return poly;
}

/// Every lateral triangle of the inner surface clipped to the slab, in triangle order (clipped in
/// parallel; the sums over them stay serial, in that order); DataError when the membrane does not
/// span the slab (the surface would not be closed by the caps).
std::vector<SlabPolygon> clipped_triangles(const Membrane& m, std::span<const Eigen::Vector3d> x, double z_bottom, double z_top) {
  if (!(z_bottom < z_top)) throw UsageError("the platens must satisfy z_bottom < z_top to enclose a volume");
  double lowest_top = std::numeric_limits<double>::infinity(), highest_bottom = -lowest_top;
  for (std::size_t i = 0; i < m.per_ring; ++i) {
    highest_bottom = std::max(highest_bottom, x[i][2]);
    lowest_top = std::min(lowest_top, x[(m.rings - 1) * m.per_ring + i][2]);
  }
  if (!(highest_bottom < z_bottom && lowest_top > z_top))
    throw DataError(fmt::format("the membrane (end rings up to z = {:.4g} m and from z = {:.4g} m) does not span the "
                                "platens at z = {:.4g} and {:.4g} m; extend it beyond both platens",
                                highest_bottom, lowest_top, z_bottom, z_top));
  const bool parallel = x.size() >= kParallelBalls;
  std::vector<Eigen::Vector3d> inner(x.size());
#pragma omp parallel for schedule(static) if (parallel)
  for (std::size_t b = 0; b < x.size(); ++b) inner[b] = inner_point(m, x[b]);
  std::vector<SlabPolygon> out(m.triangles.size());
#pragma omp parallel for schedule(static) if (parallel)
  for (std::size_t k = 0; k < m.triangles.size(); ++k) {
    const auto& t = m.triangles[k];
    out[k] = clip_to_slab(inner[t[0]], inner[t[1]], inner[t[2]], z_bottom, z_top);
  }
  return out;
}

/// For each of `balls` balls, the items (bonds or triangles) that hold it, ascending, as offsets
/// and a flat list.
template <std::size_t N>
void incidence(std::size_t balls, const std::vector<std::array<std::uint32_t, N>>& items, std::vector<std::uint32_t>& offset,
               std::vector<std::uint32_t>& list) {
  offset.assign(balls + 1, 0);
  for (const auto& item : items)
    for (const std::uint32_t b : item) ++offset[b + 1];
  for (std::size_t b = 0; b < balls; ++b) offset[b + 1] += offset[b];
  list.resize(offset.back());
  std::vector<std::uint32_t> fill(offset.begin(), offset.end() - 1);
  for (std::uint32_t k = 0; k < items.size(); ++k)
    for (const std::uint32_t b : items[k]) list[fill[b]++] = k;
}

}  // namespace

BondStiffness bond_stiffness(const MembraneMaterial& m) {
  if (!(m.young > 0) || !std::isfinite(m.young)) throw UsageError("the membrane's Young modulus must be positive; latex is about 1.25 MPa");
  if (!(m.thickness > 0) || !std::isfinite(m.thickness)) throw UsageError("the membrane thickness must be positive; latex membranes are 0.3-1 mm");
  if (!(m.density > 0) || !std::isfinite(m.density)) throw UsageError("the membrane density must be positive; latex is about 1000 kg/m^3");
  if (!(m.poisson > -1.0))
    throw UsageError(fmt::format("the membrane's Poisson ratio {} must be above -1", m.poisson));
  if (m.poisson > 1.0 / 3.0)
    throw UsageError(fmt::format(
        "the membrane's Poisson ratio {} is above 1/3, which a triangular spring lattice cannot reach (the shear spring "
        "K_s = E t (1 - 3 nu) / (sqrt(3) (1 - nu^2)) would be negative); use at most 1/3 (the membrane paper uses 0.2)",
        m.poisson));
  const double nu = m.poisson, et = m.young * m.thickness;
  return {et / (kSqrt3 * (1 - nu)), et * (1 - 3 * nu) / (kSqrt3 * (1 - nu * nu))};
}

double lattice_poisson(const BondStiffness& k) { return (k.normal - k.shear) / (3 * k.normal + k.shear); }

double lattice_young_thickness(const BondStiffness& k) {
  return 2 * kSqrt3 * k.normal * (k.normal + k.shear) / (3 * k.normal + k.shear);
}

double choose_ball_radius(double membrane_radius, double d50) {
  if (!(membrane_radius > 0) || !(d50 > 0)) throw UsageError("the membrane radius and d50 must be positive to size the membrane balls");
  return std::clamp(d50 / 3.0, membrane_radius / kMaxRadiusRatio, membrane_radius / kMinRadiusRatio);
}

Membrane build_membrane(const MembraneMaterial& material, const Eigen::Vector2d& axis_xy, double radius, double z_min,
                        double z_max, double ball_radius) {
  if (!(radius > 0) || !(ball_radius > 0) || !std::isfinite(radius) || !std::isfinite(ball_radius))
    throw UsageError("the membrane radius and ball radius must be positive");
  if (!(z_max > z_min)) throw UsageError("the membrane needs z_max > z_min");
  Membrane m;
  m.material = material;
  m.stiffness = bond_stiffness(material);
  m.axis_xy = axis_xy;
  m.radius = radius;
  m.ball_radius = ball_radius;
  const double circumference = 2 * std::numbers::pi * radius;
  m.per_ring = static_cast<std::size_t>(std::lround(circumference / (2 * ball_radius)));
  if (m.per_ring < 12)
    throw UsageError(fmt::format("a membrane of radius {:.4g} m with balls of radius {:.4g} m has {} balls per ring; it "
                                 "needs at least 12 (radius ratio above about 4)", radius, ball_radius, m.per_ring));
  const double spacing = circumference / static_cast<double>(m.per_ring);
  const double dz = spacing * kSqrt3 / 2;
  m.rings = static_cast<std::size_t>(std::ceil((z_max - z_min) / dz - 1e-9)) + 1;
  m.ball_mass = material.density * material.thickness * kSqrt3 / 2 * spacing * spacing;
  m.ball_inertia = 0.4 * m.ball_mass * ball_radius * ball_radius;
  const std::size_t n = m.per_ring;
  const double step = 2 * std::numbers::pi / static_cast<double>(n);
  for (std::size_t k = 0; k < m.rings; ++k)
    for (std::size_t i = 0; i < n; ++i) {
      const double theta = (static_cast<double>(i) + 0.5 * static_cast<double>(k % 2)) * step;
      m.reference.emplace_back(axis_xy[0] + radius * std::cos(theta), axis_xy[1] + radius * std::sin(theta),
                               z_min + static_cast<double>(k) * dz);
    }
  const auto id = [n](std::size_t k, std::size_t i) { return static_cast<std::uint32_t>(k * n + i % n); };
  const auto bond = [&](std::uint32_t a, std::uint32_t b) { m.bonds.push_back({std::min(a, b), std::max(a, b)}); };
  const auto triangle = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    const Eigen::Vector3d& pa = m.reference[a];
    const Eigen::Vector3d normal = (m.reference[b] - pa).cross(m.reference[c] - pa);
    const Eigen::Vector3d centre = (pa + m.reference[b] + m.reference[c]) / 3;
    const Eigen::Vector3d radial(centre[0] - axis_xy[0], centre[1] - axis_xy[1], 0);
    if (normal.dot(radial) >= 0) m.triangles.push_back({a, b, c});
    else m.triangles.push_back({a, c, b});
  };
  for (std::size_t k = 0; k < m.rings; ++k)
    for (std::size_t i = 0; i < n; ++i) {
      bond(id(k, i), id(k, i + 1));
      if (k + 1 == m.rings) continue;
      // Ring k + 1 is turned by half a spacing against ring k: forwards from an even ring,
      // backwards from an odd one (its own offset is undone).
      if (k % 2 == 0) {
        bond(id(k, i), id(k + 1, i));
        bond(id(k, i), id(k + 1, i + n - 1));
        triangle(id(k, i), id(k, i + 1), id(k + 1, i));
        triangle(id(k, i + 1), id(k + 1, i + 1), id(k + 1, i));
      } else {
        bond(id(k, i), id(k + 1, i));
        bond(id(k, i), id(k + 1, i + 1));
        triangle(id(k, i), id(k, i + 1), id(k + 1, i + 1));
        triangle(id(k, i), id(k + 1, i + 1), id(k + 1, i));
      }
    }
  for (const auto& b : m.bonds) m.rest_length.push_back((m.reference[b[1]] - m.reference[b[0]]).norm());
  incidence(m.balls(), m.bonds, m.bond_offset, m.ball_bonds);
  incidence(m.balls(), m.triangles, m.triangle_offset, m.ball_triangles);
  return m;
}

MembraneState rest_state(const Membrane& m) {
  MembraneState s;
  s.x = m.reference;
  s.v.assign(m.balls(), Eigen::Vector3d::Zero());
  s.spin.assign(m.balls(), Eigen::Vector3d::Zero());
  s.shear.assign(m.bonds.size(), Eigen::Vector3d::Zero());
  return s;
}

double add_bond_forces(const Membrane& m, MembraneState& s, double dt, std::span<Eigen::Vector3d> force,
                       std::span<Eigen::Vector3d> moment) {
  const double kn = m.stiffness.normal, ks = m.stiffness.shear;
  const std::size_t bonds = m.bonds.size(), balls = m.balls();
  // Each bond's force on its second ball, the moment on both, and its two energy terms; then each
  // ball gathers its bonds' in bond order, and the energies are summed in bond order.
  std::vector<Eigen::Vector3d> on_second(bonds), turn(bonds);
  std::vector<std::array<double, 2>> energy_terms(bonds);
#pragma omp parallel for schedule(static) if (balls >= kParallelBalls)
  for (std::size_t j = 0; j < bonds; ++j) {
    const auto [a, b] = m.bonds[j];
    const Eigen::Vector3d d = s.x[b] - s.x[a];
    const double length = d.norm();
    const Eigen::Vector3d n = d / length;
    // The stored shear force turns with the bond: projected on the new tangent plane, length kept.
    Eigen::Vector3d& shear = s.shear[j];
    const double before = shear.norm();
    shear -= shear.dot(n) * n;
    const double after = shear.norm();
    if (after > 0) shear *= before / after;
    const double arm = 0.5 * length;
    const Eigen::Vector3d relative = (s.v[b] - s.spin[b].cross(arm * n)) - (s.v[a] + s.spin[a].cross(arm * n));
    shear -= ks * dt * (relative - relative.dot(n) * n);
    on_second[j] = -kn * (length - m.rest_length[j]) * n + shear;
    turn[j] = -arm * n.cross(shear);  // the shear force at the contact point, on both balls
    energy_terms[j] = {0.5 * kn * (length - m.rest_length[j]) * (length - m.rest_length[j]),
                       ks > 0 ? 0.5 * shear.squaredNorm() / ks : 0.0};
  }
#pragma omp parallel for schedule(static) if (balls >= kParallelBalls)
  for (std::size_t i = 0; i < balls; ++i)
    for (std::uint32_t k = m.bond_offset[i]; k < m.bond_offset[i + 1]; ++k) {
      const std::uint32_t j = m.ball_bonds[k];
      if (m.bonds[j][1] == i) force[i] += on_second[j];
      else force[i] -= on_second[j];
      moment[i] += turn[j];
    }
  double energy = 0;
  for (std::size_t j = 0; j < bonds; ++j) {
    energy += energy_terms[j][0];
    if (ks > 0) energy += energy_terms[j][1];
  }
  return energy;
}

void add_pressure_forces(const Membrane& m, std::span<const Eigen::Vector3d> x, double pressure,
                         std::span<Eigen::Vector3d> force) {
  std::vector<Eigen::Vector3d> share(m.triangles.size());
  const bool parallel = m.balls() >= kParallelBalls;
#pragma omp parallel for schedule(static) if (parallel)
  for (std::size_t k = 0; k < m.triangles.size(); ++k) {
    const auto& t = m.triangles[k];
    // (x1 - x0) x (x2 - x0) is twice the area times the outward normal.
    share[k] = -pressure / 6.0 * (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]);
  }
#pragma omp parallel for schedule(static) if (parallel)
  for (std::size_t i = 0; i < m.balls(); ++i)
    for (std::uint32_t k = m.triangle_offset[i]; k < m.triangle_offset[i + 1]; ++k) force[i] += share[m.ball_triangles[k]];
}

double membrane_stable_time_step(const Membrane& m) {
  // Gershgorin on M^-1/2 K M^-1/2 for a ball with six bonds: each 3x3 block's absolute row sum is at
  // most sqrt(3) times its norm; blocks: translation-translation max(K_n, K_s) per bond on the
  // diagonal and to each neighbour; translation-spin K_s r / sqrt(m I); spin-spin K_s r^2 / I.
  const double mass = m.ball_mass, inertia = m.ball_inertia, r = m.ball_radius;
  const double k = std::max(m.stiffness.normal, m.stiffness.shear), ks = m.stiffness.shear;
  const double coupling = ks * r / std::sqrt(mass * inertia);
  const double translation = kSqrt3 * (12 * k / mass + 12 * coupling);
  const double rotation = kSqrt3 * (12 * ks * r * r / inertia + 12 * coupling);
  const double lambda = std::max(translation, rotation);
  return kMembraneSafety * 2 / std::sqrt(lambda);
}

double integrate_balls(const Membrane& m, MembraneState& s, std::span<const Eigen::Vector3d> force,
                       std::span<const Eigen::Vector3d> moment, double dt, double damping,
                       std::span<const BallMotion> motion, std::span<const std::uint8_t> clamp_group,
                       std::span<const Eigen::Vector3d> clamp_velocity, bool first) {
  const double a = 0.5 * damping * dt;
  const double mass = m.ball_mass, inertia = m.ball_inertia;
  std::vector<double> kinetic_of(m.balls(), 0.0);
#pragma omp parallel for schedule(static) if (m.balls() >= kParallelBalls)
  for (std::size_t i = 0; i < m.balls(); ++i) {
    if (motion[i] == BallMotion::clamped) {
      s.v[i] = clamp_velocity[clamp_group[i]];
      s.spin[i].setZero();
      s.x[i] += dt * s.v[i];
      continue;
    }
    const Eigen::Vector3d v_old = s.v[i], w_old = s.spin[i];
    const Eigen::Vector3d v_new = first ? Eigen::Vector3d(v_old + 0.5 * dt * (force[i] / mass - damping * v_old))
                                        : Eigen::Vector3d(((1 - a) * v_old + dt * force[i] / mass) / (1 + a));
    const Eigen::Vector3d w_new = first ? Eigen::Vector3d(w_old + 0.5 * dt * (moment[i] / inertia - damping * w_old))
                                        : Eigen::Vector3d(((1 - a) * w_old + dt * moment[i] / inertia) / (1 + a));
    const Eigen::Vector3d v_mid = first ? v_old : Eigen::Vector3d(0.5 * (v_old + v_new));
    const Eigen::Vector3d w_mid = first ? w_old : Eigen::Vector3d(0.5 * (w_old + w_new));
    kinetic_of[i] = 0.5 * mass * v_mid.squaredNorm() + 0.5 * inertia * w_mid.squaredNorm();
    s.v[i] = v_new;
    s.spin[i] = w_new;
    s.x[i] += dt * v_new;
  }
  double kinetic = 0;  // in ball order, whatever the threads
  for (std::size_t i = 0; i < m.balls(); ++i)
    if (motion[i] != BallMotion::clamped) kinetic += kinetic_of[i];
  return kinetic;
}

MembraneState relax_membrane(const Membrane& m, double damping,
                             const std::function<void(const MembraneState&, std::vector<Eigen::Vector3d>&)>& load,
                             double tolerance, int max_steps) {
  MembraneState s = rest_state(m);
  const double dt = membrane_stable_time_step(m);
  std::vector<Eigen::Vector3d> force(m.balls()), moment(m.balls());
  const std::vector<BallMotion> motion(m.balls(), BallMotion::free);
  const std::vector<std::uint8_t> group(m.balls(), 0);
  const std::vector<Eigen::Vector3d> no_clamp{Eigen::Vector3d::Zero()};
  double peak = 0;
  for (int step = 0; step < max_steps; ++step) {
    std::fill(force.begin(), force.end(), Eigen::Vector3d::Zero());
    std::fill(moment.begin(), moment.end(), Eigen::Vector3d::Zero());
    add_bond_forces(m, s, dt, force, moment);
    load(s, force);
    const double kinetic = integrate_balls(m, s, force, moment, dt, damping, motion, group, no_clamp, step == 0);
    peak = std::max(peak, kinetic);
    if (step > 100 && kinetic <= tolerance * peak) return s;
  }
  throw DataError(fmt::format("the membrane did not come to rest in {} steps (kinetic energy still above {} of its peak); "
                              "raise the damping towards twice the loaded mode's angular frequency",
                              max_steps, tolerance));
}

EnclosedVolumes enclosed_volumes(const Membrane& m, std::span<const Eigen::Vector3d> x, double z_bottom, double z_top) {
  const Eigen::Vector3d o(m.axis_xy[0], m.axis_xy[1], z_bottom);
  double lateral = 0, top_area = 0, radial = 0;
  for (const SlabPolygon& clipped : clipped_triangles(m, x, z_bottom, z_top)) {
    if (clipped.size < 3) continue;
    const std::span<const Eigen::Vector3d> poly = clipped.points();
    for (std::size_t i = 1; i + 1 < poly.size(); ++i) {
      lateral += (poly[0] - o).dot((poly[i] - poly[0]).cross(poly[i + 1] - poly[0])) / 6.0;
      const Eigen::Vector3d area2 = (poly[i] - poly[0]).cross(poly[i + 1] - poly[0]);  // 2 A n
      const Eigen::Vector3d centroid = (poly[0] + poly[i] + poly[i + 1]) / 3.0;
      const Eigen::Vector3d rho(centroid[0] - m.axis_xy[0], centroid[1] - m.axis_xy[1], 0);
      radial += rho.dot(area2) / 4.0;
    }
    // Edges on the top plane bound the cap, traversed against the cap's own (outward, +z) sense.
    for (std::size_t i = 0; i < poly.size(); ++i) {
      const Eigen::Vector3d& p = poly[i];
      const Eigen::Vector3d& q = poly[(i + 1) % poly.size()];
      if (p[2] == z_top && q[2] == z_top) top_area -= 0.5 * ((p - o).cross(q - o))[2];
    }
  }
  return {lateral + (z_top - z_bottom) * top_area / 3.0, radial};
}

}  // namespace graintwin::fdem
