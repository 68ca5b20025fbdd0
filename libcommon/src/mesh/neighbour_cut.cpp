#include "graintwin/mesh/neighbour_cut.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "graintwin/core/filters.hpp"
#include "graintwin/core/volume_sample.hpp"

namespace graintwin::mesh {
namespace {
/// Ray steps as a fraction of the voxel: finer than the field's smallest feature (one voxel).
constexpr double kStepPerVoxel = 0.25;
/// Bisection steps after a crossing: a quarter voxel to 1e-4 voxel.
constexpr int kBisections = 12;
/// Umbrella smoothing rounds after a vertex cut (cut_surface).
constexpr int kSmoothingRounds = 3;
/// Gaussian sigma (voxels) of the field whose slope leads a vertex out of a neighbour: wide enough
/// to slope two voxels deep, where the surfaces reach.
constexpr double kGuideSigma = 1.5;
}  // namespace

NeighbourCut::NeighbourCut(const Volume<std::uint32_t>& labels, std::uint32_t label, const std::array<std::size_t, 6>& bbox,
                           std::size_t pad_vox) {
  const Shape3& n = labels.shape();
  Shape3 shape;
  std::array<std::size_t, 3> lo;
  Vec3 origin;
  for (std::size_t a = 0; a < 3; ++a) {
    lo[a] = bbox[a] > pad_vox ? bbox[a] - pad_vox : 0;
    const std::size_t hi = std::min(n[a], bbox[a + 3] + pad_vox);
    shape[a] = hi > lo[a] ? hi - lo[a] : 0;
    origin[a] = labels.origin()[a] + static_cast<double>(lo[a]) * labels.voxel_size()[a];
  }
  field_ = Volume<float>(shape, labels.voxel_size(), origin, 0.0f);
  for (std::size_t z = 0; z < shape[0]; ++z)
    for (std::size_t y = 0; y < shape[1]; ++y)
      for (std::size_t x = 0; x < shape[2]; ++x) {
        const std::uint32_t v = labels(lo[0] + z, lo[1] + y, lo[2] + x);
        if (v == label) {
          field_(z, y, x) = 1.0f;
        } else if (v != 0) {
          field_(z, y, x) = -1.0f;
          any_ = true;
        }
      }
  if (any_) {
    guide_ = field_;
    gaussian_blur(guide_, kGuideSigma);
  }
}

double NeighbourCut::read(const Volume<float>& field, const Eigen::Vector3d& p) {
  const Vec3& o = field.origin();
  const Vec3& h = field.voxel_size();
  const double z = (p.z() - o[0]) / h[0], y = (p.y() - o[1]) / h[1], x = (p.x() - o[2]) / h[2];
  const Shape3& s = field.shape();
  if (!(z >= 0.0 && y >= 0.0 && x >= 0.0 && z <= double(s[0] - 1) && y <= double(s[1] - 1) && x <= double(s[2] - 1))) return 1.0;
  return trilinear(field, z, y, x);
}

double NeighbourCut::side(const Eigen::Vector3d& p) const { return read(field_, p); }

double NeighbourCut::radial_limit(const Eigen::Vector3d& c, const Eigen::Vector3d& d, double r) const {
  if (!any_ || !(side(c) > 0.0)) return r;
  const Vec3& h = field_.voxel_size();
  const double ds = kStepPerVoxel * std::min({h[0], h[1], h[2]});
  for (double t0 = 0.0; t0 < r;) {
    const double t1 = std::min(t0 + ds, r);
    if (side(c + t1 * d) < 0.0) {
      double in = t0, out = t1;  // the grain's side, a neighbour's
      for (int i = 0; i < kBisections; ++i) {
        const double mid = 0.5 * (in + out);
        (side(c + mid * d) < 0.0 ? out : in) = mid;
      }
      return in;
    }
    t0 = t1;
  }
  return r;
}

Eigen::Vector3d NeighbourCut::onto_own_side(const Eigen::Vector3d& p, double reach_vox) const {
  if (!any_ || side(p) >= 0.0) return p;
  const Vec3& h = field_.voxel_size();
  const double voxel = std::min({h[0], h[1], h[2]}), ds = kStepPerVoxel * voxel;
  // Central differences half a voxel either side.
  const auto uphill = [&](const Eigen::Vector3d& q) {
    Eigen::Vector3d g;
    for (int a = 0; a < 3; ++a) {
      Eigen::Vector3d e = Eigen::Vector3d::Zero();
      e[a] = 0.5 * voxel;
      g[a] = read(guide_, q + e) - read(guide_, q - e);
    }
    return g;
  };
  Eigen::Vector3d at = p;
  for (double walked = 0.0; walked < reach_vox * voxel; walked += ds) {
    const Eigen::Vector3d g = uphill(at);
    if (!(g.norm() > 0.0)) return p;  // deep inside the neighbour: no way out known
    const Eigen::Vector3d next = at + ds * g.normalized();
    if (side(next) >= 0.0) {
      Eigen::Vector3d in = next, out = at;  // the grain's side, the neighbour's
      for (int i = 0; i < kBisections; ++i) {
        const Eigen::Vector3d mid = 0.5 * (in + out);
        (side(mid) >= 0.0 ? in : out) = mid;
      }
      return in;
    }
    at = next;
  }
  return p;
}

std::size_t cut_surface(TriangleSurface& surface, const NeighbourCut& cut) {
  std::size_t count = 0;
  if (!cut.any()) return count;
  std::vector<char> moved(surface.vertices.size(), 0);
  for (std::size_t i = 0; i < surface.vertices.size(); ++i) {
    const Eigen::Vector3d w = cut.onto_own_side(surface.vertices[i]);
    if (w != surface.vertices[i]) surface.vertices[i] = w, moved[i] = 1, ++count;
  }
  if (count == 0) return count;
  // Gradient paths of nearby vertices can cross on the staircase field (a fold where the cut
  // surface meets the uncut): a few rounds of umbrella smoothing of the moved vertices, each put
  // back on the grain's side, untangle them.
  std::vector<std::vector<int>> ring(surface.vertices.size());
  for (const auto& t : surface.triangles)
    for (int k = 0; k < 3; ++k) {
      const int a = t[static_cast<std::size_t>(k)], b = t[static_cast<std::size_t>((k + 1) % 3)];
      if (moved[static_cast<std::size_t>(a)]) ring[static_cast<std::size_t>(a)].push_back(b);
      if (moved[static_cast<std::size_t>(b)]) ring[static_cast<std::size_t>(b)].push_back(a);
    }
  for (int round = 0; round < kSmoothingRounds; ++round) {
    std::vector<Eigen::Vector3d> next = surface.vertices;
    for (std::size_t i = 0; i < next.size(); ++i) {
      if (!moved[i] || ring[i].empty()) continue;
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (int j : ring[i]) mean += surface.vertices[static_cast<std::size_t>(j)];
      next[i] = cut.onto_own_side(mean / static_cast<double>(ring[i].size()));
    }
    surface.vertices = std::move(next);
  }
  return count;
}

void cut_radial_surface(TriangleSurface& surface, const Eigen::Vector3d& c, const NeighbourCut& cut) {
  if (!cut.any()) return;
  for (Eigen::Vector3d& v : surface.vertices) {
    const Eigen::Vector3d ray = v - c;
    const double r = ray.norm();
    if (r > 0.0) v = c + cut.radial_limit(c, ray / r, r) * (ray / r);
  }
}

}  // namespace graintwin::mesh
