// Angular sand grains: random convex polyhedra around an ellipsoidal core, with dents and
// roughness as radial factors, centred on their true centroid (construction in the header).
#include "graintwin/synth/angular_grains.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "graintwin/core/error.hpp"
#include "graintwin/core/geometry.hpp"
#include "graintwin/shape/sh_basis.hpp"

namespace graintwin::synth {

namespace {

constexpr double kCentroidTolerance = 1e-6;  // of the volume-equivalent radius
constexpr double kPocketedCentroidTolerance = 1e-3;  // the cavity's moments come from grid samples
constexpr int kMaxCentringSteps = 30;
constexpr int kMaxSpikeCuts = 64;
constexpr int kSpikeDirections = 8000;  // spacing about 0.04 rad: the spike test's direction set
constexpr int kMaxDraws = 100;
constexpr int kNormalTries = 100;

void require(bool ok, const std::string& what) {
  if (!ok) throw UsageError("angular grains: " + what);
}

// A unit vector uniform on the sphere (a normalised Gaussian vector).
Eigen::Vector3d random_direction(std::mt19937_64& rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  for (;;) {
    const Eigen::Vector3d g(normal(rng), normal(rng), normal(rng));
    if (g.norm() > 1e-9) return g.normalized();
  }
}

struct Core {
  Eigen::Vector3d semi_axes;
  double radius(const Eigen::Vector3d& u) const {
    return 1.0 / u.cwiseQuotient(semi_axes).norm();
  }
  // max over the ellipsoid of n.x: sqrt(sum (a_i n_i)^2).
  double support(const Eigen::Vector3d& n) const { return n.cwiseProduct(semi_axes).norm(); }
  // Outward unit normal at the surface point along u.
  Eigen::Vector3d normal(const Eigen::Vector3d& u) const {
    return (radius(u) * u).cwiseQuotient(semi_axes.cwiseAbs2()).normalized();
  }
};

// Draws the planes: normals spread quasi-uniformly (a new normal is redrawn while it lies closer
// than 0.6 of the mean spacing to an earlier one, up to kNormalTries times), each touching or
// cutting slightly into the core; then cuts every spike that reaches beyond spike_limit core radii.
void draw_planes(const AngularShapeParams& p, const Core& core, std::mt19937_64& rng, AngularGrain& g) {
  std::uniform_int_distribution<int> count(p.min_facets, p.max_facets);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int n = count(rng);
  const double min_cos = std::cos(0.6 * std::sqrt(4.0 * std::numbers::pi / n));
  auto add_plane = [&](const Eigen::Vector3d& normal) {
    g.normals.push_back(normal);
    g.offsets.push_back(core.support(normal) * (1.0 - p.facet_cut * unit(rng)));
  };
  for (int k = 0; k < n; ++k) {
    Eigen::Vector3d normal = random_direction(rng);
    for (int t = 0; t < kNormalTries; ++t) {
      const bool crowded = std::any_of(g.normals.begin(), g.normals.end(),
                                       [&](const Eigen::Vector3d& m) { return m.dot(normal) > min_cos; });
      if (!crowded) break;
      normal = random_direction(rng);
    }
    add_plane(normal);
  }
  static const std::vector<Eigen::Vector3d> probe = shape::fibonacci_directions(kSpikeDirections);
  for (int cut = 0; cut < kMaxSpikeCuts; ++cut) {
    double worst = 0.0;
    Eigen::Vector3d worst_dir = Eigen::Vector3d::UnitZ();
    for (const auto& u : probe) {
      const double ratio = g.polyhedron_radius(u) / core.radius(u);
      if (ratio > worst) {
        worst = ratio;
        worst_dir = u;
      }
    }
    if (worst <= p.spike_limit) return;
    add_plane(core.normal(worst_dir));
  }
}

// Volume and first moment of the part of the table's body inside the cavities (each cavity's
// bounding cube sampled on a grid of kPocketSamples points per edge; the cavities of a grain do
// not overlap).
constexpr int kPocketSamples = 40;
struct Moments {
  double volume = 0.0;
  Eigen::Vector3d first = Eigen::Vector3d::Zero();
};
Moments pocket_moments(const shape::RadialTable& t, const std::vector<Pocket>& pockets) {
  Moments m;
  for (const Pocket& k : pockets) {
    const double half = k.bound(), h = 2.0 * half / kPocketSamples, cell = h * h * h;
    for (int a = 0; a < kPocketSamples; ++a)
      for (int b = 0; b < kPocketSamples; ++b)
        for (int c = 0; c < kPocketSamples; ++c) {
          const Eigen::Vector3d p = k.centre + Eigen::Vector3d((a + 0.5) * h - half, (b + 0.5) * h - half, (c + 0.5) * h - half);
          if (!k.contains(p) || p.norm() >= t.radius(p)) continue;
          m.volume += cell;
          m.first += cell * p;
        }
  }
  return m;
}

// The grain's body: the table less its cavities.
Moments body_moments(const shape::RadialTable& t, const std::vector<Pocket>& pockets) {
  const Moments cut = pocket_moments(t, pockets);
  return {t.volume() - cut.volume, t.volume() * t.centroid() - cut.first};
}

// Places one undercut below the surface of a centred table (step 6 of the header): at a random
// direction where the grain is at least as wide as its volume-equivalent radius, tilted towards a
// random tangent. Kept only if its top rim opens through the surface on one side and lies under
// the surface on at least half of it (an overhang, not a shallow scoop), and it stays 0.3 r_eq off
// the centre. False if none of kPocketTries draws qualifies.
constexpr int kPocketTries = 100;
constexpr int kRimPoints = 24;
bool add_undercut(const AngularShapeParams& p, const shape::RadialTable& t, std::mt19937_64& rng, AngularGrain& g) {
  std::uniform_real_distribution<double> spread(0.85, 1.15), tilt_spread(-5.0, 5.0);
  const double r_eq = equivalent_radius(t.volume());
  const auto inside = [&](const Eigen::Vector3d& x) { return x.norm() < t.radius(x); };
  for (int k = 0; k < kPocketTries; ++k) {
    const Eigen::Vector3d u = random_direction(rng);
    Pocket c;
    c.radius = p.undercut_radius * spread(rng) * r_eq;
    c.half_height = 0.5 * p.undercut_height * spread(rng) * r_eq;
    const double depth = p.undercut_depth * spread(rng) * r_eq;
    const double tilt = (p.undercut_tilt_deg + tilt_spread(rng)) * std::numbers::pi / 180.0;
    const Eigen::Vector3d side = random_direction(rng);
    const double surface = t.radius(u);
    const Eigen::Vector3d n = t.surface_normal(u);
    const Eigen::Vector3d tangent = (side - side.dot(n) * n).normalized();
    c.axis = std::cos(tilt) * n + std::sin(tilt) * tangent;
    c.centre = surface * u - depth * n;
    if (surface < r_eq || c.outside_level(Eigen::Vector3d::Zero()) < 0.3 * r_eq) continue;
    const Eigen::Vector3d e1 = c.axis.unitOrthogonal(), e2 = c.axis.cross(e1);
    int covered = 0;
    for (int j = 0; j < kRimPoints; ++j) {
      const double a = 2.0 * std::numbers::pi * j / kRimPoints;
      covered += inside(c.centre + c.half_height * c.axis + c.radius * (std::cos(a) * e1 + std::sin(a) * e2));
    }
    if (covered == kRimPoints || 2 * covered < kRimPoints) continue;
    g.pockets.push_back(c);
    return true;
  }
  return false;
}

}  // namespace

void validate(const AngularShapeParams& p) {
  require(p.min_facets >= 4 && p.max_facets >= p.min_facets && p.max_facets <= 64,
          "the facet counts must satisfy 4 <= min <= max <= 64 (got " + std::to_string(p.min_facets) + ", " +
              std::to_string(p.max_facets) + ")");
  require(p.min_core_ratio > 0.1 && p.min_core_ratio <= 0.95, "the core ratio must be in (0.1, 0.95]");
  require(p.facet_cut >= 0.0 && p.facet_cut <= 0.5, "the facet cut must be in [0, 0.5]");
  require(p.spike_limit > 1.0 && p.spike_limit <= 4.0, "the spike limit must be in (1, 4]");
  require(p.max_dents >= 0 && p.max_dents <= 8, "the dent count must be in 0..8 (got " + std::to_string(p.max_dents) + ")");
  require(p.dent_depth >= 0.0 && p.dent_depth <= 0.3,
          "the dent depth must be in [0, 0.3] of the radius (got " + std::to_string(p.dent_depth) + ")");
  require(p.dent_width > 0.0 && p.dent_width <= 1.0, "the dent width must be in (0, 1] rad");
  require(p.roughness >= 0.0 && p.roughness <= 0.05,
          "the roughness must be in [0, 0.05] of the radius (got " + std::to_string(p.roughness) + ")");
  require(p.undercut_radius >= 0.2 && p.undercut_radius <= 1.0,
          "the undercut radius must be in [0.2, 1] of the radius (got " + std::to_string(p.undercut_radius) + ")");
  require(p.undercut_height >= 0.1 && p.undercut_height <= 0.6,
          "the undercut height must be in [0.1, 0.6] of the radius (got " + std::to_string(p.undercut_height) + ")");
  require(p.undercut_depth >= 0.1 && p.undercut_depth <= 0.8,
          "the undercut depth must be in [0.1, 0.8] of the radius (got " + std::to_string(p.undercut_depth) + ")");
  require(p.undercut_tilt_deg >= 5.0 && p.undercut_tilt_deg <= 60.0,
          "the undercut tilt must be in [5, 60] degrees (got " + std::to_string(p.undercut_tilt_deg) + ")");
  require(p.roughness_from_degree >= 2 && p.roughness_degree >= p.roughness_from_degree && p.roughness_degree <= 64,
          "the roughness degrees must satisfy 2 <= from <= max <= 64 (got " + std::to_string(p.roughness_from_degree) +
              ", " + std::to_string(p.roughness_degree) + ")");
}

double AngularGrain::polyhedron_radius(const Eigen::Vector3d& unit) const {
  double r = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < normals.size(); ++k) {
    const double c = normals[k].dot(unit);
    if (c > 0.0) r = std::min(r, offsets[k] / c);
  }
  return r;
}

