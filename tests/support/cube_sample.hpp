#pragma once
// A tiny triaxial sample for tests: 3 x 3 x 3 rigid cubes of `edge`, 2 % apart, in a sample
// cylinder that just encloses them, between platens "bottom" and "top" 2 % of an edge away.
#include <cmath>

#include "graintwin/fdem/model.hpp"
#include "graintwin/fdem/primitives.hpp"

namespace graintwin::test {

inline fdem::Model cube_sample(double edge) {
  fdem::Model m;
  const fdem::TetMesh cube = fdem::box_mesh(Eigen::Vector3d::Constant(edge), 0.5 * edge);
  const double pitch = 1.02 * edge;
  std::uint32_t label = 0;
  for (int i = -1; i <= 1; ++i)
    for (int j = -1; j <= 1; ++j)
      for (int k = 0; k < 3; ++k)
        fdem::add_grain(m, cube, Eigen::Vector3d(i * pitch, j * pitch, (k + 0.5) * pitch), fdem::GrainKind::rigid, 0, ++label);
  fdem::SampleCylinder s;
  s.radius = std::hypot(1.5 * pitch, 1.5 * pitch) * 1.01;
  s.z_min = 0.0;
  s.z_max = 3 * pitch;
  m.sample = s;
  m.platens = {fdem::Platen{"bottom", Eigen::Vector3d(0, 0, s.z_min), Eigen::Vector3d::UnitZ(), 0.0},
               fdem::Platen{"top", Eigen::Vector3d(0, 0, s.z_max), -Eigen::Vector3d::UnitZ(), 0.0}};
  return m;
}

}  // namespace graintwin::test
