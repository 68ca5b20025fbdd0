// Partial-volume rendering of grains and membrane, and the scanner model of synthetic CT scans.
#include "graintwin/synth/render.hpp"

#include <algorithm>
#include <cmath>

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

// Smallest cos(angle) between the surface normal and the radial direction over a grain: the
// radial distance to the surface overestimates the true distance by at most 1 / that factor.
double min_normal_cosine(const shape::RadialTable& t) {
  double c = 1.0;
  const int n = 4000;
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / n, r = std::sqrt(1.0 - z * z), phi = golden * i;
    const Eigen::Vector3d d(r * std::cos(phi), r * std::sin(phi), z);
    c = std::min(c, t.surface_normal(d).dot(d));
  }
  return std::max(c, 0.1);
}

struct GrainPrep {
  Eigen::Matrix3d world_to_body;
  Eigen::Vector3d position;
  std::vector<Eigen::Vector3d> body_offsets;  // sub-sample offsets in the body frame
  double threshold = 0.0;                     // |radial distance| beyond which a voxel is whole
  long z0 = 0, z1 = -1, y0 = 0, y1 = -1, x0 = 0, x1 = -1;
};

long clamp_index(double v, std::size_t n) {
  return std::clamp(static_cast<long>(std::floor(v)), 0L, static_cast<long>(n) - 1);
}

}  // namespace

GrainImages render_grains(const std::vector<PlacedGrain>& grains, const Shape3& shape, const Vec3& voxel_size,
                          const Vec3& origin, const RenderParams& params, const std::function<void(double)>& progress) {
  if (params.supersample < 1 || params.supersample > 16)
    throw UsageError("supersampling must be between 1 and 16 samples per voxel edge (got " +
                     std::to_string(params.supersample) + ")");
  GrainImages out{Volume<float>(shape, voxel_size, origin), Volume<std::uint32_t>(shape, voxel_size, origin)};
  const double half_diagonal =
      0.5 * std::sqrt(voxel_size[0] * voxel_size[0] + voxel_size[1] * voxel_size[1] + voxel_size[2] * voxel_size[2]);
  const auto offsets = subsample_offsets(params.supersample, voxel_size);

  std::vector<GrainPrep> prep(grains.size());
#pragma omp parallel for schedule(dynamic)
  for (std::size_t g = 0; g < grains.size(); ++g) {
    const PlacedGrain& pg = grains[g];
    GrainPrep& p = prep[g];
    p.world_to_body = pg.orientation.normalized().toRotationMatrix().transpose();
    p.position = pg.position;
    p.body_offsets.reserve(offsets.size());
    for (const auto& o : offsets) p.body_offsets.push_back(p.world_to_body * o);
    p.threshold = half_diagonal / min_normal_cosine(*pg.shape);
    const double rmax = pg.shape->max_radius() + half_diagonal;
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
        for (long y = p.y0; y <= p.y1; ++y) {
          const double wy = origin[1] + static_cast<double>(y) * voxel_size[1];
          for (long x = p.x0; x <= p.x1; ++x) {
            const Eigen::Vector3d q = p.world_to_body *
                                      (Eigen::Vector3d(origin[2] + static_cast<double>(x) * voxel_size[2], wy, wz) - p.position);
            const double dist = q.norm();
            const double s = dist > 0.0 ? t.radius(q) - dist : t.radius(Eigen::Vector3d::UnitZ());
            if (s < -p.threshold) continue;
            const std::size_t i = out.fraction.index(z, static_cast<std::size_t>(y), static_cast<std::size_t>(x));
            double f = 1.0;
            if (s < p.threshold) {
              int inside = 0;
              for (const auto& o : p.body_offsets) {
                const Eigen::Vector3d qs = q + o;
                const double r = t.radius(qs);
                inside += qs.squaredNorm() <= r * r;
              }
              f = inside * inv_samples;
            }
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
                           int supersample) {
  Volume<float> out(shape, voxel_size, origin);
  const auto offsets = subsample_offsets(supersample, voxel_size);
  const double h = 0.5 * std::sqrt(voxel_size[0] * voxel_size[0] + voxel_size[1] * voxel_size[1] +
                                   voxel_size[2] * voxel_size[2]);
  auto inside = [&](double x, double y, double z) {
    if (z < shell.z0 || z > shell.z1) return false;
    const double rho = std::hypot(x - shell.centre_x, y - shell.centre_y);
    const double r_in = shell.inner_radius(z);
    return rho >= r_in && rho <= r_in + shell.thickness;
  };
#pragma omp parallel for schedule(dynamic)
  for (std::size_t z = 0; z < shape[0]; ++z) {
    const double wz = origin[0] + static_cast<double>(z) * voxel_size[0];
    if (wz < shell.z0 - h || wz > shell.z1 + h) continue;
    const double r_in = shell.inner_radius(std::clamp(wz, shell.z0, shell.z1));
    for (std::size_t y = 0; y < shape[1]; ++y) {
      const double wy = origin[1] + static_cast<double>(y) * voxel_size[1];
      for (std::size_t x = 0; x < shape[2]; ++x) {
        const double wx = origin[2] + static_cast<double>(x) * voxel_size[2];
        const double rho = std::hypot(wx - shell.centre_x, wy - shell.centre_y);
        const double in_depth = std::min(rho - r_in, r_in + shell.thickness - rho);
        if (in_depth < -2.0 * h) continue;
        const bool whole_z = wz > shell.z0 + h && wz < shell.z1 - h;
        if (in_depth > 2.0 * h && whole_z) {  // 2h: r_in(z) may vary across the voxel
          out(z, y, x) = 1.0f;
          continue;
        }
        int n = 0;
        for (const auto& o : offsets) n += inside(wx + o.x(), wy + o.y(), wz + o.z());
        out(z, y, x) = static_cast<float>(n) / static_cast<float>(offsets.size());
      }
    }
  }
  return out;
}

Volume<std::uint16_t> simulate_scan(const Volume<float>& grain_fraction, const Volume<float>* membrane_fraction,
                                    const ScannerParams& p) {
  const Shape3 s = grain_fraction.shape();
  if (membrane_fraction && membrane_fraction->shape() != s)
    throw DataError("membrane and grain images differ in shape");
  if (p.noise < 0.0 || p.photons < 0.0 || p.blur_sigma_vox < 0.0)
    throw UsageError("noise, photons and blur must not be negative");
  const double contrast = p.grey_grain - p.grey_void;
  Volume<float> grey(s, grain_fraction.voxel_size(), grain_fraction.origin());
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
