#include "graintwin/track/rotation.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <numbers>

#include "graintwin/core/enum_names.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/shape/sh_basis.hpp"
#include "graintwin/shape/sh_fitter.hpp"

namespace graintwin::track {
namespace {

double angle_between(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return std::acos(std::clamp(((a.transpose() * b).trace() - 1.0) / 2.0, -1.0, 1.0));
}

Eigen::Matrix3d rotation_of(const Eigen::Vector3d& w) {
  const double t = w.norm();
  return t > 0.0 ? Eigen::AngleAxisd(t, w / t).toRotationMatrix() : Eigen::Matrix3d::Identity();
}

/// The length the radial misfit is expressed in: the equivalent radius of the grain.
double radius_scale(const shape::GrainShape& g) {
  return g.equivalent_diameter > 0.0 ? g.equivalent_diameter / 2.0 : g.coeffs[0] / std::sqrt(4.0 * std::numbers::pi);
}

bool near_symmetric(const Eigen::Vector3d& s, double tol) {
  return !(s[0] > 0.0) || (s[0] - s[1]) < tol * s[0] || (s[1] - s[2]) < tol * s[1];
}

struct Candidate {
  Eigen::Matrix3d r;
  double misfit;
};

}  // namespace

void inertia_ellipsoid(const Eigen::VectorXd& coeffs, int degree, Eigen::Vector3d& semi_axes, Eigen::Matrix3d& axes) {
  const shape::SphereQuadrature q = shape::sphere_quadrature(2 * degree + 4, 4 * degree + 8);
  const Eigen::VectorXd r = shape::sh_design_matrix(degree, q.directions) * coeffs.head(shape::sh_count(degree));
  Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
  double volume = 0.0;
  for (std::size_t k = 0; k < q.directions.size(); ++k) {
    const double rk = r[static_cast<Eigen::Index>(k)];
    volume += q.weights[k] * rk * rk * rk / 3.0;
    m += q.weights[k] * std::pow(rk, 5) / 5.0 * q.directions[k] * q.directions[k].transpose();
  }
  if (!(volume > 0.0)) throw DataError("inertia_ellipsoid: the SH body has no positive volume");
  // A uniform solid ellipsoid has second moments a_k^2 / 5 per unit volume.
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(m / volume);
  for (int k = 0; k < 3; ++k) {
    semi_axes[k] = std::sqrt(5.0 * std::max(es.eigenvalues()[2 - k], 0.0));
    axes.col(k) = es.eigenvectors().col(2 - k);
  }
  if (axes.determinant() < 0.0) axes.col(2) *= -1.0;
}

namespace {
constexpr std::array<EnumName<RotationMethod>, 3> kRotationMethodNames{
    {{RotationMethod::sh, "sh"}, {RotationMethod::axes, "axes"}, {RotationMethod::none, "none"}}};
}  // namespace

RotationMethod parse_rotation_method(const std::string& name) {
  return parse_enum(kRotationMethodNames, name, "rotation method");
}

const char* rotation_method_name(RotationMethod method) { return enum_name(kRotationMethodNames, method); }

RotationEstimator::RotationEstimator(int coeff_degree, const RotationOptions& o) : options_(o) {
  if (!(o.symmetry_tol >= 0.0 && o.symmetry_tol < 1.0)) throw UsageError("the symmetry tolerance must be in [0, 1)");
  if (!(o.min_margin >= 1.0)) throw UsageError("the rotation margin must be at least 1");
  if (o.degree < 2) throw UsageError("the rotation comparison needs SH degree 2 or more");
  if (coeff_degree < 2) throw UsageError("rotations need SH coefficients of degree 2 or more");
  degree_ = std::min(o.degree, coeff_degree);
  directions_ = shape::fibonacci_directions(2 * shape::sh_count(degree_));
  design_ = shape::sh_design_matrix(degree_, directions_);
}

Eigen::VectorXd RotationEstimator::radii(const shape::GrainShape& g, const Eigen::Matrix3d& r) const {
  // The surface rotated by r: r'(d) = r_g(r^T d).
  const int k = shape::sh_count(degree_);
  if (g.coeffs.size() < k) throw UsageError("RotationEstimator: a grain's SH coefficients are of too low a degree");
  Eigen::VectorXd out(static_cast<Eigen::Index>(directions_.size()));
  std::vector<double> y(static_cast<std::size_t>(k));
  for (std::size_t i = 0; i < directions_.size(); ++i) {
    const Eigen::Vector3d d = r.transpose() * directions_[i];
    shape::real_sh_values(degree_, d.z(), std::atan2(d.y(), d.x()), y.data());
    out[static_cast<Eigen::Index>(i)] = Eigen::Map<const Eigen::VectorXd>(y.data(), k).dot(g.coeffs.head(k));
  }
  return out;
}

double RotationEstimator::misfit(const shape::GrainShape& a, const shape::GrainShape& b, const Eigen::Matrix3d& r) const {
  const Eigen::VectorXd f = design_ * b.coeffs.head(shape::sh_count(degree_)) - radii(a, r);
  return std::sqrt(f.squaredNorm() / static_cast<double>(f.size())) / radius_scale(b);
}

RotationEstimate RotationEstimator::estimate(const shape::GrainShape& a, const shape::GrainShape& b) const {
  RotationEstimate out;
  if (options_.method == RotationMethod::none) return out;
  const int k = shape::sh_count(degree_);
  const Eigen::VectorXd rb = design_ * b.coeffs.head(k);
  const double scale = radius_scale(b);
  const auto cost = [&](const Eigen::Matrix3d& r) {
    return std::sqrt((rb - radii(a, r)).squaredNorm() / static_cast<double>(rb.size())) / scale;
  };
  // The four right-handed sign choices of the principal axes: R = B S A^T.
  std::vector<Candidate> starts;
  for (const Eigen::Vector3d& s : {Eigen::Vector3d(1, 1, 1), Eigen::Vector3d(1, -1, -1), Eigen::Vector3d(-1, 1, -1),
                                  Eigen::Vector3d(-1, -1, 1)}) {
    const Eigen::Matrix3d r = b.axes * s.asDiagonal() * a.axes.transpose();
    starts.push_back({r, cost(r)});
  }
  const auto best_distinct = [](std::vector<Candidate>& c, const Eigen::Matrix3d& from) {
    double m = std::numeric_limits<double>::infinity();
    for (const auto& x : c)
      if (angle_between(x.r, from) > 10.0 * std::numbers::pi / 180.0) m = std::min(m, x.misfit);
    return m;
  };
  const auto by_misfit = [](const Candidate& x, const Candidate& y) { return x.misfit < y.misfit; };
  std::vector<Candidate> result;
  if (options_.method == RotationMethod::axes) {
    result = starts;
  } else {
    // Surface alignment. Extra starts turned about each principal axis by odd multiples of 45
    // degrees (the sign choices hold the 180-degree turns) cover grains whose ellipsoid is nearly
    // symmetric, whose axes may be swapped; the best few distinct starts are refined by
    // Levenberg-Marquardt on the radial differences over rotation vectors (numerical Jacobian).
    const std::size_t base = starts.size();
    for (std::size_t s = 0; s < base; ++s)
      for (int axis = 0; axis < 3; ++axis)
        for (int step = 1; step < 8; step += 2) {
          const Eigen::Matrix3d r =
              starts[s].r * Eigen::AngleAxisd(step * std::numbers::pi / 4.0, a.axes.col(axis)).toRotationMatrix();
          starts.push_back({r, cost(r)});
        }
    std::sort(starts.begin(), starts.end(), by_misfit);
    std::vector<Candidate> seeds;
    for (const auto& s : starts) {
      if (seeds.size() == 3) break;
      if (std::all_of(seeds.begin(), seeds.end(), [&](const Candidate& x) { return angle_between(x.r, s.r) > 0.35; }))
        seeds.push_back(s);
    }
    const double h = 1e-4;
    for (Candidate c : seeds) {
      double mu = 1e-3;
      Eigen::VectorXd f = rb - radii(a, c.r);
      for (int it = 0; it < 12; ++it) {
        Eigen::Matrix<double, Eigen::Dynamic, 3> jac(f.size(), 3);
        for (int q = 0; q < 3; ++q)
          jac.col(q) = (rb - radii(a, rotation_of(h * Eigen::Vector3d::Unit(q)) * c.r) - f) / h;
        const Eigen::Matrix3d jtj = jac.transpose() * jac;
        const Eigen::Vector3d g = jac.transpose() * f;
        const Eigen::Vector3d step = (jtj + mu * jtj.diagonal().asDiagonal().toDenseMatrix() +
                                      1e-12 * Eigen::Matrix3d::Identity()).ldlt().solve(-g);
        const Eigen::Matrix3d r = rotation_of(step) * c.r;
        const Eigen::VectorXd fn = rb - radii(a, r);
        if (fn.squaredNorm() < f.squaredNorm()) {
          c.r = r, f = fn, mu = std::max(mu / 10.0, 1e-9);
          if (step.norm() < 1e-5) break;
        } else {
          mu *= 10.0;
          if (mu > 1e6) break;
        }
      }
      c.misfit = std::sqrt(f.squaredNorm() / static_cast<double>(f.size())) / scale;
      result.push_back(c);
    }
    result.insert(result.end(), starts.begin(), starts.end());
  }
  std::sort(result.begin(), result.end(), by_misfit);
  const Candidate& best = result.front();
  out.misfit = best.misfit;
  out.margin = best_distinct(result, best.r) / std::max(best.misfit, 1e-12);
  Eigen::Quaterniond q(best.r);
  q.normalize();
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  out.rotation = q;
  out.defined = out.margin >= options_.min_margin &&
                (options_.method == RotationMethod::sh || !(near_symmetric(a.semi_axes, options_.symmetry_tol) ||
                                                            near_symmetric(b.semi_axes, options_.symmetry_tol)));
  return out;
}

}  // namespace graintwin::track
