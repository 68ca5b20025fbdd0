#include "graintwin/synth/loading.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <random>

#include "graintwin/core/error.hpp"

namespace graintwin::synth {

namespace {

// Barrel profile over the normalised height zeta in [-1, 1], mean 1 over the height.
double barrel(double zeta) { return 1.5 * (1.0 - zeta * zeta); }

struct Band {
  Eigen::Vector3d point, normal, slip_dir;  // plane through point; slip of the upper side
  double share;                             // fraction of the total slip this band carries
};

std::vector<Band> bands(const LoadingParams& p) {
  std::vector<Band> out;
  if (p.band == ShearBand::none) return out;
  const double th = p.band_angle_deg * M_PI / 180.0, az = p.band_azimuth_deg * M_PI / 180.0;
  const Eigen::Vector3d centre(p.centre_x, p.centre_y, 0.5 * p.height);
  auto make = [&](double azimuth, double share) {
    const Eigen::Vector3d h(std::cos(azimuth), std::sin(azimuth), 0.0);  // horizontal dip direction
    const Eigen::Vector3d up_dip = (std::cos(th) * h + std::sin(th) * Eigen::Vector3d::UnitZ()).normalized();
    const Eigen::Vector3d normal = (-std::sin(th) * h + std::cos(th) * Eigen::Vector3d::UnitZ()).normalized();
    out.push_back({centre, normal, -up_dip, share});  // the upper block slides down the dip
  };
  if (p.band == ShearBand::single) {
    make(az, 1.0);
  } else {
    make(az, 0.5);
    make(az + M_PI, 0.5);
  }
  return out;
}

// Smooth step of the slip across a band of width w at signed distance d: 0 below, 1 above.
double slip_profile(double d, double w) { return 0.5 * (1.0 + std::erf(2.0 * d / w)); }
double slip_gradient(double d, double w) { return 2.0 / (w * std::sqrt(M_PI)) * std::exp(-4.0 * d * d / (w * w)); }

// Cubic B-spline weights of the four lattice nodes around fractional position t in [0, 1).
std::array<double, 4> bspline_weights(double t) {
  const double t2 = t * t, t3 = t2 * t, s = 1.0 - t;
  return {s * s * s / 6.0, (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0, (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0, t3 / 6.0};
}

// A smooth random vector field of unit std in each component at every point: independent normal
// vectors on a lattice of spacing `length` over [lo, hi], blended by cubic B-splines and divided by
// the blend's own std there (the sum of the squared weights), so only the correlation depends on
// where the point lies between the nodes. Its correlation falls to zero at four spacings.
class SmoothNoise {
 public:
  SmoothNoise(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double length, std::uint64_t seed)
      : lo_(lo), length_(length) {
    for (int a = 0; a < 3; ++a) dims_[a] = static_cast<std::size_t>(std::floor((hi[a] - lo[a]) / length)) + 4;
    values_.resize(dims_[0] * dims_[1] * dims_[2]);
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> n01;
    for (Eigen::Vector3d& v : values_) v = Eigen::Vector3d(n01(rng), n01(rng), n01(rng));
  }
  Eigen::Vector3d at(const Eigen::Vector3d& x) const {
    std::array<std::array<double, 4>, 3> w;
    std::array<std::size_t, 3> base;
    double variance = 1.0;
    for (int a = 0; a < 3; ++a) {
      const double u = (x[a] - lo_[a]) / length_;
      const double cell = std::clamp(std::floor(u), 0.0, static_cast<double>(dims_[a] - 4));
      base[a] = static_cast<std::size_t>(cell);
      w[a] = bspline_weights(std::clamp(u - cell, 0.0, 1.0));
      double sum2 = 0.0;
      for (double wi : w[a]) sum2 += wi * wi;
      variance *= sum2;
    }
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j)
        for (int k = 0; k < 4; ++k)
          sum += w[0][i] * w[1][j] * w[2][k] *
                 values_[((base[2] + k) * dims_[1] + base[1] + j) * dims_[0] + base[0] + i];
    return sum / std::sqrt(variance);
  }

 private:
  Eigen::Vector3d lo_;
  double length_;
  std::array<std::size_t, 3> dims_{};
  std::vector<Eigen::Vector3d> values_;
};

// Lattices beyond this many nodes (a correlation length far below the grain size) are refused.
constexpr std::size_t kMaxNoiseNodes = 50'000'000;

void validate(const LoadingParams& p) {
  if (!(p.height > 0.0 && p.radius > 0.0)) throw UsageError("loading needs a positive sample height and radius");
  if (p.band != ShearBand::none && !(p.band_width > 0.0))
    throw UsageError("a shear band needs a positive band width (about 10 d50)");
  if (!(p.band_angle_deg > 0.0 && p.band_angle_deg < 90.0))
    throw UsageError("band angle must be between 0 and 90 degrees from the horizontal");
}

}  // namespace

void check_nonaffine_correlation(double length, const Eigen::Vector3d& extent) {
  if (!(length >= 0.0) || !std::isfinite(length))
    throw UsageError("the nonaffine correlation length must be 0 (independent grains) or a positive length");
  if (length == 0.0) return;
  double nodes = 1.0;  // SmoothNoise's lattice
  for (int a = 0; a < 3; ++a) nodes *= std::floor(std::max(0.0, extent[a]) / length) + 4.0;
  if (nodes > static_cast<double>(kMaxNoiseNodes))
    throw UsageError(fmt::format("a nonaffine correlation length of {:.3g} mm is too short for a sample {:.3g} mm across: "
                                 "give at least {:.3g} mm (about the grain size), or 0 for independent grains",
                                 1e3 * length, 1e3 * extent.maxCoeff(),
                                 2e3 * extent.maxCoeff() / std::cbrt(static_cast<double>(kMaxNoiseNodes))));
}

Eigen::Vector3d smooth_displacement(const LoadingParams& p, const Eigen::Vector3d& x, double eps) {
  const double zeta = 2.0 * x.z() / p.height - 1.0;
  const Eigen::Vector3d radial(x.x() - p.centre_x, x.y() - p.centre_y, 0.0);
  Eigen::Vector3d u(0.0, 0.0, -eps * x.z());
  u += radial * (p.bulge * eps * barrel(std::clamp(zeta, -1.0, 1.0)));
  for (const Band& b : bands(p)) {
    const double d = b.normal.dot(x - b.point);
    u += b.slip_dir * (b.share * p.band_slip * eps * p.height * slip_profile(d, p.band_width));
  }
  return u;
}

double local_shear(const LoadingParams& p, const Eigen::Vector3d& x, double eps) {
  double g = 0.0;
  for (const Band& b : bands(p)) {
    const double d = b.normal.dot(x - b.point);
    g += b.share * p.band_slip * eps * p.height * slip_gradient(d, p.band_width);
  }
  return g + eps;  // the affine part shears at about the axial strain
}

double sample_radius_at(const LoadingParams& p, double z_deformed, double eps) {
  const double h = p.height * (1.0 - eps);
  const double zeta = std::clamp(2.0 * z_deformed / h - 1.0, -1.0, 1.0);
  return p.radius * (1.0 + p.bulge * eps * barrel(zeta));
}

std::vector<std::vector<PackedGrain>> loading_states(const LoadingParams& p, const std::vector<PackedGrain>& reference,
                                                     const std::vector<double>& strains) {
  validate(p);
  std::vector<std::vector<PackedGrain>> states;
  std::vector<Eigen::Vector3d> walk(reference.size(), Eigen::Vector3d::Zero());
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const PackedGrain& g : reference) lo = lo.cwiseMin(g.position), hi = hi.cwiseMax(g.position);
  const bool correlated = p.nonaffine_correlation > 0.0 && !reference.empty();
  check_nonaffine_correlation(p.nonaffine_correlation, reference.empty() ? Eigen::Vector3d::Zero() : Eigen::Vector3d(hi - lo));
  std::vector<Eigen::Quaterniond> spin(reference.size(), Eigen::Quaterniond::Identity());
  double prev = 0.0;
  for (std::size_t k = 0; k < strains.size(); ++k) {
    const double eps = strains[k];
    if (!(eps >= 0.0 && eps < 0.5)) throw UsageError("axial strains must lie in [0, 0.5)");
    const double deps = eps - prev;
    std::vector<PackedGrain> state(reference.size());
    std::optional<SmoothNoise> field;
    if (correlated && k > 0 && deps != 0.0)
      field.emplace(lo, hi, p.nonaffine_correlation, p.seed ^ (0xD6E8FEB86659FD93ull * (k + 1)));
    for (std::size_t i = 0; i < reference.size(); ++i) {
      const Eigen::Vector3d& x = reference[i].position;
      if (k > 0 && deps != 0.0) {
        // Per grain and state, an independent stream: the result is the same in any loop order.
        std::mt19937_64 rng(p.seed ^ (0x9E3779B97F4A7C15ull * (i + 1)) ^ (0xC2B2AE3D27D4EB4Full * (k + 1)));
        std::normal_distribution<double> n01;
        double band_weight = 0.0;
        for (const Band& b : bands(p)) {
          const double d = b.normal.dot(x - b.point);
          band_weight += b.share * std::exp(-4.0 * d * d / (p.band_width * p.band_width));
        }
        const double sigma = p.nonaffine * p.band_slip * std::abs(deps) * p.height * band_weight;
        const Eigen::Vector3d draw(n01(rng), n01(rng), n01(rng));  // drawn either way: the rotations' stream stays
        walk[i] += sigma * (field ? field->at(x) : draw);
        const double shear_inc = local_shear(p, x, eps) - local_shear(p, x, prev);
        const double angle = p.rotation_per_shear * shear_inc + p.rotation_noise_deg * M_PI / 180.0 * n01(rng);
        const Eigen::Vector3d axis = Eigen::Vector3d(n01(rng), n01(rng), n01(rng)).normalized();
        spin[i] = (Eigen::Quaterniond(Eigen::AngleAxisd(angle, axis)) * spin[i]).normalized();
      }
      state[i].position = x + smooth_displacement(p, x, eps) + walk[i];
      state[i].orientation = (spin[i] * reference[i].orientation).normalized();
    }
    states.push_back(std::move(state));
    prev = eps;
  }
  return states;
}

}  // namespace graintwin::synth
