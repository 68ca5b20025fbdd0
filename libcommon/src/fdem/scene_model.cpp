// The model a scene describes: the model file's grains and the scene's primitives, platens and
// sample cylinder, with the penalties set per element size resolved on the built meshes.
#include <fmt/format.h>

#include <algorithm>
#include <string>
#include <vector>

#include "graintwin/core/error.hpp"
#include "graintwin/core/statistics.hpp"
#include "graintwin/fdem/model_file.hpp"
#include "graintwin/fdem/primitives.hpp"
#include "graintwin/fdem/scene.hpp"

namespace graintwin::fdem {

Model build_model(const Scene& scene, const CurvedGrainMesher& mesh_curved) {
  Model m;
  if (scene.model) {
    m = *scene.model->model;
    if (scene.model->kind == GrainKind::rigid)
      for (Grain& g : m.grains) g.kind = GrainKind::rigid;
    if (scene.model->kind == GrainKind::tet4) split_into_linear_grains(m);
    if (const auto& deformable = scene.model->deformable) {
      // The picked grains deform with their mesh's element order (also where the file models them
      // rigid), the others are rigid.
      std::vector<char> picked(m.grains.size(), 0);
      for (std::uint32_t g : deformable->grains) picked[g] = 1;
      for (std::size_t g = 0; g < m.grains.size(); ++g) {
        Grain& grain = m.grains[g];
        const bool quadratic = grain.element_end > grain.element_begin && m.nodes_of(grain.element_begin) == 10;
        grain.kind = !picked[g] ? GrainKind::rigid : quadratic ? GrainKind::tet10 : GrainKind::tet4;
      }
    }
  }
  m.materials = scene.materials;
  m.platens.clear();
  for (const GrainSpec& g : scene.grains) {
    if (g.shape == PrimitiveShape::box) {
      add_grain(m, box_mesh(g.size, g.element_size), g.position, g.kind, g.material, g.label);
    } else {
      if (!mesh_curved)
        throw UsageError("grain label " + std::to_string(g.label) + " is a " + enum_name(kPrimitiveShapeNames, g.shape) +
                         ", which this program cannot mesh (gmsh is in graintwin_mesh); use fdemrun");
      mesh_curved(m, g);
    }
  }
  for (const PlatenSpec& p : scene.platens) m.platens.push_back(p.platen);
  m.sample = scene.sample;
  for (std::uint32_t k = 0; k < std::min(scene.size_penalties.size(), m.materials.size()); ++k) {
    const SizePenalty& rule = scene.size_penalties[k];
    if (!(rule.per_size > 0)) continue;
    const double h = rule.element_size > 0 ? rule.element_size : contact_element_size(m, k);
    if (!(h > 0))
      throw UsageError("material '" + m.materials[k].name + "' sets penalty_per_size but no grain uses it; " +
                       "give it penalty_element_size or drop the key");
    m.materials[k].normal_penalty = m.materials[k].tangential_penalty = rule.per_size * m.materials[k].young / h;
    if (const std::string problem = material_range_problem(m.materials[k]); !problem.empty())
      throw UsageError(fmt::format("material '{}': penalty_per_size {:g} x young / {:g} m gives a penalty out of range: {}; "
                                   "lower penalty_per_size or give a larger penalty_element_size",
                                   m.materials[k].name, rule.per_size, h, problem));
  }
  return m;
}

std::array<std::size_t, 3> grain_kind_counts(const Model& model) {
  std::array<std::size_t, 3> counts{};
  for (const Grain& g : model.grains) ++counts[static_cast<std::size_t>(g.kind)];
  return counts;
}

double contact_element_size(const Model& model, std::uint32_t material) {
  std::vector<double> edges;
  for (std::size_t t = 0; t < model.triangles.size(); ++t) {
    const Grain& grain = model.grains[model.triangle_grain[t]];
    if (grain.material != material) continue;
    // A 10-node grain's surface triangles are quarters of its element faces.
    const bool quadratic = grain.element_end > grain.element_begin && model.nodes_of(grain.element_begin) == 10;
    const double split = quadratic ? 2.0 : 1.0;
    const auto& c = model.triangles[t];
    for (int i = 0; i < 3; ++i) edges.push_back(split * (model.nodes[c[i]] - model.nodes[c[(i + 1) % 3]]).norm());
  }
  return median(std::move(edges));
}

}  // namespace graintwin::fdem
