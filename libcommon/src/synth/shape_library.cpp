// A shape library read from a segmented scan: usable grains of a shapes file with their voxels.
#include "graintwin/synth/shape_library.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <map>
#include <numbers>

#include "graintwin/core/error.hpp"
#include "graintwin/core/filters.hpp"
#include "graintwin/core/geometry.hpp"
#include "graintwin/core/parallel.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "graintwin/shape/sh_basis.hpp"
#include "graintwin/shape/shapes_file.hpp"

namespace graintwin::synth {

ShapeLibrary read_shape_library(const std::filesystem::path& shapes_path, const std::filesystem::path& labels_path) {
  const shape::ShapesFile shapes = shape::read_shapes_file(shapes_path);
  segment::LabelsFile labels = segment::read_labels_file(labels_path);
  std::map<std::uint32_t, const segment::GrainRecord*> records;
  for (const auto& r : labels.grains) records[r.label] = &r;
  ShapeLibrary out;
  constexpr std::uint8_t unusable =
      shape::shape_flag::touches_edge | shape::shape_flag::small | shape::shape_flag::centroid_outside;
  for (const shape::GrainShape& g : shapes.grains) {
    const auto found = records.find(g.label);
    if (found == records.end())
      throw UsageError(labels_path.string() + " has no grain with label " + std::to_string(g.label) + " of " +
                       shapes_path.string() + "; give the labels file the shapes were measured from");
    if (g.flags & unusable) {
      ++out.left_out;
      continue;
    }
    out.grains.push_back({g.label, found->second->bbox, g.centroid, g.volume});
  }
  if (out.grains.empty())
    throw UsageError(shapes_path.string() + " holds no grain usable as a library shape (all " +
                     std::to_string(out.left_out) +
                     " are cut by the field of view, too small or have the centroid outside); give a scan with whole grains");
  out.labels = std::move(labels.labels);
  return out;
}

VoxelGrain library_grain(const ShapeLibrary& library, std::size_t index) {
  const ShapeLibrary::Entry& e = library.grains.at(index);
  const auto pad = static_cast<std::size_t>(3 + std::ceil(3.0 * kLibrarySmoothingVox));
  const Shape3 s{e.bbox[3] - e.bbox[0] + 2 * pad, e.bbox[4] - e.bbox[1] + 2 * pad, e.bbox[5] - e.bbox[2] + 2 * pad};
  const Vec3& vs = library.labels.voxel_size();
  const Vec3& o = library.labels.origin();
  // Field voxel (0, 0, 0) is labels voxel bbox - pad; body coordinates are relative to the centroid.
  const Vec3 origin{o[0] + (static_cast<double>(e.bbox[0]) - static_cast<double>(pad)) * vs[0] - e.centroid.z(),
                    o[1] + (static_cast<double>(e.bbox[1]) - static_cast<double>(pad)) * vs[1] - e.centroid.y(),
                    o[2] + (static_cast<double>(e.bbox[2]) - static_cast<double>(pad)) * vs[2] - e.centroid.x()};
  Volume<float> field(s, vs, origin);
  for (std::size_t z = e.bbox[0]; z < e.bbox[3]; ++z)
    for (std::size_t y = e.bbox[1]; y < e.bbox[4]; ++y)
      for (std::size_t x = e.bbox[2]; x < e.bbox[5]; ++x)
        if (library.labels(z, y, x) == e.label) field(z - e.bbox[0] + pad, y - e.bbox[1] + pad, x - e.bbox[2] + pad) = 1.0f;
  const double voxels = e.volume / (vs[0] * vs[1] * vs[2]);
  gaussian_blur(field, kLibrarySmoothingVox);
  const double iso = volume_preserving_level(field, voxels);
  return VoxelGrain(std::move(field), iso);
}

std::vector<std::size_t> draw_library_grains(const ShapeLibrary& library, double volume, std::mt19937_64& rng) {
  if (library.grains.empty()) throw UsageError("the shape library holds no grain to draw");
  std::uniform_int_distribution<std::size_t> pick(0, library.grains.size() - 1);
  std::vector<std::size_t> out;
  for (double filled = 0.0; filled < volume;) {
    out.push_back(pick(rng));
    filled += library.grains[out.back()].volume;
  }
  return out;
}

GrainSet make_library_grains(const ShapeLibrary& library, const std::vector<std::size_t>& draws, int degree,
                             double voxel_size, const std::function<void(double)>& progress) {
  std::vector<std::size_t> distinct = draws;
  std::sort(distinct.begin(), distinct.end());
  distinct.erase(std::unique(distinct.begin(), distinct.end()), distinct.end());
  const shape::ShFitter fitter(degree);
  const double library_voxel = std::cbrt(library.labels.voxel_size()[0] * library.labels.voxel_size()[1] *
                                         library.labels.voxel_size()[2]);
  // Rays step a quarter of the finer of the two voxels: the field varies on the library's voxel,
  // the scans resolve the render's.
  const double resolution = 0.25 * std::min(library_voxel, voxel_size);
  std::vector<std::shared_ptr<const VoxelGrain>> solids(distinct.size());
  std::vector<SolidGrainRecord> records(distinct.size());
  std::atomic<std::size_t> done{0};
  parallel_for_each_index(distinct.size(), [&](std::size_t k) {
    auto solid = std::make_shared<const VoxelGrain>(library_grain(library, distinct[k]));
    const double r = equivalent_radius(library.grains[distinct[k]].volume);
    // Table nodes: a node spacing of about a third of the finer voxel at the grain's surface.
    const int nodes = std::clamp(static_cast<int>(std::ceil(2.0 * r / (resolution * 4.0 / 3.0))), 16, 160);
    records[k] = solid_grain_record(*solid, last_exit_table(*solid, nodes, resolution), fitter, resolution);
    solids[k] = std::move(solid);
    const std::size_t d = ++done;
    if (progress) {
#pragma omp critical(library_progress)
      progress(static_cast<double>(d) / static_cast<double>(distinct.size()));
    }
  });
  GrainSet set;
  set.sh_degree = fitter.degree();
  const auto n = static_cast<Eigen::Index>(draws.size());
  set.coeffs_body = Eigen::MatrixXd::Zero(n, shape::sh_count(set.sh_degree));
  for (std::size_t i = 0; i < draws.size(); ++i) {
    const auto k = static_cast<std::size_t>(std::lower_bound(distinct.begin(), distinct.end(), draws[i]) - distinct.begin());
    const SolidGrainRecord& r = records[k];
    set.diameters.push_back(r.stats.equivalent_diameter);
    set.tables.push_back(r.table);
    set.coeffs_body.row(static_cast<Eigen::Index>(i)) = r.coeffs.transpose();
    set.stats.push_back(r.stats);
    set.sh_fit_rms.push_back(r.sh_fit_rms);
    set.solids.push_back(solids[k]);
    set.non_star.push_back(r.non_star);
  }
  return set;
}

}  // namespace graintwin::synth