int AngularGrain::facet_of(const Eigen::Vector3d& unit) const {
  double r = std::numeric_limits<double>::infinity();
  int best = -1;
  for (std::size_t k = 0; k < normals.size(); ++k) {
    const double c = normals[k].dot(unit);
    if (c > 0.0 && offsets[k] / c < r) {
      r = offsets[k] / c;
      best = static_cast<int>(k);
    }
  }
  return best;
}

int AngularGrain::visible_facets(const std::vector<Eigen::Vector3d>& directions) const {
  std::vector<bool> seen(normals.size(), false);
  for (const auto& u : directions) {
    const int f = facet_of(u);
    if (f >= 0) seen[static_cast<std::size_t>(f)] = true;
  }
  return static_cast<int>(std::count(seen.begin(), seen.end(), true));
}

double AngularGrain::modulation(const Eigen::Vector3d& unit) const {
  double m = 1.0;
  for (const Dent& d : dents) {
    const double angle = std::acos(std::clamp(d.axis.dot(unit), -1.0, 1.0));
    if (angle < d.width) {
      const double s = 1.0 - (angle / d.width) * (angle / d.width);
      m *= 1.0 - d.depth * s * s;
    }
  }
  if (roughness.size() > 0) m *= 1.0 + shape::sh_radius(roughness, roughness_degree, unit);
  return m;
}

