#include "graintwin/track/synthetic.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <random>

#include "graintwin/core/error.hpp"

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

ScanGrains deform_grains(const ScanGrains& ref, const SyntheticMotion& m, std::vector<int>& truth) {
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
  std::vector<Eigen::Vector3d> pos;
  std::vector<double> vol;
  std::vector<Eigen::VectorXd> inv;
  truth.assign(ref.size(), -1);
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
    Eigen::VectorXd r = ref.invariants.row(static_cast<Eigen::Index>(i)).transpose();
    const double r0 = r[0];
    for (Eigen::Index k = 0; k < r.size(); ++k) r[k] = std::abs(r[k] + m.shape_noise * r0 * gauss(rng));
    truth[i] = static_cast<int>(pos.size());
    pos.push_back(y);
    vol.push_back(ref.volume[i] * std::max(0.5, 1.0 + m.volume_noise * gauss(rng)));
    inv.push_back(r);
  }
  const std::size_t extra = static_cast<std::size_t>(std::lround(m.extra * static_cast<double>(ref.size())));
  const ScanGrains newcomers = synthetic_grains(std::max<std::size_t>(extra, 1), d50, static_cast<int>(ref.invariants.cols()) - 1,
                                                m.seed + 1);
  for (std::size_t k = 0; k < extra; ++k) {
    pos.push_back(lo + Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng)).cwiseProduct(hi - lo));
    vol.push_back(newcomers.volume[k]);
    inv.push_back(newcomers.invariants.row(static_cast<Eigen::Index>(k)).transpose());
  }
  // Shuffle so that indices carry no identity.
  std::vector<std::size_t> order(pos.size());
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), rng);
  std::vector<int> where(pos.size());
  ScanGrains out;
  out.d50 = d50;
  out.invariants.resize(static_cast<Eigen::Index>(pos.size()), ref.invariants.cols());
  for (std::size_t k = 0; k < order.size(); ++k) {
    where[order[k]] = static_cast<int>(k);
    out.centroid.push_back(pos[order[k]]);
    out.volume.push_back(vol[order[k]]);
    out.invariants.row(static_cast<Eigen::Index>(k)) = inv[order[k]].transpose();
    out.label.push_back(static_cast<std::uint32_t>(k + 1));
  }
  for (auto& t : truth)
    if (t >= 0) t = where[static_cast<std::size_t>(t)];
  return out;
}

}  // namespace graintwin::track
