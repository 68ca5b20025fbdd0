#include "graintwin/synth/loading.hpp"

#include <cmath>
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

void validate(const LoadingParams& p) {
  if (!(p.height > 0.0 && p.radius > 0.0)) throw UsageError("loading needs a positive sample height and radius");
  if (p.band != ShearBand::none && !(p.band_width > 0.0))
    throw UsageError("a shear band needs a positive band width (about 10 d50)");
  if (!(p.band_angle_deg > 0.0 && p.band_angle_deg < 90.0))
    throw UsageError("band angle must be between 0 and 90 degrees from the horizontal");
}

}  // namespace

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
  std::vector<Eigen::Quaterniond> spin(reference.size(), Eigen::Quaterniond::Identity());
  double prev = 0.0;
  for (std::size_t k = 0; k < strains.size(); ++k) {
    const double eps = strains[k];
    if (!(eps >= 0.0 && eps < 0.5)) throw UsageError("axial strains must lie in [0, 0.5)");
    const double deps = eps - prev;
    std::vector<PackedGrain> state(reference.size());
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
        walk[i] += sigma * Eigen::Vector3d(n01(rng), n01(rng), n01(rng));
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
