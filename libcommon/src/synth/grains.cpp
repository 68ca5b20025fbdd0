#include "graintwin/synth/grains.hpp"

#include <Eigen/QR>
#include <atomic>
#include <memory>
#include <cmath>
#include <random>

#include "graintwin/core/error.hpp"
#include "graintwin/shape/sh_basis.hpp"
#include "graintwin/shape/sh_fitter.hpp"

namespace graintwin::synth {

GrainShape parse_grain_shape(const std::string& name) {
  if (name == "sphere") return GrainShape::sphere;
  if (name == "ellipsoid") return GrainShape::ellipsoid;
  if (name == "sand") return GrainShape::sand;
  if (name == "angular") return GrainShape::angular;
  throw UsageError("--grain-shape '" + name + "' is not one of sphere, ellipsoid, sand, angular");
}

std::vector<const shape::RadialTable*> GrainSet::table_pointers() const {
  std::vector<const shape::RadialTable*> out;
  for (const auto& t : tables) out.push_back(&t);
  return out;
}

namespace {
// Nodes per cube-face edge so that the bilinear table deviates from the SH surface by at most
// about 0.02 voxel: the measured worst relative error of degree-15 grains is about 27 / n^2.
int table_nodes(double radius_vox) {
  return std::clamp(static_cast<int>(std::ceil(std::sqrt(27.0 * radius_vox / 0.02))), 32, 160);
}

// Runs make(i) for every grain in parallel; the first exception is rethrown after the loop (an
// exception must not leave an OpenMP region).
template <class F>
void for_each_grain(std::size_t n, F&& make) {
  std::exception_ptr failure;
#pragma omp parallel for schedule(dynamic)
  for (std::size_t i = 0; i < n; ++i) {
    try {
      make(i);
    } catch (...) {
#pragma omp critical(grain_failure)
      if (!failure) failure = std::current_exception();
    }
  }
  if (failure) std::rethrow_exception(failure);
}
}  // namespace

double grain_bytes(double diameter, double voxel_size, int degree) {
  const double stride = table_nodes(0.5 * diameter / voxel_size) + 2.0;  // nodes plus the ghost ring
  return 8.0 * (6.0 * stride * stride + shape::sh_count(degree)) + sizeof(shape::RadialTable) + sizeof(shape::ShapeStats);
}

GrainSet make_grains(const GrainSetParams& p, const std::vector<double>& diameters,
                     const std::function<void(double)>& progress) {
  if (p.aspect_ratio < 1.0) throw UsageError("aspect-ratio must be at least 1");
  if (p.shape == GrainShape::angular) validate(p.angular);
  const int degree = p.sand.degree;
  const std::size_t n = diameters.size();
  GrainSet set;
  set.sh_degree = degree;
  set.diameters = diameters;
  set.tables.resize(n);
  set.stats.resize(n);
  set.coeffs_body = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(n), shape::sh_count(degree));
  // Ellipsoids differ only in size: their coefficients are fitted once, at unit volume-equivalent
  // radius, and scaled.
  const double ell_a = std::pow(p.aspect_ratio, 2.0 / 3.0), ell_b = std::pow(p.aspect_ratio, -1.0 / 3.0);
  const Eigen::VectorXd unit_ellipsoid =
      p.shape == GrainShape::ellipsoid
          ? shape::sh_fit([&](const Eigen::Vector3d& d) {
              return 1.0 / std::sqrt(d.x() * d.x() / (ell_a * ell_a) + (d.y() * d.y() + d.z() * d.z()) / (ell_b * ell_b));
            }, degree, 2 * shape::sh_count(degree))
          : Eigen::VectorXd();
  // Angular grains are fitted on one direction set, so the pseudo-inverse is computed once.
  std::unique_ptr<const shape::ShFitter> fitter;
  if (p.shape == GrainShape::angular) {
    fitter = std::make_unique<const shape::ShFitter>(degree);
    set.sh_fit_rms.resize(n);
  }
  std::atomic<std::size_t> done{0};
  for_each_grain(n, [&](std::size_t i) {
    const double r = 0.5 * diameters[i];
    const int nodes = table_nodes(r / p.voxel_size);
    Eigen::VectorXd c;
    shape::RadialTable t;
    if (p.shape == GrainShape::sand) {
      std::mt19937_64 rng(p.seed * 0x9E3779B97F4A7C15ull + i);
      c = shape::random_sand_coeffs(p.sand, rng) * r;
      t = shape::radial_table_from_sh(c, degree, nodes);
    } else if (p.shape == GrainShape::angular) {
      std::mt19937_64 rng(p.seed * 0x9E3779B97F4A7C15ull + i);
      AngularGrain g = random_angular_grain(p.angular, rng, nodes, &t);
      g.scale(r);
      t = t.scaled(r);
      const auto& dirs = fitter->directions();
      Eigen::VectorXd radii(static_cast<Eigen::Index>(dirs.size()));
      for (std::size_t k = 0; k < dirs.size(); ++k) radii[static_cast<Eigen::Index>(k)] = g.radius(dirs[k]);
      c = fitter->fit(radii);
      const Eigen::VectorXd residual = fitter->design() * c - radii;
      set.sh_fit_rms[i] = std::sqrt(residual.squaredNorm() / static_cast<double>(residual.size())) / r;
    } else if (p.shape == GrainShape::ellipsoid) {
      t = shape::ellipsoid_table(r * ell_a, r * ell_b, r * ell_b, nodes);
      c = r * unit_ellipsoid;
    } else {
      c = shape::sphere_coeffs(r, degree);
      t = shape::RadialTable::from_function([r](const Eigen::Vector3d&) { return r; }, 8);
    }
    set.coeffs_body.row(static_cast<Eigen::Index>(i)) = c.transpose();
    set.stats[i] = shape::shape_stats(t);
    set.tables[i] = std::move(t);
    const std::size_t d = ++done;
    if (progress) {
#pragma omp critical(grain_progress)
      progress(static_cast<double>(d) / static_cast<double>(n));
    }
  });
  return set;
}

