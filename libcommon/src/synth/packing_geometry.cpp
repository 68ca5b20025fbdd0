// Contact kernels for star-shaped grains: the deepest points of one grain's surface inside another
// (or through a wall), from lattice samples facing the other body that seed local searches on the
// unit sphere. See packing_geometry.hpp.
#include "packing_geometry.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>

namespace graintwin::synth::detail {

namespace {

// First step (rad) of a warm-started search.
constexpr double kWarmStep = 0.03;
// At most kMaxSeeds local searches per side and per wall; searches that end closer than
// kSameRegion (rad) found the same maximum.
constexpr int kMaxSeeds = 8;
constexpr double kSameRegion = 0.03;
// Lattice neighbours: within this many spacings.
constexpr double kNeighbourSpacings = 1.6;
// The lattice's covering radius (largest angle from any direction to its nearest sample), in
// spacings; used for the curvature part of the sampling margin.
constexpr double kCover = 0.7;

// Orthonormal tangent basis (t1, t2) of the unit vector u.
void tangent_basis(const Eigen::Vector3d& u, Eigen::Vector3d& t1, Eigen::Vector3d& t2) {
  const Eigen::Vector3d a =
      std::abs(u.x()) < 0.8 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  t1 = (a - a.dot(u) * u).normalized();
  t2 = u.cross(t1);
}

// Step (in units of the tangent coordinate) to the vertex of the parabola through (-h, fm),
// (0, f0), (h, fp), clamped to +-2h; +-2h toward the larger side if the data are not concave.
double parabola_step(double fp, double fm, double f0, double h) {
  const double curv = fp + fm - 2.0 * f0;
  if (curv < 0.0) return std::clamp(0.5 * h * (fp - fm) / -curv, -2.0 * h, 2.0 * h);
  if (fp > fm) return 2.0 * h;
  if (fm > fp) return -2.0 * h;
  return 0.0;
}

// Local maximisation of f over unit vectors, from (u, fu) with first step h (rad) down to h_min:
// each round probes +-h along two tangent axes, jumps to the per-axis parabola vertex, keeps the
// best of the six points and shrinks h by 4 once the maximum is bracketed.
template <class F>
void refine_max(Eigen::Vector3d& u, double& fu, double h, double h_min, F&& f) {
  Eigen::Vector3d t1, t2;
  for (int round = 0; round < 48 && h >= h_min; ++round) {
    tangent_basis(u, t1, t2);
    Eigen::Vector3d cand[5] = {(u + h * t1).normalized(), (u - h * t1).normalized(),
                               (u + h * t2).normalized(), (u - h * t2).normalized(),
                               Eigen::Vector3d::Zero()};
    double val[5];
    for (int i = 0; i < 4; ++i) val[i] = f(cand[i]);
    const double x1 = parabola_step(val[0], val[1], fu, h);
    const double x2 = parabola_step(val[2], val[3], fu, h);
    if (x1 != 0.0 || x2 != 0.0) {
      cand[4] = (u + x1 * t1 + x2 * t2).normalized();
      val[4] = f(cand[4]);
    } else {
      val[4] = -HUGE_VAL;
    }
    int best = -1;
    double fbest = fu;
    for (int i = 0; i < 5; ++i) {
      if (val[i] > fbest) {
        fbest = val[i];
        best = i;
      }
    }
    if (best < 0) {
      h *= 0.25;
      continue;
    }
    const bool bracketed = best == 4 && std::max(std::abs(x1), std::abs(x2)) < 1.5 * h;
    u = cand[best];
    fu = fbest;
    if (bracketed) h *= 0.25;
  }
}

// Refines each seed (given deepest first) and merges searches that end within kSameRegion of
// each other, keeping the higher; writes the kMaxRegions highest peaks, highest first, and
// returns their number.
template <class F>
int refine_peaks(const Eigen::Vector3d* seed, const double* seed_value, int seeds,
                 double first_step, double h_min, F&& f, Eigen::Vector3d* peak,
                 double* peak_value) {
  const double cos_same = std::cos(kSameRegion);
  Eigen::Vector3d found[kMaxSeeds];
  double found_value[kMaxSeeds];
  int n = 0;
  for (int r = 0; r < seeds; ++r) {
    Eigen::Vector3d u = seed[r];
    double v = seed_value[r];
    refine_max(u, v, first_step, h_min, f);
    int same = -1;
    for (int q = 0; q < n && same < 0; ++q) {
      if (u.dot(found[q]) > cos_same) same = q;
    }
    if (same < 0) {
      found[n] = u;
      found_value[n++] = v;
    } else if (v > found_value[same]) {
      found[same] = u;
      found_value[same] = v;
    }
  }
  int order[kMaxSeeds];
  for (int i = 0; i < n; ++i) order[i] = i;
  std::stable_sort(order, order + n, [&](int x, int y) { return found_value[x] > found_value[y]; });
  const int kept = std::min(n, kMaxRegions);
  for (int i = 0; i < kept; ++i) {
    peak[i] = found[order[i]];
    peak_value[i] = found_value[order[i]];
  }
  return kept;
}

// Sampled candidates of one search: lattice index (-1: the extra `axis` direction, which is not
// a lattice point) and score.
struct Candidates {
  const Lattice* lat = nullptr;
  int k[kFineSamples + 1];
  double v[kFineSamples + 1];
  int m = 0;
  Eigen::Vector3d axis{1.0, 0.0, 0.0};
  void reset(const Lattice& l, const Eigen::Vector3d& a) {
    lat = &l;
    m = 0;
    axis = a;
  }
  void add(int index, double value) {
    k[m] = index;
    v[m++] = value;
  }
  const Eigen::Vector3d& dir(int c) const { return k[c] < 0 ? axis : lat->dir[k[c]]; }
};

// Local maxima of the candidates' scores (a candidate that no neighbouring candidate beats; ties
// go to the lower index) seed the searches, deepest first, at most kMaxSeeds: a rough grain has
// several bumps, and a search climbs only the one it starts on.
template <class F>
int find_peaks(const Candidates& cand, double first_step, double h_min, F&& f,
               Eigen::Vector3d* peak, double* peak_value) {
  const Lattice& lat = *cand.lat;
  // Scores by lattice index; only the touched entries are reset, so this costs O(m).
  thread_local std::vector<double> score(kFineSamples, -HUGE_VAL);
  int axis = -1;
  for (int c = 0; c < cand.m; ++c) {
    if (cand.k[c] >= 0) {
      score[cand.k[c]] = cand.v[c];
    } else {
      axis = c;
    }
  }
  const double cos_near = std::cos(kNeighbourSpacings * lat.spacing);
  auto beats = [](double v_other, int i_other, double v, int i) {
    return v_other > v || (v_other == v && i_other < i);
  };
  int maxima[kFineSamples + 1];
  int nmax = 0;
  for (int c = 0; c < cand.m; ++c) {
    const int k = cand.k[c];
    const double v = cand.v[c];
    bool top = true;
    if (k >= 0) {
      for (int j = lat.nb_start[k]; j < lat.nb_start[k + 1] && top; ++j) {
        const int o = lat.nb[j];
        top = !beats(score[o], o, v, k);
      }
      if (top && axis >= 0 && lat.dir[k].dot(cand.axis) > cos_near) {
        top = !beats(cand.v[axis], -1, v, k);
      }
    } else {
      for (int o = 0; o < cand.m && top; ++o) {
        if (cand.k[o] < 0 || lat.dir[cand.k[o]].dot(cand.axis) <= cos_near) continue;
        top = !beats(cand.v[o], cand.k[o], v, -1);
      }
    }
    if (top) maxima[nmax++] = c;
  }
  for (int c = 0; c < cand.m; ++c) {
    if (cand.k[c] >= 0) score[cand.k[c]] = -HUGE_VAL;
  }
  std::stable_sort(maxima, maxima + nmax, [&](int x, int y) { return cand.v[x] > cand.v[y]; });
  Eigen::Vector3d seed[kMaxSeeds];
  double seed_value[kMaxSeeds];
  const int seeds = std::min(nmax, kMaxSeeds);
  for (int r = 0; r < seeds; ++r) {
    seed[r] = cand.dir(maxima[r]);
    seed_value[r] = cand.v[maxima[r]];
  }
  return refine_peaks(seed, seed_value, seeds, first_step, h_min, f, peak, peak_value);
}

// Contact regions of A's surface inside B (see SideSet). Full mode: samples of A's surface that
// face B and come within gap + margin of it seed the searches; warm mode: the searches start
// from the peaks found last time. Returns false when nothing is within gap; `bound` then
// receives a lower bound of the separation (full mode; -inf in warm mode, where a local search
// proves nothing).
bool side_contacts(const SurfaceView& A, const Frame& fa, const SurfaceView& B, const Frame& fb,
                   double gap, double h_min, const SideSet* warm, SideSet& out, double& bound) {
  out.n = 0;
  out.peaks = 0;
  const Eigen::Vector3d d = fb.x - fa.x;
  const double dist = d.norm();
  const double rho_cut = fb.s * B.max_radius + gap;
  Eigen::Vector3d dA = Eigen::Vector3d::UnitX();
  if (dist > 0.0) dA = fa.R.transpose() * (d / dist);
  // A's surface point along u can only come within rho_cut of B's centre if u lies in the cone
  // of half-angle asin(rho_cut / dist) about the centre line.
  const double cos_alpha =
      dist > rho_cut ? std::sqrt(std::max(0.0, 1.0 - (rho_cut / dist) * (rho_cut / dist))) : -2.0;

  // Body-A point (unscaled) -> B's unscaled body frame: q = M P + t.
  const Eigen::Matrix3d M = fb.R.transpose() * fa.R * (fa.s / fb.s);
  const Eigen::Vector3d t = fb.R.transpose() * (fa.x - fb.x) / fb.s;
  const shape::RadialTable& ta = *A.table;
  const shape::RadialTable& tb = *B.table;
  const double b_scale = fb.s;
  const double b_deep = fb.s * B.max_radius;
  auto depth_at = [&](const Eigen::Vector3d& P) {
    const Eigen::Vector3d q = M * P + t;
    const double rho = q.norm();
    if (rho < 1e-12 * B.max_radius) return b_deep;
    return b_scale * (tb.radius(q / rho) - rho);
  };
  auto f = [&](const Eigen::Vector3d& u) { return depth_at(ta.radius(u) * u); };

  Eigen::Vector3d peak[kMaxRegions];
  double peak_value[kMaxRegions];
  int peaks = 0;
  const bool warm_start = warm && warm->peaks > 0;
  if (warm_start) {
    double value[kMaxRegions];
    for (int r = 0; r < warm->peaks; ++r) value[r] = f(warm->peak_dir[r]);
    peaks = refine_peaks(warm->peak_dir, value, warm->peaks, kWarmStep, h_min, f, peak,
                         peak_value);
    bound = -HUGE_VAL;
  } else {
    const Lattice& lat = *A.lattice;
    // What the sampling can miss: near a smooth maximum a point at angle theta is shallower by
    // about r_a (r_a + r_b) theta^2 / (2 r_b) (spheres; r_b: B's smallest radius as curvature
    // proxy), theta up to the covering radius, doubled for safety; plus both grains' roughness
    // slack.
    const double ra = fa.s * A.max_radius;
    const double rb = fb.s * std::max(B.table->min_radius(), 1e-3 * B.max_radius);
    const double cover = kCover * lat.spacing;
    const double margin = ra * (ra + rb) / rb * cover * cover + fa.s * A.slack + fb.s * B.slack;
    const double floor = -(gap + margin);
    // Candidates: samples within gap + margin of B. A point at distance rho from B's centre is
    // at most s_b (R_max,b - rho) deep, so most samples are screened out before B's radius is
    // looked up; `top` keeps the largest score or screening bound seen, for the separation bound.
    thread_local Candidates cand;
    cand.reset(lat, dA);
    double top = f(dA);
    if (top > floor) cand.add(-1, top);
    for (int k = 0; k < lat.size; ++k) {
      const Eigen::Vector3d& u = lat.dir[k];
      if (u.dot(dA) < cos_alpha) continue;
      const Eigen::Vector3d P = static_cast<double>((*A.radii)[k]) * u;
      const Eigen::Vector3d q = M * P + t;
      const double rho = q.norm();
      const double cap = b_scale * (B.max_radius - rho);
      if (cap <= floor) {
        top = std::max(top, cap);
        continue;
      }
      const double v = rho < 1e-12 * B.max_radius ? b_deep : b_scale * (tb.radius(q / rho) - rho);
      top = std::max(top, v);
      if (v > floor) cand.add(k, v);
    }
    if (cand.m == 0) {
      bound = -top - margin;
      return false;
    }
    peaks = find_peaks(cand, lat.spacing, h_min, f, peak, peak_value);
  }

  // Depth along B's surface normal at the radial projection of each deepest point.
  double deepest = -HUGE_VAL;
  out.peaks = peaks;
  for (int r = 0; r < peaks; ++r) {
    out.peak_dir[r] = peak[r];
    const Eigen::Vector3d& u = peak[r];
    const Eigen::Vector3d P = ta.radius(u) * u;
    const Eigen::Vector3d q = M * P + t;
    const double rho = q.norm();
    const Eigen::Vector3d v = rho > 1e-12 * B.max_radius
                                  ? Eigen::Vector3d(q / rho)
                                  : Eigen::Vector3d(fb.R.transpose() * -d.normalized());
    const Eigen::Vector3d nb = tb.surface_normal(v);
    const double depth = peak_value[r] * std::max(v.dot(nb), 0.2);
    deepest = std::max(deepest, depth);
    if (depth < -gap) continue;
    Side& sd = out.side[out.n];
    sd.depth = depth;
    const Eigen::Vector3d p_world = fa.x + fa.R * (fa.s * P);
    const Eigen::Vector3d nb_world = fb.R * nb;
    sd.normal = -nb_world;
    sd.point = p_world + 0.5 * depth * nb_world;
    ++out.n;
  }
  // Deepest first (the normal correction may reorder the peaks).
  for (int i = 1; i < out.n; ++i) {
    for (int j = i; j > 0 && out.side[j].depth > out.side[j - 1].depth; --j) {
      std::swap(out.side[j], out.side[j - 1]);
    }
  }
  if (!warm_start) bound = -deepest;
  return out.n > 0;
}

}  // namespace

namespace {

Lattice make_lattice(int size) {
  Lattice l;
  l.size = size;
  l.dir.resize(size);
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int k = 0; k < size; ++k) {
    const double z = 1.0 - (2.0 * k + 1.0) / size;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = golden * k;
    l.dir[k] = Eigen::Vector3d(r * std::cos(phi), r * std::sin(phi), z);
  }
  l.spacing = std::sqrt(4.0 * M_PI / size);
  // Neighbours by brute force once (size^2 / 2 dot products, a few ms for the fine lattice).
  const double cos_near = std::cos(kNeighbourSpacings * l.spacing);
  std::vector<std::vector<int>> nb(size);
  for (int i = 0; i < size; ++i) {
    for (int j = i + 1; j < size; ++j) {
      if (l.dir[i].dot(l.dir[j]) > cos_near) {
        nb[i].push_back(j);
        nb[j].push_back(i);
      }
    }
  }
  l.nb_start.assign(size + 1, 0);
  for (int i = 0; i < size; ++i) {
    l.nb_start[i + 1] = l.nb_start[i] + static_cast<int>(nb[i].size());
    l.nb.insert(l.nb.end(), nb[i].begin(), nb[i].end());
  }
  return l;
}

std::vector<float> radii_on(const Lattice& lat, const shape::RadialTable& t) {
  std::vector<float> r(lat.size);
  for (int k = 0; k < lat.size; ++k) r[k] = static_cast<float>(t.radius(lat.dir[k]));
  return r;
}

// A shape is rough if its coarse-lattice slack exceeds this fraction of its largest radius:
// measured 0.01-0.12 for ellipsoids of aspect 1.1-2.0, 0.11-0.28 for degree-15 SH sand grains.
constexpr double kRoughSlack = 0.08;

}  // namespace

