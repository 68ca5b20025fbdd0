#include "graintwin/synth/grains.hpp"

#include <Eigen/QR>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <memory>
#include <numbers>
#include <numeric>
#include <random>

#include "graintwin/core/enum_names.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/geometry.hpp"
#include "graintwin/core/parallel.hpp"
#include "graintwin/shape/sh_basis.hpp"
#include "graintwin/shape/sh_fitter.hpp"

namespace graintwin::synth {

GrainShape parse_grain_shape(const std::string& name) {
  static constexpr std::array<EnumName<GrainShape>, 5> kNames{{{GrainShape::sphere, "sphere"},
                                                                {GrainShape::ellipsoid, "ellipsoid"},
                                                                {GrainShape::sand, "sand"},
                                                                {GrainShape::angular, "angular"},
                                                                {GrainShape::library, "library"}}};
  return parse_enum(kNames, name, "--grain-shape");
}

std::vector<const shape::RadialTable*> GrainSet::table_pointers() const {
  std::vector<const shape::RadialTable*> out;
  for (const auto& t : tables) out.push_back(&t);
  return out;
}

std::vector<const GrainSolid*> GrainSet::solid_pointers() const {
  std::vector<const GrainSolid*> out(tables.size(), nullptr);
  for (std::size_t i = 0; i < solids.size(); ++i) out[i] = solids[i].get();
  return out;
}

SolidGrainRecord solid_grain_record(const GrainSolid& solid, shape::RadialTable hull, const shape::ShFitter& fitter,
                                    double resolution) {
  SolidGrainRecord out;
  const double r_hull = equivalent_radius(hull.volume());
  out.stats = solid_stats(solid, std::min(r_hull / 30.0, 2.0 * resolution));
  const double r_eq = 0.5 * out.stats.equivalent_diameter;
  const double step = std::min(r_eq / 100.0, resolution);
  const auto& dirs = fitter.directions();
  Eigen::VectorXd radii(static_cast<Eigen::Index>(dirs.size()));
  for (std::size_t k = 0; k < dirs.size(); ++k) radii[static_cast<Eigen::Index>(k)] = ray_exits(solid, dirs[k], step).last;
  out.coeffs = fitter.fit(radii);
  const Eigen::VectorXd residual = fitter.design() * out.coeffs - radii;
  out.sh_fit_rms = std::sqrt(residual.squaredNorm() / static_cast<double>(residual.size())) / r_eq;
  out.non_star = non_star_measures(solid, out.stats.volume, step);
  out.table = std::move(hull);
  return out;
}

namespace {
// Nodes per cube-face edge so that the bilinear table deviates from the SH surface by at most
// about 0.02 voxel: the measured worst relative error of degree-15 grains is about 27 / n^2.
int table_nodes(double radius_vox) {
  return std::clamp(static_cast<int>(std::ceil(std::sqrt(27.0 * radius_vox / 0.02))), 32, 160);
}

}  // namespace

double grain_bytes(double diameter, double voxel_size, int degree) {
  const double stride = table_nodes(0.5 * diameter / voxel_size) + 2.0;  // nodes plus the ghost ring
  return sizeof(float) * 6.0 * stride * stride + sizeof(double) * shape::sh_count(degree) + sizeof(shape::RadialTable) +
         sizeof(shape::ShapeStats);
}

GrainSet make_grains(const GrainSetParams& p, const std::vector<double>& diameters,
                     const std::function<void(double)>& progress) {
  if (p.aspect_ratio < 1.0) throw UsageError("aspect-ratio must be at least 1");
  if (p.shape == GrainShape::angular) validate(p.angular);
  if (p.shape == GrainShape::library) throw UsageError("library grains are made by make_library_grains, not make_grains");
  if (!(p.non_star_share >= 0.0 && p.non_star_share <= 1.0))
    throw UsageError("the share of grains that are not star-shaped must be in [0, 1]");
  if (p.non_star_share > 0.0 && p.shape != GrainShape::angular)
    throw UsageError("only angular grains can be drawn not star-shaped (give --grain-shape angular)");
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
  // The grains drawn with a pocket: round(share n) of them, by a shuffle of their own stream, so
  // that the others are the same grains as without pockets.
  std::vector<bool> pocketed(n, false);
  if (p.non_star_share > 0.0) {
    std::vector<std::size_t> order(n);
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::mt19937_64 pick(p.seed * 0xD1B54A32D192ED03ull + 17);
    std::shuffle(order.begin(), order.end(), pick);
    const auto count = static_cast<std::size_t>(std::llround(p.non_star_share * static_cast<double>(n)));
    for (std::size_t k = 0; k < count; ++k) pocketed[order[k]] = true;
    set.solids.resize(n);
  }
  set.non_star.resize(n);
  set.tables_are_sh_surfaces = synth::tables_are_sh_surfaces(p.shape);
  std::atomic<std::size_t> done{0};
  auto report_done = [&] {
    const std::size_t d = ++done;
    if (progress) {
#pragma omp critical(grain_progress)
      progress(static_cast<double>(d) / static_cast<double>(n));
    }
  };
  parallel_for_each_index(n, [&](std::size_t i) {
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
      AngularGrain g = random_angular_grain(p.angular, rng, nodes, &t, pocketed[i]);
      g.scale(r);
      t = t.scaled(r);
      if (!g.pockets.empty()) {
        // The body without its pocket is the hull: convex around the pocket, it packs like the
        // star-shaped grains (a hull with a well down the pocket's mouth jams the packer).
        auto solid = std::make_shared<const PocketedGrain>(t, g.pockets);
        SolidGrainRecord record = solid_grain_record(*solid, std::move(t), *fitter, p.voxel_size / 4.0);
        set.coeffs_body.row(static_cast<Eigen::Index>(i)) = record.coeffs.transpose();
        set.sh_fit_rms[i] = record.sh_fit_rms;
        set.stats[i] = record.stats;
        set.non_star[i] = record.non_star;
        set.tables[i] = std::move(record.table);
        set.solids[i] = std::move(solid);
        report_done();
        return;
      }
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
    report_done();
  });
  return set;
}

std::vector<shape::RadialTable> smoothed_tables(const GrainSet& set, int degree, double voxel_size,
                                                const std::function<void(double)>& progress) {
  if (degree < 0 || degree > set.sh_degree)
    throw UsageError("smoothed_tables: degree " + std::to_string(degree) + " is outside 0.." +
                     std::to_string(set.sh_degree) + ", the grains' SH degree");
  const std::size_t n = set.diameters.size();  // the set's tables may be freed meanwhile
  std::vector<shape::RadialTable> out(n);
  const Eigen::Index kept = shape::sh_count(degree);
  std::atomic<std::size_t> done{0};
  parallel_for_each_index(n, [&](std::size_t i) {
    const Eigen::VectorXd c = set.coeffs_body.row(static_cast<Eigen::Index>(i)).head(kept).transpose();
    out[i] = shape::radial_table_from_sh(c, degree, table_nodes(0.5 * set.diameters[i] / voxel_size));
    const std::size_t d = ++done;
    if (progress) {
#pragma omp critical(smoothing_progress)
      progress(static_cast<double>(d) / static_cast<double>(n));
    }
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