std::vector<shape::RadialTable> smoothed_tables(const GrainSet& set, int degree, double voxel_size) {
  if (degree < 0 || degree > set.sh_degree)
    throw UsageError("smoothed_tables: degree " + std::to_string(degree) + " is outside 0.." +
                     std::to_string(set.sh_degree) + ", the grains' SH degree");
  std::vector<shape::RadialTable> out(set.tables.size());
  const Eigen::Index kept = shape::sh_count(degree);
  for_each_grain(out.size(), [&](std::size_t i) {
    const Eigen::VectorXd c = set.coeffs_body.row(static_cast<Eigen::Index>(i)).head(kept).transpose();
    out[i] = shape::radial_table_from_sh(c, degree, table_nodes(0.5 * set.diameters[i] / voxel_size));
  });
  return out;
}

ShRotator::ShRotator(int degree) : degree_(degree), dirs_(shape::fibonacci_directions(2 * shape::sh_count(degree))) {
  const Eigen::MatrixXd a = shape::sh_design_matrix(degree, dirs_);
  pinv_ = a.colPivHouseholderQr().solve(Eigen::MatrixXd::Identity(a.rows(), a.rows()));
}

Eigen::VectorXd ShRotator::rotate(const Eigen::VectorXd& body, const Eigen::Matrix3d& body_to_world) const {
  Eigen::VectorXd r(static_cast<Eigen::Index>(dirs_.size()));
  const Eigen::Matrix3d world_to_body = body_to_world.transpose();
  for (std::size_t k = 0; k < dirs_.size(); ++k)
    r[static_cast<Eigen::Index>(k)] = shape::sh_radius(body, degree_, world_to_body * dirs_[k]);
  return pinv_ * r;
}

}  // namespace graintwin::synth