const Lattice& coarse_lattice() {
  static const Lattice lat = make_lattice(kCoarseSamples);
  return lat;
}

const Lattice& fine_lattice() {
  static const Lattice lat = make_lattice(kFineSamples);
  return lat;
}

double sample_slack(const Lattice& lat, const std::vector<float>& radii) {
  // Twice the largest deviation of a sample from the mean of its neighbours: zero for a sphere,
  // second order in the spacing for a smooth body, large near bumps and tips no wider than the
  // lattice spacing, which is where a maximum between samples can rise above them.
  double slack = 0.0;
  for (int k = 0; k < lat.size; ++k) {
    double sum = 0.0;
    for (int j = lat.nb_start[k]; j < lat.nb_start[k + 1]; ++j) sum += radii[lat.nb[j]];
    const int count = lat.nb_start[k + 1] - lat.nb_start[k];
    if (count > 0) slack = std::max(slack, std::abs(radii[k] - sum / count));
  }
  return 2.0 * slack;
}

ShapeSampling sample_shape(const shape::RadialTable& t) {
  ShapeSampling s;
  s.lattice = &coarse_lattice();
  s.radii = radii_on(*s.lattice, t);
  s.slack = sample_slack(*s.lattice, s.radii);
  if (s.slack > kRoughSlack * t.max_radius()) {
    s.lattice = &fine_lattice();
    s.radii = radii_on(*s.lattice, t);
    s.slack = sample_slack(*s.lattice, s.radii);
  }
  return s;
}

