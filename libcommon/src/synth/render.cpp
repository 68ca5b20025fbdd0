// Partial-volume rendering of grains and membrane, and the scanner model of synthetic CT scans.
#include "graintwin/synth/render.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <string>
#include <vector>

#include "graintwin/core/error.hpp"
#include "graintwin/core/filters.hpp"

namespace graintwin::synth {

namespace {

// Per-voxel random numbers from a counter-based generator (splitmix64), so the noise of a voxel
// depends only on the seed and the voxel index, never on the thread schedule.
class VoxelRng {
 public:
  VoxelRng(std::uint64_t seed, std::uint64_t index) : state_(seed * 0x9E3779B97F4A7C15ull ^ (index + 0x632BE59BD9B4E019ull)) {
    next();
  }
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double uniform() { return (static_cast<double>(next() >> 11) + 0.5) * (1.0 / 9007199254740992.0); }
  double normal() {
    const double u1 = uniform(), u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
  }
  double poisson(double lambda) {
    if (lambda <= 0.0) return 0.0;
    if (lambda > 64.0) return std::max(0.0, std::round(lambda + std::sqrt(lambda) * normal()));
    const double limit = std::exp(-lambda);
    double p = uniform();
    int k = 0;
    while (p > limit) {
      p *= uniform();
      ++k;
    }
    return k;
  }

