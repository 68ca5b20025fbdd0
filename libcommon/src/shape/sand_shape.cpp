// Random sand-grain SH coefficients (Wei, Wang & Zhao 2018 spectrum, radial form), reference
// shapes and shape statistics.
#include "graintwin/shape/sand_shape.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <numbers>
#include <string>
#include <vector>

#include "graintwin/core/error.hpp"
#include "graintwin/core/geometry.hpp"
#include "graintwin/shape/sh_basis.hpp"

namespace graintwin::shape {

namespace {

constexpr double kCentroidTolerance = 1e-5;  // of the volume-equivalent radius
constexpr double kMinRadius = 0.1;           // of the volume-equivalent radius, on sample grids
constexpr int kMaxDraws = 1000;
constexpr int kMaxCentringSteps = 20;
constexpr int kMaxRaySteps = 100;

// Fixed Fibonacci direction set, its design matrix and QR factorisation for one degree: every
// re-fit of every grain reuses them, so they are built once per degree.
struct FitBasis {
  std::vector<Eigen::Vector3d> dirs;
  Eigen::MatrixXd design;
  Eigen::HouseholderQR<Eigen::MatrixXd> qr;
};

std::shared_ptr<const FitBasis> fit_basis(int degree) {
  static std::mutex mutex;
  static std::map<int, std::shared_ptr<const FitBasis>> cache;
  const std::lock_guard<std::mutex> lock(mutex);
  auto& entry = cache[degree];
  if (!entry) {
    auto basis = std::make_shared<FitBasis>();
    // Twice the unknowns keeps cond(A) ~ 1.1 (anchors-sh-mesh.md section 3).
    basis->dirs = fibonacci_directions(2 * sh_count(degree));
    basis->design = sh_design_matrix(degree, basis->dirs);
    basis->qr.compute(basis->design);
    entry = std::move(basis);
  }
  return entry;
}

void validate(const SandShapeParams& p) {
  if (p.degree < 2) {
    throw UsageError("SandShapeParams.degree must be >= 2 (got " + std::to_string(p.degree) +
                     "); use 15 for sand");
  }
  if (!std::isfinite(p.d2) || p.d2 < 0.0) {
    throw UsageError("SandShapeParams.d2 must be finite and >= 0 (got " + std::to_string(p.d2) +
                     ")");
  }
  if (!(p.d2_spread >= 0.0 && p.d2_spread < 1.0)) {
    throw UsageError("SandShapeParams.d2_spread must be in [0, 1) (got " +
                     std::to_string(p.d2_spread) + ")");
  }
  if (!(p.exponent_spread >= 0.0 && p.exponent_spread < 1.0) ||
      !(p.degree_jitter >= 0.0 && std::isfinite(p.degree_jitter))) {
    throw UsageError("SandShapeParams.exponent_spread must be in [0, 1) and degree_jitter finite "
                     "and >= 0 (got " + std::to_string(p.exponent_spread) + ", " +
                     std::to_string(p.degree_jitter) + ")");
  }
  if (!std::isfinite(p.roundness_exponent) || !std::isfinite(p.roughness_exponent)) {
    throw UsageError("SandShapeParams exponents must be finite numbers");
  }
  if (p.roughness_from_degree < 3 || p.roughness_from_degree > p.degree + 1) {
    throw UsageError("SandShapeParams.roughness_from_degree must be in [3, degree + 1] (got " +
                     std::to_string(p.roughness_from_degree) + " for degree " +
                     std::to_string(p.degree) + ")");
  }
}

// One grain's spectrum Dhat_n = D_n / D_0, n = 0..degree (SandShapeParams doc): the drawn Dhat_2,
// the grain's own exponents, and a per-degree factor (1 for n <= 2) of each Dhat_n.
struct GrainSpectrum {
  double dhat2 = 0.0, roundness_exponent = 0.0, roughness_exponent = 0.0;
  Eigen::VectorXd jitter;
};

Eigen::VectorXd invariant_ratios(const SandShapeParams& p, const GrainSpectrum& g) {
  Eigen::VectorXd d = Eigen::VectorXd::Zero(p.degree + 1);
  d[0] = 1.0;
  const int nr = p.roughness_from_degree;
  const double at_nr = g.dhat2 * std::pow(nr / 2.0, -g.roundness_exponent);
  for (int n = 2; n <= p.degree; ++n) {
    d[n] = g.jitter[n] * (n < nr ? g.dhat2 * std::pow(n / 2.0, -g.roundness_exponent)
                                 : at_nr * std::pow(static_cast<double>(n) / nr, -g.roughness_exponent));
  }
  return d;
}

// Ray length t > 0 from `origin` along unit e to the surface |x| = r(x / |x|), by the fixed point
// t <- root of |origin + t e| = r(dir(origin + t e)). It contracts with factor ~ |grad r| |origin|
// / r, small for a near-centroid origin; returns NaN if it does not converge, which flags a grain
// that is not star-shaped (or too steep) about the origin.
double ray_length(const Eigen::VectorXd& coeffs, int degree, const Eigen::Vector3d& origin,
                  const Eigen::Vector3d& e, double t0) {
  const double b = origin.dot(e);
  const double o2 = origin.squaredNorm();
  double t = t0;
  for (int step = 0; step < kMaxRaySteps; ++step) {
    const Eigen::Vector3d x = origin + t * e;
    const double r = sh_radius(coeffs, degree, x);
    const double disc = b * b - o2 + r * r;
    if (!(r > 0.0) || disc < 0.0) return std::nan("");
    const double t_next = -b + std::sqrt(disc);
    if (std::abs(t_next - t) <= 1e-13 * t_next) return t_next;
    t = t_next;
  }
  return std::nan("");
}

// Moves the SH origin to the grain's centroid (re-fit about the centroid until the offset is below
// kCentroidTolerance of the volume-equivalent radius) and scales to unit volume-equivalent radius.
// Returns false if the volume is not positive or a ray solve fails.
bool centre_and_normalise(Eigen::VectorXd& coeffs, int degree, const FitBasis& basis) {
  const auto n_dirs = static_cast<std::ptrdiff_t>(basis.dirs.size());
  Eigen::VectorXd lengths(n_dirs);
  for (int step = 0; step < kMaxCentringSteps; ++step) {
    const ShMoments m = sh_moments(coeffs, degree);
    if (!(m.volume > 0.0)) return false;  // r mostly negative: not a body at all
    const double r_eq = equivalent_radius(m.volume);
    if (m.centroid.norm() <= kCentroidTolerance * r_eq) {
      coeffs /= r_eq;
      return true;
    }
    const Eigen::VectorXd r_old = basis.design * coeffs;
    bool ok = true;
#pragma omp parallel for schedule(static) reduction(&& : ok)
    for (std::ptrdiff_t i = 0; i < n_dirs; ++i) {
      const Eigen::Vector3d& e = basis.dirs[static_cast<std::size_t>(i)];
      // First guess: the old radius seen from the shifted origin, to first order in the offset.
      const double t = ray_length(coeffs, degree, m.centroid, e, r_old[i] - m.centroid.dot(e));
      lengths[i] = t;
      ok = ok && std::isfinite(t);
    }
    if (!ok) return false;
    coeffs = basis.qr.solve(lengths);
  }
  return false;
}

}  // namespace

Eigen::VectorXd random_sand_coeffs(const SandShapeParams& params, std::mt19937_64& rng) {
  validate(params);
  const int degree = params.degree;
  const std::shared_ptr<const FitBasis> basis = fit_basis(degree);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  const double d0 = std::sqrt(4.0 * std::numbers::pi);  // c_00 of the unit sphere
  for (int draw = 0; draw < kMaxDraws; ++draw) {
    GrainSpectrum spectrum;
    spectrum.dhat2 = params.d2 * (1.0 + params.d2_spread * uniform(rng));
    spectrum.roundness_exponent =
        params.roundness_exponent * (1.0 + params.exponent_spread * uniform(rng));
    spectrum.roughness_exponent =
        params.roughness_exponent * (1.0 + params.exponent_spread * uniform(rng));
    spectrum.jitter = Eigen::VectorXd::Ones(degree + 1);
    for (int n = 3; n <= degree; ++n) spectrum.jitter[n] = std::exp(params.degree_jitter * normal(rng));
    const Eigen::VectorXd dhat = invariant_ratios(params, spectrum);
    Eigen::VectorXd coeffs = Eigen::VectorXd::Zero(sh_count(degree));
    coeffs[0] = d0;
    for (int n = 2; n <= degree; ++n) {
      // A Gaussian vector has a uniformly distributed direction in R^(2n+1).
      Eigen::VectorXd g(2 * n + 1);
      for (Eigen::Index k = 0; k < g.size(); ++k) g[k] = normal(rng);
      coeffs.segment(n * n, 2 * n + 1) = (d0 * dhat[n] / g.norm()) * g;
    }
    if (!centre_and_normalise(coeffs, degree, *basis)) continue;
    const double fit_grid_min = (basis->design * coeffs).minCoeff();
    if (std::min(fit_grid_min, sh_moments(coeffs, degree).min_sampled_radius) < kMinRadius) {
      continue;
    }
    return coeffs;
  }
  throw DataError("random_sand_coeffs rejected " + std::to_string(kMaxDraws) +
                  " draws in a row as not star-shaped; lower d2 or raise the exponents");
}

Eigen::VectorXd sphere_coeffs(double radius, int degree) {
  if (!std::isfinite(radius) || radius <= 0.0) {
    throw UsageError("sphere_coeffs needs a finite radius > 0 (got " + std::to_string(radius) +
                     ")");
  }
  Eigen::VectorXd c = Eigen::VectorXd::Zero(sh_count(degree));
  c[0] = radius * std::sqrt(4.0 * std::numbers::pi);
  return c;
}

RadialTable ellipsoid_table(double a, double b, double c, int n) {
  for (double s : {a, b, c}) {
    if (!std::isfinite(s) || s <= 0.0) {
      throw UsageError("ellipsoid_table needs finite semi-axes > 0 (got " + std::to_string(s) +
                       ")");
    }
  }
  const Eigen::Vector3d inv2(1.0 / (a * a), 1.0 / (b * b), 1.0 / (c * c));
  return RadialTable::from_function(
      [&inv2](const Eigen::Vector3d& d) { return 1.0 / std::sqrt(d.cwiseAbs2().dot(inv2)); }, n);
}

void set_equivalent_ellipsoid(ShapeStats& s, const Eigen::Matrix3d& m) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(m);
  // Eigenvalues come ascending; a solid ellipsoid has M_ii / V = a_i^2 / 5.
  for (int i = 0; i < 3; ++i) {
    s.semi_axes[i] = std::sqrt(5.0 * std::max(eigen.eigenvalues()[2 - i], 0.0));
    s.axes.col(i) = eigen.eigenvectors().col(2 - i);
  }
  if (s.axes.determinant() < 0) s.axes.col(2) = -s.axes.col(2);
  s.aspect_ratio = s.semi_axes[0] / s.semi_axes[2];
}

ShapeStats shape_stats(const RadialTable& table) {
  if (table.empty()) {
    throw UsageError("shape_stats got an empty RadialTable; build it with from_function first");
  }
  ShapeStats s;
  s.volume = table.volume();
  s.surface_area = table.surface_area();
  s.equivalent_diameter = equivalent_diameter(s.volume);
  s.sphericity = sphericity(s.volume, s.surface_area);
  // J = tr(M) I - M, so M = tr(J)/2 I - J.
  const Eigen::Matrix3d j = table.inertia_tensor();
  const Eigen::Matrix3d m = 0.5 * j.trace() * Eigen::Matrix3d::Identity() - j;
  set_equivalent_ellipsoid(s, m / s.volume);
  return s;
}

}  // namespace graintwin::shape
