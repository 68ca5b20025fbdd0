#include "graintwin/track/synthetic.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <functional>
#include <limits>
#include <random>

#include "graintwin/core/error.hpp"
#include "graintwin/core/geometry.hpp"
#include "graintwin/core/point_grid.hpp"
#include "graintwin/shape/sh_basis.hpp"
#include "graintwin/shape/sh_fitter.hpp"

namespace graintwin::track {
namespace {

/// Invariants of a sand grain of radius r: ||R_0|| = sqrt(4 pi) r, ||R_1|| = 0, the form degree
/// drawn, the rest falling as power laws from it (shape/sand_shape.hpp's defaults).
Eigen::VectorXd sand_invariants(double r, int degree, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> d2(0.085 * 0.65, 0.085 * 1.35);
  const double dhat2 = d2(rng);
  Eigen::VectorXd v = Eigen::VectorXd::Zero(degree + 1);
  v[0] = std::sqrt(4.0 * std::numbers::pi) * r;
  for (int n = 2; n <= degree; ++n) {
    const double dn = n < 8 ? dhat2 * std::pow(n / 2.0, -1.0) : dhat2 * std::pow(4.0, -1.0) * std::pow(n / 8.0, -2.0);
    v[n] = v[0] * dn;
  }
  return v;
}

}  // namespace

ScanGrains synthetic_grains(std::size_t n, double d50, int degree, std::uint64_t seed) {
  if (!(d50 > 0.0) || degree < 2) throw UsageError("synthetic_grains: d50 must be positive and the degree at least 2");
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> lognormal(0.0, 0.25);
  std::uniform_real_distribution<double> jitter(-0.2, 0.2);
  // A dense packing holds about 1.15 / d50^3 grains per unit volume: cubic pitch 0.955 d50.
  const double pitch = 0.955 * d50;
  const std::size_t side = static_cast<std::size_t>(std::ceil(std::cbrt(static_cast<double>(n))));
  ScanGrains s;
  s.d50 = d50;
  s.invariants.resize(static_cast<Eigen::Index>(n), degree + 1);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t x = i % side, y = (i / side) % side, z = i / (side * side);
    s.centroid.emplace_back((x + 0.5 + jitter(rng)) * pitch, (y + 0.5 + jitter(rng)) * pitch, (z + 0.5 + jitter(rng)) * pitch);
    const double d = std::clamp(d50 * std::exp(lognormal(rng)), 0.5 * d50, 1.9 * d50);
    s.volume.push_back(std::numbers::pi / 6.0 * d * d * d);
    s.invariants.row(static_cast<Eigen::Index>(i)) = sand_invariants(d / 2.0, degree, rng).transpose();
    s.label.push_back(static_cast<std::uint32_t>(i + 1));
  }
  return s;
}