SurfaceView view_of(const shape::RadialTable& t, const ShapeSampling& sampling) {
  SurfaceView v;
  v.table = &t;
  v.lattice = sampling.lattice;
  v.radii = &sampling.radii;
  v.max_radius = t.max_radius();
  v.slack = sampling.slack;
  return v;
}

void index_shapes(const std::vector<const shape::RadialTable*>& shapes, std::vector<ShapeData>& data,
                  std::vector<int>& grain_shape) {
  std::map<const shape::RadialTable*, int> index;
  grain_shape.resize(shapes.size());
  for (std::size_t i = 0; i < shapes.size(); ++i) {
    auto [it, added] = index.emplace(shapes[i], static_cast<int>(data.size()));
    if (added) {
      ShapeData d;
      d.table = shapes[i];
      d.max_radius = shapes[i]->max_radius();
      d.volume = shapes[i]->volume();
      data.push_back(std::move(d));
    }
    grain_shape[i] = it->second;
  }
#pragma omp parallel for schedule(dynamic, 1) if (data.size() > 8)
  for (std::size_t k = 0; k < data.size(); ++k) {
    data[k].sampling = sample_shape(*data[k].table);
  }
}

PairEval evaluate_pair(const SurfaceView& a, const Frame& fa, const SurfaceView& b, const Frame& fb,
                       double gap, double h_min, const PairEval* warm) {
  PairEval e;
  const double dist = (fb.x - fa.x).norm();
  const double reach = fa.s * a.max_radius + fb.s * b.max_radius;
  if (dist > reach + gap) {
    e.gap_bound = dist - reach;
    return e;
  }
  double bound1 = 0.0, bound2 = 0.0;
  const bool f1 = side_contacts(a, fa, b, fb, gap, h_min, warm ? &warm->ab : nullptr, e.ab, bound1);
  const bool f2 = side_contacts(b, fb, a, fa, gap, h_min, warm ? &warm->ba : nullptr, e.ba, bound2);
  // ba's normals run from b to a: flip them so that every normal of the pair runs from a to b.
  for (int r = 0; r < e.ba.n; ++r) e.ba.side[r].normal = -e.ba.side[r].normal;
  if (!f1 && !f2) {
    e.gap_bound = std::max(bound1, bound2);
    return e;
  }
  e.found = true;
  e.side = f1 && (!f2 || e.ab.side[0].depth >= e.ba.side[0].depth) ? e.ab.side[0] : e.ba.side[0];
  return e;
}