void AngularGrain::move_origin(const Eigen::Vector3d& shift) {
  for (std::size_t k = 0; k < normals.size(); ++k) {
    offsets[k] -= normals[k].dot(shift);
    if (!(offsets[k] > 0.0))
      throw DataError("angular grain: moving the origin by the centroid offset left it outside the polyhedron");
  }
  for (Pocket& k : pockets) {
    k.centre -= shift;
    if (k.contains(Eigen::Vector3d::Zero()))
      throw DataError("angular grain: moving the origin by the centroid offset put it in the cavity");
  }
}

void AngularGrain::scale(double s) {
  if (!(s > 0.0 && std::isfinite(s))) throw UsageError("AngularGrain::scale needs a finite factor > 0");
  for (double& h : offsets) h *= s;
  for (Pocket& k : pockets) k.centre *= s, k.radius *= s, k.half_height *= s;
}

std::vector<double> AngularGrain::modulation_at_nodes(int n) const {
  const std::vector<Eigen::Vector3d> dirs = shape::RadialTable::node_directions(n);
  std::vector<double> m(dirs.size());
  for (std::size_t i = 0; i < dirs.size(); ++i) m[i] = modulation(dirs[i]);
  return m;
}

shape::RadialTable AngularGrain::table(int n, const std::vector<double>* modulation_at_nodes) const {
  const std::vector<Eigen::Vector3d> dirs = shape::RadialTable::node_directions(n);
  if (modulation_at_nodes && modulation_at_nodes->size() != dirs.size())
    throw UsageError("AngularGrain::table: the precomputed modulation has the wrong node count");
  std::vector<double> radii(dirs.size());
  for (std::size_t i = 0; i < dirs.size(); ++i)
    radii[i] = polyhedron_radius(dirs[i]) * (modulation_at_nodes ? (*modulation_at_nodes)[i] : modulation(dirs[i]));
  return shape::RadialTable::from_node_radii(n, std::move(radii));
}