namespace {

/// One label of the deformed scan as it is built: what it measures and the reference grains it holds.
struct Label {
  Eigen::Vector3d centroid;
  double volume = 0.0;
  Eigen::VectorXd invariants;
  std::array<int, 2> source{-1, -1};
};

/// Distance from p along the unit vector u to where the ray leaves the ball (centre c, radius r),
/// or 0 when it never meets the ball ahead of p.
double ball_exit(const Eigen::Vector3d& p, const Eigen::Vector3d& u, const Eigen::Vector3d& c, double r) {
  const Eigen::Vector3d q = p - c;
  const double b = q.dot(u), disc = b * b - (q.squaredNorm() - r * r);
  return disc < 0.0 ? 0.0 : std::max(0.0, -b + std::sqrt(disc));
}

/// The invariants of a body given by its radius along each direction from its centroid, fitted as
/// labels2shapes fits a grain's surface (least squares over the fitter's directions).
Eigen::VectorXd body_invariants(const shape::ShFitter& fitter, const std::function<double(const Eigen::Vector3d&)>& radius) {
  const auto& dirs = fitter.directions();
  Eigen::VectorXd r(static_cast<Eigen::Index>(dirs.size()));
  for (std::size_t k = 0; k < dirs.size(); ++k) r[static_cast<Eigen::Index>(k)] = radius(dirs[k]);
  return shape::sh_invariants(fitter.fit(r), fitter.degree());
}

/// The label of grains a and b merged: balls of their volumes joined at a point, seen from their
/// joint centroid (inside the larger ball); the outermost surface along each direction, as a
/// radial fit sees it.
Label merged_label(const Label& a, const Label& b, const shape::ShFitter& fitter) {
  const double ra = equivalent_radius(a.volume), rb = equivalent_radius(b.volume), v = a.volume + b.volume;
  const Eigen::Vector3d cb(0.0, 0.0, ra + rb), p = b.volume / v * cb;
  Label m;
  m.volume = v;
  m.centroid = (a.volume * a.centroid + b.volume * b.centroid) / v;
  m.invariants = body_invariants(fitter, [&](const Eigen::Vector3d& u) {
    return std::max(ball_exit(p, u, Eigen::Vector3d::Zero(), ra), ball_exit(p, u, cb, rb));
  });
  m.source = {a.source[0], b.source[0]};
  return m;
}

/// The two labels of grain g cut by the plane at `offset` (in [0, 1) of its body's radius) from
/// its centre across the unit normal n: the cap beyond the plane and the rest, each with its volume,
/// centroid and the invariants of its piece of the ball seen from its own centroid.
std::array<Label, 2> cut_labels(const Label& g, const Eigen::Vector3d& n, double offset, const shape::ShFitter& fitter) {
  const double r = equivalent_radius(g.volume), h = offset * r, t = r - h;
  const double cap_share = t * t * (3.0 * r - t) / (4.0 * r * r * r);          // cap volume / ball volume
  const double cap_at = 3.0 * (2.0 * r - t) * (2.0 * r - t) / (4.0 * (3.0 * r - t));  // cap centroid from the centre
  std::array<Label, 2> piece;
  for (int k = 0; k < 2; ++k) {
    const double side = k == 0 ? 1.0 : -1.0;  // the cap lies on the normal's side of the plane
    const double share = k == 0 ? cap_share : 1.0 - cap_share;
    const double at = k == 0 ? cap_at : -cap_share * cap_at / (1.0 - cap_share);
    const Eigen::Vector3d p(0.0, 0.0, at), axis = Eigen::Vector3d::UnitZ();  // the body frame: normal along z
    piece[k].volume = share * g.volume;
    piece[k].centroid = g.centroid + at * n;
    piece[k].invariants = body_invariants(fitter, [&](const Eigen::Vector3d& u) {
      const double towards_plane = -side * u.dot(axis);
      const double plane_exit = towards_plane > 0.0 ? side * (at - h) / towards_plane : 1e300;
      return std::min(ball_exit(p, u, Eigen::Vector3d::Zero(), r), plane_exit);
    });
    piece[k].source = g.source;
  }
  return piece;
}

}  // namespace

bool DeformedScan::holds(std::size_t j, std::size_t i) const {
  return source.at(j)[0] == static_cast<int>(i) || source.at(j)[1] == static_cast<int>(i);
}

bool DeformedScan::damaged(std::size_t j) const {
  const int i = source.at(j)[0];
  return i >= 0 && (source[j][1] >= 0 || fate.at(static_cast<std::size_t>(i)) == Segmented::cut);
}