int evaluate_walls(const SurfaceView& a, const Frame& fa, const Container& c, double gap,
                   double h_min, WallHit* hits) {
  const shape::RadialTable& ta = *a.table;
  const Lattice& lat = *a.lattice;
  const double reach = fa.s * a.max_radius;
  // The support point of a star-shaped body in direction w has r(u) u.w >= r(w) >= r_min, so
  // u.w >= r_min / r_max: only samples in that cone can be deepest.
  const double cos_support = std::max(ta.min_radius(), 0.0) / a.max_radius;
  // What the sampling can miss near a maximum: about r theta^2 / 2 for theta up to the covering
  // radius, plus the roughness slack.
  const double cover = kCover * lat.spacing;
  const double margin = 0.5 * reach * cover * cover + fa.s * a.slack;
  int n = 0;

  // Contact regions with one wall: the scores value(k) of the samples in the cone u.w >= cos_cone
  // that come within gap + margin seed searches of f; finish(u, depth) records a hit.
  auto regions = [&](const Eigen::Vector3d& w, double cos_cone, auto&& f, auto&& value,
                     auto&& finish) {
    thread_local Candidates cand;
    cand.reset(lat, w);
    const double floor = -(gap + margin);
    const double vw = f(w);
    if (vw > floor) cand.add(-1, vw);
    for (int k = 0; k < lat.size; ++k) {
      if (lat.dir[k].dot(w) < cos_cone) continue;
      const double v = value(k);
      if (v > floor) cand.add(k, v);
    }
    if (cand.m == 0) return;
    Eigen::Vector3d peak[kMaxRegions];
    double peak_value[kMaxRegions];
    const int peaks = find_peaks(cand, lat.spacing, h_min, f, peak, peak_value);
    for (int r = 0; r < peaks; ++r) {
      if (peak_value[r] >= -gap) finish(peak[r], peak_value[r]);
    }
  };
  auto radius_at = [&](int k) { return static_cast<double>((*a.radii)[k]); };

  // Plane wall {y : e.y >= c0}: the depth of surface point u is (c0 - e.x) + s r(u) u.w with
  // w = -R^T e.
  auto plane = [&](const Eigen::Vector3d& e, double c0) {
    if (e.dot(fa.x) - c0 > reach + gap) return;
    const Eigen::Vector3d w = -(fa.R.transpose() * e);
    const double base = c0 - e.dot(fa.x);
    auto f = [&](const Eigen::Vector3d& u) { return base + fa.s * ta.radius(u) * u.dot(w); };
    auto value = [&](int k) { return base + fa.s * radius_at(k) * lat.dir[k].dot(w); };
    auto finish = [&](const Eigen::Vector3d& u, double depth) {
      const Eigen::Vector3d p = fa.x + fa.R * (fa.s * ta.radius(u) * u);
      hits[n].depth = depth;
      hits[n].normal = e;
      hits[n].point = p + 0.5 * depth * e;
      ++n;
    };
    regions(w, cos_support, f, value, finish);
  };

  if (c.kind == Container::Kind::box) {
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d e = Eigen::Vector3d::Zero();
      e[k] = 1.0;
      plane(e, 0.0);
      plane(-e, -c.box_size[k]);
    }
    return n;
  }
  plane(Eigen::Vector3d::UnitZ(), 0.0);
  plane(-Eigen::Vector3d::UnitZ(), -c.height);
  // Cylinder side: the depth of surface point p is |p_xy| - R.
  const double rho_c = std::hypot(fa.x.x(), fa.x.y());
  if (c.radius - rho_c > reach + gap) return n;
  Eigen::Vector3d er = Eigen::Vector3d::UnitX();
  if (rho_c > 0.0) er = Eigen::Vector3d(fa.x.x() / rho_c, fa.x.y() / rho_c, 0.0);
  const Eigen::Vector3d w = fa.R.transpose() * er;
  // The wall curves away from the tangent plane, so widen the support cone a little.
  const double cos_side = rho_c > reach ? cos_support - 0.15 : -2.0;
  auto radial = [&](const Eigen::Vector3d& P) {
    const Eigen::Vector3d p = fa.x + fa.R * (fa.s * P);
    return std::hypot(p.x(), p.y()) - c.radius;
  };
  auto f = [&](const Eigen::Vector3d& u) { return radial(ta.radius(u) * u); };
  auto value = [&](int k) { return radial(radius_at(k) * lat.dir[k]); };
  auto finish = [&](const Eigen::Vector3d& u, double depth) {
    const Eigen::Vector3d p = fa.x + fa.R * (fa.s * ta.radius(u) * u);
    const double rp = std::hypot(p.x(), p.y());
    Eigen::Vector3d e = -er;
    if (rp > 0.0) e = Eigen::Vector3d(-p.x() / rp, -p.y() / rp, 0.0);
    hits[n].depth = depth;
    hits[n].normal = e;
    hits[n].point = p + 0.5 * depth * e;
    ++n;
  };
  regions(w, cos_side, f, value, finish);
  return n;
}

}  // namespace graintwin::synth::detail
