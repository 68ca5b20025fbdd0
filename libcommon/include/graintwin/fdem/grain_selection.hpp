#pragma once
// Rules that pick grains of a model by label, place or a value per label (a scan's D2min, a run's
// grain stress): a scene's [model.deformable] (docs/fdemrun.md) models the picked grains of a model
// file deformable and the rest rigid. Each returns rows of model.grains, ascending.
#include <Eigen/Core>

#include <cstdint>
#include <filesystem>
#include <map>
#include <span>
#include <vector>

#include "graintwin/fdem/model.hpp"

namespace graintwin::fdem {

/// The grains with these labels; `unknown` receives the labels no grain has, in the given order.
std::vector<std::uint32_t> grains_with_labels(const Model& model, std::span<const std::uint32_t> labels,
                                              std::vector<std::uint32_t>& unknown);
/// Centroid of grain g's mesh from its corner tetrahedra (exact for 4-node elements, within the
/// curvature of 10-node ones), m.
Eigen::Vector3d mesh_centroid(const Model& model, std::size_t grain);
/// The grains whose mesh_centroid lies in the box [lo, hi].
std::vector<std::uint32_t> grains_in_box(const Model& model, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi);
/// The grains whose value (looked up by label) exceeds `above`; grains without a value are left out.
std::vector<std::uint32_t> grains_above(const Model& model, const std::map<std::uint32_t, double>& value, double above);
/// The `count` grains with the highest values (looked up by label; equal values: the lower label
/// first); grains without a value are left out.
std::vector<std::uint32_t> grains_highest(const Model& model, const std::map<std::uint32_t, double>& value, std::size_t count);

/// Mean stress p = tr(sigma) / 3 (compression positive, Pa) of every grain of frame `frame` of a
/// kind=fdem_results file, by label (results_file's readers; their errors name the file).
std::map<std::uint32_t, double> mean_stress_by_label(const std::filesystem::path& results, std::size_t frame);

}  // namespace graintwin::fdem