AngularGrain random_angular_grain(const AngularShapeParams& p, std::mt19937_64& rng, int n,
                                  shape::RadialTable* table, bool pocketed) {
  validate(p);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int draw = 0; draw < kMaxDraws; ++draw) {
    AngularGrain g;
    Core core;
    const double b = p.min_core_ratio + (0.95 - p.min_core_ratio) * unit(rng);
    const double c = b * (p.min_core_ratio + (0.95 - p.min_core_ratio) * unit(rng));
    core.semi_axes = Eigen::Vector3d(1.0, b, c);
    draw_planes(p, core, rng, g);
    std::uniform_int_distribution<int> dent_count(0, p.max_dents);
    const int dents = dent_count(rng);
    for (int k = 0; k < dents; ++k) {
      AngularGrain::Dent d;
      d.axis = random_direction(rng);
      d.depth = p.dent_depth * (0.5 + 0.5 * unit(rng));
      d.width = p.dent_width * (0.75 + 0.5 * unit(rng));
      g.dents.push_back(d);
    }
    if (p.roughness > 0.0) {
      // Degree band n gets a Gaussian direction in R^(2n+1) and norm proportional to 1/n; the
      // whole field is then scaled to the RMS asked for (orthonormal basis: RMS^2 = |c|^2 / 4 pi).
      g.roughness_degree = p.roughness_degree;
      g.roughness = Eigen::VectorXd::Zero(shape::sh_count(p.roughness_degree));
      for (int deg = p.roughness_from_degree; deg <= p.roughness_degree; ++deg) {
        Eigen::VectorXd v(2 * deg + 1);
        for (Eigen::Index k = 0; k < v.size(); ++k) v[k] = normal(rng);
        g.roughness.segment(deg * deg, 2 * deg + 1) = v / (v.norm() * deg);
      }
      g.roughness *= p.roughness * std::sqrt(4.0 * std::numbers::pi) / g.roughness.norm();
    }
    const std::vector<double> modulation = g.modulation_at_nodes(n);
    if (std::any_of(modulation.begin(), modulation.end(), [](double m) { return !(m > 0.0); })) continue;
    // The planes (and the cavity) move until the centroid of the whole body is the origin; the
    // modulation, a function of the direction about the origin, stays. Each step removes most of
    // the offset. An undercut is placed once the body without it is centred.
    shape::RadialTable t;
    bool centred = false;
    try {
      for (int step = 0; step < kMaxCentringSteps && !centred; ++step) {
        t = g.table(n, &modulation);
        const Moments body = body_moments(t, g.pockets);
        const Eigen::Vector3d centroid = body.first / body.volume;
        const double r_eq = equivalent_radius(body.volume);
        const double tolerance = g.pockets.empty() ? kCentroidTolerance : kPocketedCentroidTolerance;
        if (centroid.norm() > tolerance * r_eq) {
          g.move_origin(centroid);
        } else if (pocketed && g.pockets.empty()) {
          if (!add_undercut(p, t, rng, g)) break;
        } else {
          centred = true;
        }
      }
    } catch (const DataError&) {
      continue;  // an unbounded direction the spike test missed, or the origin left the body: redraw
    }
    if (!centred) continue;
    const double s = 1.0 / equivalent_radius(body_moments(t, g.pockets).volume);
    g.scale(s);
    if (table) *table = t.scaled(s);
    return g;
  }
  throw DataError("angular grains: " + std::to_string(kMaxDraws) +
                  " draws in a row could not be centred; raise the spike limit or lower the dent depth");
}

}  // namespace graintwin::synth
