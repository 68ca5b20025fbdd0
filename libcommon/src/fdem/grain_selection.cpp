#include "graintwin/fdem/grain_selection.hpp"

#include <algorithm>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/results_file.hpp"

namespace graintwin::fdem {

std::vector<std::uint32_t> grains_with_labels(const Model& model, std::span<const std::uint32_t> labels,
                                              std::vector<std::uint32_t>& unknown) {
  std::map<std::uint32_t, std::uint32_t> row;
  for (std::size_t g = 0; g < model.grains.size(); ++g) row[model.grains[g].label] = static_cast<std::uint32_t>(g);
  std::vector<std::uint32_t> out;
  for (std::uint32_t label : labels) {
    const auto it = row.find(label);
    if (it == row.end())
      unknown.push_back(label);
    else
      out.push_back(it->second);
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

Eigen::Vector3d mesh_centroid(const Model& model, std::size_t g) {
  const Grain& grain = model.grains[g];
  Eigen::Vector3d moment = Eigen::Vector3d::Zero();
  double volume = 0;
  for (std::uint32_t e = grain.element_begin; e < grain.element_end; ++e) {
    const std::uint32_t* n = model.element_nodes.data() + model.element_offset[e];
    const Eigen::Vector3d &a = model.nodes[n[0]], &b = model.nodes[n[1]], &c = model.nodes[n[2]], &d = model.nodes[n[3]];
    const double v = (b - a).cross(c - a).dot(d - a) / 6;
    moment += v * (a + b + c + d) / 4;
    volume += v;
  }
  return moment / volume;
}

std::vector<std::uint32_t> grains_in_box(const Model& model, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  std::vector<std::uint32_t> out;
  for (std::size_t g = 0; g < model.grains.size(); ++g) {
    const Eigen::Vector3d c = mesh_centroid(model, g);
    if ((c.array() >= lo.array()).all() && (c.array() <= hi.array()).all()) out.push_back(static_cast<std::uint32_t>(g));
  }
  return out;
}

std::vector<std::uint32_t> grains_above(const Model& model, const std::map<std::uint32_t, double>& value, double above) {
  std::vector<std::uint32_t> out;
  for (std::size_t g = 0; g < model.grains.size(); ++g)
    if (const auto it = value.find(model.grains[g].label); it != value.end() && it->second > above)
      out.push_back(static_cast<std::uint32_t>(g));
  return out;
}

std::vector<std::uint32_t> grains_highest(const Model& model, const std::map<std::uint32_t, double>& value, std::size_t count) {
  std::vector<std::uint32_t> valued;
  for (std::size_t g = 0; g < model.grains.size(); ++g)
    if (value.count(model.grains[g].label)) valued.push_back(static_cast<std::uint32_t>(g));
  const auto higher = [&](std::uint32_t a, std::uint32_t b) {
    const double va = value.at(model.grains[a].label), vb = value.at(model.grains[b].label);
    return va != vb ? va > vb : model.grains[a].label < model.grains[b].label;
  };
  const std::size_t n = std::min(count, valued.size());
  std::partial_sort(valued.begin(), valued.begin() + static_cast<std::ptrdiff_t>(n), valued.end(), higher);
  valued.resize(n);
  std::sort(valued.begin(), valued.end());
  return valued;
}

std::map<std::uint32_t, double> mean_stress_by_label(const std::filesystem::path& results, std::size_t frame) {
  const ResultsGrains grains = read_results_grains(results);
  const ResultsFrame f = read_results_frame(results, frame);
  if (f.stress.size() != 9 * grains.label.size())
    throw DataError(results.string() + ": frame " + std::to_string(frame) + " holds stresses of " + std::to_string(f.stress.size() / 9) +
                    " grains, not of its " + std::to_string(grains.label.size()) + "; rerun fdemrun");
  std::map<std::uint32_t, double> out;
  for (std::size_t g = 0; g < grains.label.size(); ++g)
    out[grains.label[g]] = (f.stress[9 * g] + f.stress[9 * g + 4] + f.stress[9 * g + 8]) / 3;
  return out;
}

}  // namespace graintwin::fdem