 private:
  std::uint64_t state_;
};

// Offsets of the k^3 sub-sample centres of a voxel, relative to its centre (m, x y z).
std::vector<Eigen::Vector3d> subsample_offsets(int k, const Vec3& voxel_size) {
  std::vector<Eigen::Vector3d> off;
  off.reserve(static_cast<std::size_t>(k) * k * k);
  for (int a = 0; a < k; ++a)
    for (int b = 0; b < k; ++b)
      for (int c = 0; c < k; ++c)
        off.emplace_back(((c + 0.5) / k - 0.5) * voxel_size[2], ((b + 0.5) / k - 0.5) * voxel_size[1],
                         ((a + 0.5) / k - 0.5) * voxel_size[0]);
  return off;
}

// Body-frame offsets that drive the analytic partial volume of one grain's voxels: the voxel's
// 2 x 2 x 2 Gauss points (at +-edge / (2 sqrt 3) from the centre) and the centres of its 8 halves
// (+-edge / 4); world edge lengths; the spread of secant offsets that triggers a split.
struct SecantFrame {
  Eigen::Matrix3d body_to_world;
  Eigen::Vector3d gauss[8], half[8];
  Eigen::Vector3d edges;
  double split_spread = 0.0;
  double margin = 0.0;  // beyond its half extent plus this, a voxel is whole by its tangent plane
};

// Unit direction of body-frame point p (+z for p = 0).
Eigen::Vector3d direction_of(const Eigen::Vector3d& p) {
  const double len = p.norm();
  return len > 0.0 ? Eigen::Vector3d(p / len) : Eigen::Vector3d::UnitZ();
}

// Analytic partial volume of the voxel (or, at scale 0.5, the half-voxel) centred at body-frame
// point q, given the table's normal there: the fraction below the secant plane (RenderParams).
// The plane's offset is the mean of the offsets through the 8 Gauss points' surface points; for
// a quadratic surface that averages the sagitta the way the voxel's volume integral does, which a
// tangent plane (one point) would miss by ~ curvature x voxel^2. A spread of those offsets
// beyond frame.split_spread means the surface bends within the voxel: the halves are done
// separately (once).
double secant_fraction(const shape::RadialTable& t, const Eigen::Vector3d& q, const Eigen::Vector3d& normal,
                       const SecantFrame& frame, double scale, bool may_split) {
  double sum = 0.0, lo = HUGE_VAL, hi = -HUGE_VAL;
  for (const Eigen::Vector3d& g : frame.gauss) {
    const Eigen::Vector3d d = direction_of(q + scale * g);
    const double a = normal.dot(t.radius(d) * d - q);
    sum += a;
    lo = std::min(lo, a);
    hi = std::max(hi, a);
  }
  if (may_split && hi - lo > scale * frame.split_spread) {
    double f = 0.0;
    for (const Eigen::Vector3d& c : frame.half) {
      const Eigen::Vector3d qc = q + scale * c;
      f += secant_fraction(t, qc, t.surface_normal(direction_of(qc)), frame, 0.5 * scale, false);
    }
    return 0.125 * f;
  }
  return box_fraction_below_plane(frame.body_to_world * normal, 0.125 * sum, scale * frame.edges);
}

struct GrainPrep {
  Eigen::Matrix3d world_to_body;
  Eigen::Vector3d position;
  std::vector<Eigen::Vector3d> body_offsets;  // point-sample offsets in the body frame (supersample > 0 or a solid)
  SecantFrame secant;                         // analytic partial volume (supersample 0)
  double threshold = 0.0;                     // |radial distance| beyond which a voxel is whole
  double reach = 0.0;                         // voxel centres farther from the grain centre are empty
  double core = 0.0;                          // voxel centres nearer to it are whole
  long z0 = 0, z1 = -1, y0 = 0, y1 = -1, x0 = 0, x1 = -1;
};

long clamp_index(double v, std::size_t n) {
  return std::clamp(static_cast<long>(std::floor(v)), 0L, static_cast<long>(n) - 1);
}

}  // namespace

double box_fraction_below_plane(const Eigen::Vector3d& normal, double offset, const Eigen::Vector3d& edges) {
  // Box coordinates xi in [0, 1]^3 (x = (xi - 1/2) e, an axis flipped where n_i < 0): the region
  // is m . xi <= alpha with m_i = |n_i| e_i >= 0 and alpha = offset + sum(m) / 2.
  double m1 = std::abs(normal.x()) * edges.x(), m2 = std::abs(normal.y()) * edges.y(),
         m3 = std::abs(normal.z()) * edges.z();
  const double sum = m1 + m2 + m3;
  const double alpha = offset + 0.5 * sum;
  if (alpha <= 0.0) return 0.0;
  if (alpha >= sum) return 1.0;
  m1 /= sum;
  m2 /= sum;
  m3 /= sum;
  if (m1 > m2) std::swap(m1, m2);
  if (m2 > m3) std::swap(m2, m3);
  if (m1 > m2) std::swap(m1, m2);
  // V(a) = [a^3 - sum_i (a - m_i)_+^3 + sum_i<j (a - m_i - m_j)_+^3 - ...] / (6 m1 m2 m3) for the
  // normalised a <= 1/2 (V(a) = 1 - V(1 - a)), written per range of a so that nothing is divided
  // by a vanishing m1 (in the last two ranges a - m2 and a - m3 are below m1, so their cubes over
  // m1 stay small).
  const double a_in = alpha / sum;
  const bool flip = a_in > 0.5;
  const double a = flip ? 1.0 - a_in : a_in;
  double v;
  if (a < m1) {
    v = a * a * a / (6.0 * m1 * m2 * m3);
  } else if (a < m2) {
    v = (3.0 * a * (a - m1) + m1 * m1) / (6.0 * m2 * m3);
  } else if (a < std::min(m1 + m2, m3)) {
    const double c2 = a - m2;
    v = (3.0 * a * a - 3.0 * a * m1 + m1 * m1 - c2 * c2 * c2 / m1) / (6.0 * m2 * m3);
  } else if (m1 + m2 < m3) {
    v = (a - 0.5 * (m1 + m2)) / m3;  // the plane crosses the box's four long edges
  } else if (m1 > 0.0) {
    const double c2 = a - m2, c3 = a - m3;
    v = (3.0 * a * a - 3.0 * a * m1 + m1 * m1 - (c2 * c2 * c2 + c3 * c3 * c3) / m1) / (6.0 * m2 * m3);
  } else {
    v = 0.5;  // m1 = 0 and m2 = m3 = a = 1/2: the plane halves the box
  }
  v = std::clamp(v, 0.0, 1.0);
  return flip ? 1.0 - v : v;
}

GrainImages render_grains(const std::vector<PlacedGrain>& grains, const Shape3& shape, const Vec3& voxel_size,
                          const Vec3& origin, const RenderParams& params, const std::function<void(double)>& progress) {
  if (params.supersample < 0 || params.supersample > 16)
    throw UsageError("supersample must be 0 (analytic partial volumes) or 1 to 16 samples per voxel edge (got " +
                     std::to_string(params.supersample) + ")");
  GrainImages out{Volume<float>(shape, voxel_size, origin), Volume<std::uint32_t>(shape, voxel_size, origin)};
  const double half_diagonal =
      0.5 * std::sqrt(voxel_size[0] * voxel_size[0] + voxel_size[1] * voxel_size[1] + voxel_size[2] * voxel_size[2]);
  const bool analytic = params.supersample == 0;
  // Solids are point-sampled even in analytic mode: a pocket's rim has no single secant plane.
  const auto offsets = subsample_offsets(analytic ? 4 : params.supersample, voxel_size);
  const Eigen::Vector3d edges(voxel_size[2], voxel_size[1], voxel_size[0]);
  const double gauss = 0.5 / std::sqrt(3.0);

  std::vector<GrainPrep> prep(grains.size());
#pragma omp parallel for schedule(dynamic)
  for (std::size_t g = 0; g < grains.size(); ++g) {
    const PlacedGrain& pg = grains[g];
    GrainPrep& p = prep[g];
    p.world_to_body = pg.orientation.normalized().toRotationMatrix().transpose();
    p.position = pg.position;
    if (!analytic || pg.solid) {
      p.body_offsets.reserve(offsets.size());
      for (const auto& o : offsets) p.body_offsets.push_back(p.world_to_body * o);
    }
    if (analytic) {
      SecantFrame& f = p.secant;
      f.body_to_world = p.world_to_body.transpose();
      f.edges = edges;
      f.split_spread = 0.1 * std::cbrt(edges.prod());
      f.margin = 0.25 * std::cbrt(edges.prod());
      for (int k = 0; k < 8; ++k) {
        const Eigen::Vector3d sign(k & 1 ? 1.0 : -1.0, k & 2 ? 1.0 : -1.0, k & 4 ? 1.0 : -1.0);
        f.gauss[k] = p.world_to_body * (gauss * sign.cwiseProduct(edges));
        f.half[k] = p.world_to_body * (0.25 * sign.cwiseProduct(edges));
      }
    }
    // The radial distance to the surface overestimates the true distance by at most 1 / the
    // smallest normal cosine (floored, for safety, at a slope of 84 degrees).
    p.threshold = half_diagonal / std::max(pg.shape->min_normal_cosine(), 0.1);
    p.reach = pg.shape->max_radius() + half_diagonal;
    p.core = pg.shape->min_radius() - half_diagonal;
    const double rmax = p.reach;
    // Index range of voxel centres within rmax of the grain centre.
    p.x0 = clamp_index((pg.position.x() - rmax - origin[2]) / voxel_size[2], shape[2]);
    p.x1 = clamp_index((pg.position.x() + rmax - origin[2]) / voxel_size[2] + 1.0, shape[2]);
    p.y0 = clamp_index((pg.position.y() - rmax - origin[1]) / voxel_size[1], shape[1]);
    p.y1 = clamp_index((pg.position.y() + rmax - origin[1]) / voxel_size[1] + 1.0, shape[1]);
    p.z0 = clamp_index((pg.position.z() - rmax - origin[0]) / voxel_size[0], shape[0]);
    p.z1 = clamp_index((pg.position.z() + rmax - origin[0]) / voxel_size[0] + 1.0, shape[0]);
  }
  // Grains per z slice: slices are rendered in parallel, each by one thread, in grain order.
  std::vector<std::vector<std::uint32_t>> per_slice(shape[0]);
  for (std::size_t g = 0; g < grains.size(); ++g)
    for (long z = prep[g].z0; z <= prep[g].z1; ++z) per_slice[z].push_back(static_cast<std::uint32_t>(g));

  const double inv_samples = 1.0 / static_cast<double>(offsets.size());
  std::size_t slices_done = 0;
#pragma omp parallel
  {
    std::vector<float> depth(shape[1] * shape[2]);  // how deep the centre is in its labelled grain
#pragma omp for schedule(dynamic)
    for (std::size_t z = 0; z < shape[0]; ++z) {
      std::fill(depth.begin(), depth.end(), 0.0f);
      for (std::uint32_t g : per_slice[z]) {
        const GrainPrep& p = prep[g];
        const shape::RadialTable& t = *grains[g].shape;
        const double wz = origin[0] + static_cast<double>(z) * voxel_size[0];
        const double dz = wz - p.position.z();
        for (long y = p.y0; y <= p.y1; ++y) {
          const double wy = origin[1] + static_cast<double>(y) * voxel_size[1];
          // Only the row's voxel centres within reach of the grain centre.
          const double dy = wy - p.position.y();
          const double across2 = p.reach * p.reach - dy * dy - dz * dz;
          if (across2 < 0.0) continue;
          const double across = std::sqrt(across2);
          const long xa = std::max(p.x0, static_cast<long>(std::ceil((p.position.x() - across - origin[2]) / voxel_size[2])));
          const long xb = std::min(p.x1, static_cast<long>(std::floor((p.position.x() + across - origin[2]) / voxel_size[2])));
          for (long x = xa; x <= xb; ++x) {
            const Eigen::Vector3d q = p.world_to_body *
                                      (Eigen::Vector3d(origin[2] + static_cast<double>(x) * voxel_size[2], wy, wz) - p.position);
            const double dist = q.norm();
            double s, f = 1.0;  // s: radial depth of the centre inside the grain
            const GrainSolid* solid = grains[g].solid;
            if (solid && solid->may_differ_from_hull(q, half_diagonal)) {
              s = dist > 0.0 ? t.radius(q) - dist : t.radius(Eigen::Vector3d::UnitZ());
              if (s < -p.threshold) continue;
              int inside = 0;
              for (const auto& o : p.body_offsets) inside += solid->contains(q + o);
              f = inside * inv_samples;
              // The hull's depth ranks the voxel against other grains, where the solid holds its centre.
              s = solid->contains(q) ? std::max(s, 1e-12) : -1.0;
            } else if (dist < p.core) {
              s = t.min_radius() - dist;  // a lower bound, enough to rank it against other grains
            } else {
              s = dist > 0.0 ? t.radius(q) - dist : t.radius(Eigen::Vector3d::UnitZ());
              if (s < -p.threshold) continue;
              if (s < p.threshold && analytic) {
                // The tangent plane settles most of the voxels the radial test leaves open (its
                // bound holds for the steepest spot of the grain, not for this one); the margin
                // covers the surface's bending away from that plane within the voxel.
                const Eigen::Vector3d d = direction_of(q);
                const Eigen::Vector3d normal = t.surface_normal(d);
                const double tangent_offset = s * normal.dot(d);
                const double extent = 0.5 * (p.secant.body_to_world * normal).cwiseAbs().dot(edges) + p.secant.margin;
                if (tangent_offset < -extent) continue;
                if (tangent_offset <= extent) f = secant_fraction(t, q, normal, p.secant, 1.0, true);
              } else if (s < p.threshold) {
                int inside = 0;
                for (const auto& o : p.body_offsets) {
                  const Eigen::Vector3d qs = q + o;
                  const double r = t.radius(qs);
                  inside += qs.squaredNorm() <= r * r;
                }
                f = inside * inv_samples;
              }
            }
            const std::size_t i = out.fraction.index(z, static_cast<std::size_t>(y), static_cast<std::size_t>(x));
            out.fraction.values()[i] += static_cast<float>(f);
            const std::size_t j = static_cast<std::size_t>(y) * shape[2] + static_cast<std::size_t>(x);
            if (s > 0.0 && s > depth[j]) {
              depth[j] = static_cast<float>(s);
              out.labels.values()[i] = grains[g].label;
            }
          }
        }
      }
      float* row = &out.fraction(z, 0, 0);
      for (std::size_t j = 0; j < shape[1] * shape[2]; ++j) row[j] = std::min(row[j], 1.0f);  // tolerance overlaps
      if (progress) {
#pragma omp atomic
        ++slices_done;
#pragma omp critical(render_progress)
        progress(static_cast<double>(slices_done) / static_cast<double>(shape[0]));
      }
    }
  }
  return out;
}

Volume<float> render_shell(const Shell& shell, const Shape3& shape, const Vec3& voxel_size, const Vec3& origin,
                           const RenderParams& params, const std::function<void(double)>& progress) {
  Volume<float> out(shape, voxel_size, origin);
  const auto offsets = subsample_offsets(params.supersample > 0 ? params.supersample : 4, voxel_size);
  const double h = 0.5 * std::sqrt(voxel_size[0] * voxel_size[0] + voxel_size[1] * voxel_size[1] +
                                   voxel_size[2] * voxel_size[2]);
  auto inside = [&](double x, double y, double z) {
    if (z < shell.z0 || z > shell.z1) return false;
    const double rho = std::hypot(x - shell.centre_x, y - shell.centre_y);
    const double r_in = shell.inner_radius(std::atan2(y - shell.centre_y, x - shell.centre_x), z);
    return rho >= r_in && rho <= r_in + shell.thickness;
  };
  std::atomic<std::size_t> slices_done{0};
#pragma omp parallel for schedule(dynamic)
  for (std::size_t z = 0; z < shape[0]; ++z) {
    const double wz = origin[0] + static_cast<double>(z) * voxel_size[0];
    if (wz >= shell.z0 - h && wz <= shell.z1 + h) {
      for (std::size_t y = 0; y < shape[1]; ++y) {
        const double wy = origin[1] + static_cast<double>(y) * voxel_size[1];
        for (std::size_t x = 0; x < shape[2]; ++x) {
          const double wx = origin[2] + static_cast<double>(x) * voxel_size[2];
          const double rho = std::hypot(wx - shell.centre_x, wy - shell.centre_y);
          const double r_in = shell.inner_radius(std::atan2(wy - shell.centre_y, wx - shell.centre_x),
                                                 std::clamp(wz, shell.z0, shell.z1));
          const double in_depth = std::min(rho - r_in, r_in + shell.thickness - rho);
          if (in_depth < -2.0 * h) continue;
          const bool whole_z = wz > shell.z0 + h && wz < shell.z1 - h;
          if (in_depth > 2.0 * h && whole_z) {  // 2h: r_in may vary across the voxel
            out(z, y, x) = 1.0f;
            continue;
          }
          int n = 0;
          for (const auto& o : offsets) n += inside(wx + o.x(), wy + o.y(), wz + o.z());
          out(z, y, x) = static_cast<float>(n) / static_cast<float>(offsets.size());
        }
      }
    }
    const std::size_t done = ++slices_done;
    if (progress) {
#pragma omp critical(shell_progress)
      progress(static_cast<double>(done) / static_cast<double>(shape[0]));
    }
  }
  return out;
}

void check_grey_levels(const ScannerParams& p, bool with_membrane) {
  if (!(p.grey_grain > p.grey_void))
    throw UsageError(fmt::format("--grey-grain {:g} is not above --grey-void {:g}, so grains would not be brighter than "
                                 "the pores; give a grain grey level above the void's",
                                 p.grey_grain, p.grey_void));
  const double steps = (p.grey_grain - p.grey_void) * p.uint16_scale;
  if (!(steps >= 1.0))
    throw UsageError(fmt::format("--grey-scale {:g} maps the grain-void contrast {:g} to {:.3g} uint16 steps, so grains "
                                 "and pores would get the same value; give --grey-scale of at least {:.3g}",
                                 p.uint16_scale, p.grey_grain - p.grey_void, steps, 1.0 / (p.grey_grain - p.grey_void)));
  struct Level {
    const char* option;
    double grey;
  };
  std::vector<Level> levels{{"--grey-void", p.grey_void}, {"--grey-grain", p.grey_grain}};
  if (with_membrane) levels.push_back({"--grey-membrane", p.grey_membrane});
  for (const Level& l : levels) {
    const double value = l.grey * p.uint16_scale + p.uint16_offset;
    if (value >= 0.0 && value <= 65535.0) continue;
    double top = 0.0, bottom = 0.0;
    for (const Level& m : levels) top = std::max(top, m.grey), bottom = std::min(bottom, m.grey);
    const std::string fix = value > 65535.0 ? fmt::format("give --grey-scale of at most {:.6g} or lower --grey-offset",
                                                          std::floor((65535.0 - p.uint16_offset) / top))
                                            : fmt::format("raise --grey-offset to at least {:.6g}", std::ceil(-bottom * p.uint16_scale));
    throw UsageError(fmt::format("--grey-scale {:g} and --grey-offset {:g} put {} {:g} at uint16 value {:.4g}, outside "
                                 "0..65535, so every such voxel would saturate; {}",
                                 p.uint16_scale, p.uint16_offset, l.option, l.grey, value, fix));
  }
}

Volume<std::uint16_t> simulate_scan(Volume<float> grain_fraction, const Volume<float>* membrane_fraction,
                                    const ScannerParams& p) {
  const Shape3 s = grain_fraction.shape();
  if (membrane_fraction && membrane_fraction->shape() != s)
    throw DataError("membrane and grain images differ in shape");
  for (const double v : {p.noise, p.photons, p.blur_sigma_vox, p.ring_amplitude, p.beam_hardening})
    if (!(v >= 0.0 && std::isfinite(v)))
      throw UsageError("noise, photons, blur, rings and beam hardening must be finite and not negative");
  const double contrast = p.grey_grain - p.grey_void;
  // The grey image takes the fraction's place voxel by voxel: a scan holds one float image, not two.
  Volume<float>& grey = grain_fraction;
  // Ring artifacts: a few thin concentric rings about the rotation axis with random radii and signs.
  std::vector<std::pair<double, double>> rings;  // (radius m, signed amplitude)
  if (p.ring_amplitude > 0.0) {
    VoxelRng rng(p.seed, 0xABCDEFull);
    for (int i = 0; i < 8; ++i)
      rings.emplace_back(rng.uniform() * p.field_radius, (rng.uniform() < 0.5 ? -1.0 : 1.0) * p.ring_amplitude * contrast);
  }
  const double ring_width = grain_fraction.voxel_size()[2] * 0.7;
#pragma omp parallel for schedule(static)
  for (std::size_t z = 0; z < s[0]; ++z)
    for (std::size_t y = 0; y < s[1]; ++y)
      for (std::size_t x = 0; x < s[2]; ++x) {
        const std::size_t i = grain_fraction.index(z, y, x);
        const double fg = grain_fraction.values()[i];
        const double fm = membrane_fraction ? std::min(1.0 - fg, static_cast<double>(membrane_fraction->values()[i])) : 0.0;
        double g = p.grey_void + contrast * fg + (p.grey_membrane - p.grey_void) * fm;
        if (p.beam_hardening > 0.0 || !rings.empty()) {
          const Vec3 pos = grain_fraction.position_xyz(z, y, x);
          const double rho = std::hypot(pos[0] - p.axis_x, pos[1] - p.axis_y);
          if (p.beam_hardening > 0.0 && rho < p.field_radius)
            g = p.grey_void + (g - p.grey_void) * (1.0 - p.beam_hardening * (1.0 - (rho * rho) / (p.field_radius * p.field_radius)));
          for (const auto& [rr, amp] : rings) g += amp * std::exp(-0.5 * std::pow((rho - rr) / ring_width, 2.0));
        }
        grey.values()[i] = static_cast<float>(g);
      }
  gaussian_blur(grey, p.blur_sigma_vox);
  Volume<std::uint16_t> out(s, grain_fraction.voxel_size(), grain_fraction.origin());
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < grey.size(); ++i) {
    VoxelRng rng(p.seed, i);
    double g = grey.values()[i];
    if (p.photons > 0.0) g = rng.poisson(p.photons * std::max(g, 0.0) / p.grey_grain) * p.grey_grain / p.photons;
    if (p.noise > 0.0) g += p.noise * contrast * rng.normal();
    out.values()[i] = static_cast<std::uint16_t>(std::clamp(std::round(g * p.uint16_scale + p.uint16_offset), 0.0, 65535.0));
  }
  return out;
}

}  // namespace graintwin::synth
