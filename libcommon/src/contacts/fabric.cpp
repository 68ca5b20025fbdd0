#include "graintwin/contacts/fabric.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "graintwin/core/error.hpp"

namespace graintwin::contacts {

double anisotropy(const Eigen::Matrix3d& phi) {
  return 15.0 * (phi(0, 0) + phi(1, 1) - 2.0 * phi(2, 2)) /
         (-8.0 + 5.0 * phi(0, 0) + 5.0 * phi(1, 1) - 10.0 * phi(2, 2));
}

Fabric fabric_tensor(const std::vector<Vec3>& directions) {
  Fabric f;
  for (const Vec3& v : directions) {
    const Eigen::Vector3d d(v[0], v[1], v[2]);
    const double n2 = d.squaredNorm();
    if (!(n2 > 0.0) || !std::isfinite(n2)) continue;
    f.tensor += d * d.transpose() / n2;
    ++f.count;
  }
  if (f.count == 0) return f;
  f.tensor /= static_cast<double>(f.count);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(f.tensor);
  for (int k = 0; k < 3; ++k) {  // Eigen sorts ascending; phi_1 is the largest
    f.principal_values[k] = eig.eigenvalues()[2 - k];
    Eigen::Vector3d dir = eig.eigenvectors().col(2 - k);
    if (dir.z() < 0.0) dir = -dir;
    f.principal_directions.col(k) = dir;
  }
  f.anisotropy = anisotropy(f.tensor);
  return f;
}

Rose rose(const std::vector<Vec3>& directions, int theta_bins, int phi_bins) {
  if (theta_bins < 1 || phi_bins < 1)
    throw UsageError("rose diagrams need at least one bin in theta and in phi, got " + std::to_string(theta_bins) +
                     " x " + std::to_string(phi_bins));
  Rose r;
  const auto nt = static_cast<std::size_t>(theta_bins), np = static_cast<std::size_t>(phi_bins);
  for (std::size_t i = 0; i <= nt; ++i) r.theta_edges.push_back(std::numbers::pi / 2.0 * static_cast<double>(i) / static_cast<double>(nt));
  for (std::size_t j = 0; j <= np; ++j) r.phi_edges.push_back(2.0 * std::numbers::pi * static_cast<double>(j) / static_cast<double>(np));
  r.counts.assign(nt * np, 0);
  std::size_t total = 0;
  for (const Vec3& v : directions) {
    double x = v[0], y = v[1], z = v[2];
    const double len = std::sqrt(x * x + y * y + z * z);
    if (!(len > 0.0) || !std::isfinite(len)) continue;
    if (z < 0.0) x = -x, y = -y, z = -z;
    const double theta = std::acos(std::min(1.0, z / len));
    double phi = x == 0.0 && y == 0.0 ? 0.0 : std::atan2(y, x);  // along z the azimuth is undefined: bin 0
    if (phi < 0.0) phi += 2.0 * std::numbers::pi;
    const auto i = std::min(nt - 1, static_cast<std::size_t>(theta / (std::numbers::pi / 2.0) * static_cast<double>(nt)));
    const auto j = std::min(np - 1, static_cast<std::size_t>(phi / (2.0 * std::numbers::pi) * static_cast<double>(np)));
    ++r.counts[i * np + j];
    ++total;
  }
  r.density.assign(nt * np, 0.0);
  if (total == 0) return r;
  for (std::size_t i = 0; i < nt; ++i)
    for (std::size_t j = 0; j < np; ++j) {
      const double solid = (std::cos(r.theta_edges[i]) - std::cos(r.theta_edges[i + 1])) * (r.phi_edges[j + 1] - r.phi_edges[j]);
      r.density[i * np + j] = static_cast<double>(r.counts[i * np + j]) / (2.0 * static_cast<double>(total) * solid);
    }
  return r;
}

Coordination coordination(const std::vector<segment::GrainRecord>& grains, const std::vector<Contact>& contacts,
                          bool include_edge_grains) {
  Coordination c;
  c.per_grain.assign(grains.size(), 0);
  const auto row_of = [&](std::uint32_t label) {
    const auto it = std::lower_bound(grains.begin(), grains.end(), label,
                                     [](const segment::GrainRecord& g, std::uint32_t l) { return g.label < l; });
    if (it == grains.end() || it->label != label)
      throw DataError("label " + std::to_string(label) + " has a contact but no row in the grain table");
    return static_cast<std::size_t>(it - grains.begin());
  };
  for (const Contact& k : contacts) ++c.per_grain[row_of(k.low)], ++c.per_grain[row_of(k.high)];
  double sum = 0.0;
  for (std::size_t g = 0; g < grains.size(); ++g) {
    if (grains[g].touches_edge && !include_edge_grains) continue;
    const std::uint32_t z = c.per_grain[g];
    if (c.histogram.size() <= z) c.histogram.resize(z + 1, 0);
    ++c.histogram[z];
    sum += z;
    ++c.counted;
  }
  if (c.counted > 0) c.mean = sum / static_cast<double>(c.counted);
  return c;
}

}  // namespace graintwin::contacts