DeformedScan deform_scan(const ScanGrains& ref, const SyntheticMotion& m) {
  for (double share : {m.missing, m.extra, m.merged, m.cut})
    if (!(share >= 0.0 && share <= 1.0)) throw UsageError("deform_scan: every share must be in [0, 1]");
  if (m.missing + m.merged + m.cut > 1.0) throw UsageError("deform_scan: missing, merged and cut grains add up to more than all");
  std::mt19937_64 rng(m.seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const double d50 = ref.d50;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (const auto& c : ref.centroid) lo = lo.cwiseMin(c), hi = hi.cwiseMax(c);
  const Eigen::Vector3d mid = (lo + hi) / 2.0;
  // Band plane through the box centre, dipping 60 degrees towards +x; slip along its dip.
  const double dip = 60.0 * std::numbers::pi / 180.0;
  const Eigen::Vector3d normal(std::sin(dip), 0.0, -std::cos(dip)), along(std::cos(dip), 0.0, std::sin(dip));
  const auto noisy = [&](Eigen::VectorXd r, std::mt19937_64& g) {
    const double r0 = r[0];
    for (Eigen::Index k = 0; k < r.size(); ++k) r[k] = std::abs(r[k] + m.shape_noise * r0 * gauss(g));
    return r;
  };
  DeformedScan out;
  out.fate.assign(ref.size(), Segmented::missing);
  std::vector<Label> moved(ref.size());  // every grain present, as it would be segmented intact
  for (std::size_t i = 0; i < ref.size(); ++i) {
    if (uniform(rng) < m.missing) continue;
    const Eigen::Vector3d x = ref.centroid[i] - mid;
    Eigen::Vector3d y = ref.centroid[i];
    y.z() = ref.centroid[i].z() * (1.0 - m.axial_strain);
    y.x() += m.bulge * m.axial_strain * x.x();
    y.y() += m.bulge * m.axial_strain * x.y();
    const double side = std::erf(x.dot(normal) / (m.band_width_d50 * d50 / 2.0));
    y += 0.5 * m.band_slip_d50 * d50 * side * along;
    for (int k = 0; k < 3; ++k) y[k] += m.noise_d50 * d50 * gauss(rng);
    moved[i].invariants = noisy(ref.invariants.row(static_cast<Eigen::Index>(i)).transpose(), rng);
    moved[i].centroid = y;
    moved[i].volume = ref.volume[i] * std::max(0.5, 1.0 + m.volume_noise * gauss(rng));
    moved[i].source[0] = static_cast<int>(i);
    out.fate[i] = Segmented::intact;
  }
  // Damage, from its own random stream so that an undamaged scan is drawn as before: pairs of
  // grains near each other in the reference scan merged, then other grains cut.
  std::vector<int> merged_with(ref.size(), -1);
  std::vector<std::array<Label, 2>> pieces(ref.size());
  if (m.merged > 0.0 || m.cut > 0.0) {
    std::mt19937_64 damage_rng(m.seed ^ 0x5eed'da7a'9e3c'0b1dULL);
    std::vector<std::size_t> order(ref.size());
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), damage_rng);
    const shape::ShFitter fitter(static_cast<int>(ref.invariants.cols()) - 1);
    const PointGrid grid(ref.centroid, d50);
    const auto target = [&](double share) { return static_cast<std::size_t>(std::lround(share * static_cast<double>(ref.size()))); };
    std::size_t merged = 0, cut = 0;
    for (std::size_t i : order) {
      if (merged + 2 > target(m.merged)) break;
      if (out.fate[i] != Segmented::intact) continue;
      std::size_t nearest = ref.size();
      double best = std::numeric_limits<double>::infinity();
      grid.for_each_within(ref.centroid[i], 1.5 * d50, [&](std::size_t k, double d2) {
        if (k != i && out.fate[k] == Segmented::intact && d2 < best) best = d2, nearest = k;
      });
      if (nearest == ref.size()) continue;
      out.fate[i] = out.fate[nearest] = Segmented::merged;
      merged_with[std::min(i, nearest)] = static_cast<int>(std::max(i, nearest));
      merged += 2;
    }
    for (std::size_t i : order) {
      if (cut >= target(m.cut)) break;
      if (out.fate[i] != Segmented::intact) continue;
      Eigen::Vector3d n(gauss(damage_rng), gauss(damage_rng), gauss(damage_rng));
      pieces[i] = cut_labels(moved[i], n.normalized(), 0.5 * uniform(damage_rng), fitter);
      for (Label& p : pieces[i]) p.invariants = noisy(p.invariants, damage_rng);
      out.fate[i] = Segmented::cut;
      ++cut;
    }
    for (std::size_t i = 0; i < ref.size(); ++i)
      if (merged_with[i] >= 0) {
        Label& joint = moved[i];
        joint = merged_label(joint, moved[static_cast<std::size_t>(merged_with[i])], fitter);
        joint.invariants = noisy(joint.invariants, damage_rng);
      }
  }
  // The labels in reference order (a merged pair where its lower grain is), then the newcomers.
  std::vector<Label> labels;
  for (std::size_t i = 0; i < ref.size(); ++i) {
    if (out.fate[i] == Segmented::intact || merged_with[i] >= 0) labels.push_back(moved[i]);
    if (out.fate[i] == Segmented::cut) labels.insert(labels.end(), pieces[i].begin(), pieces[i].end());
  }
  const std::size_t extra = static_cast<std::size_t>(std::lround(m.extra * static_cast<double>(ref.size())));
  const ScanGrains newcomers = synthetic_grains(std::max<std::size_t>(extra, 1), d50, static_cast<int>(ref.invariants.cols()) - 1,
                                                m.seed + 1);
  for (std::size_t k = 0; k < extra; ++k) {
    Label g;
    g.centroid = lo + Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng)).cwiseProduct(hi - lo);
    g.volume = newcomers.volume[k];
    g.invariants = newcomers.invariants.row(static_cast<Eigen::Index>(k)).transpose();
    labels.push_back(g);
  }
  std::vector<std::size_t> order(labels.size());
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), rng);
  ScanGrains& s = out.grains;
  s.d50 = d50;
  s.invariants.resize(static_cast<Eigen::Index>(labels.size()), ref.invariants.cols());
  out.partner.assign(ref.size(), -1);
  for (std::size_t k = 0; k < order.size(); ++k) {
    const Label& g = labels[order[k]];
    s.centroid.push_back(g.centroid);
    s.volume.push_back(g.volume);
    s.invariants.row(static_cast<Eigen::Index>(k)) = g.invariants.transpose();
    s.label.push_back(static_cast<std::uint32_t>(k + 1));
    out.source.push_back(g.source);
    if (g.source[0] >= 0 && out.fate[static_cast<std::size_t>(g.source[0])] == Segmented::intact)
      out.partner[static_cast<std::size_t>(g.source[0])] = static_cast<int>(k);
  }
  return out;
}

SyntheticScore score_matching(const DeformedScan& truth, const Matching& m) {
  if (m.partner.size() != truth.fate.size()) throw UsageError("score_matching: the matching is not of this scan's reference grains");
  SyntheticScore s;
  for (std::size_t i = 0; i < truth.fate.size(); ++i) {
    const int j = m.partner[i];
    if (truth.fate[i] == Segmented::intact) {
      ++s.intact;
      (j < 0 ? s.lost : j == truth.partner[i] ? s.right : s.wrong) += 1;
    } else if (truth.fate[i] != Segmented::missing) {
      ++s.damaged;
      if (j < 0) {
        ++s.damaged_lost;
      } else if (truth.holds(static_cast<std::size_t>(j), i)) {
        ++s.damaged_own;
      } else {
        ++s.damaged_wrong;
        s.stolen += !truth.damaged(static_cast<std::size_t>(j)) && truth.source[static_cast<std::size_t>(j)][0] >= 0;
      }
    }
  }
  return s;
}

ScanGrains deform_grains(const ScanGrains& ref, const SyntheticMotion& m, std::vector<int>& truth) {
  DeformedScan d = deform_scan(ref, m);
  truth = std::move(d.partner);
  return std::move(d.grains);
}

}  // namespace graintwin::track
