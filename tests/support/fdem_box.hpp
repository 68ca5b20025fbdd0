#pragma once
// One elastic box grain for the single-grain fdem tests (elastostatic, implicit grains): kSide x
// kSide x kLength m along z, centred on the origin, meshed at 0.25 mm, material 0 (the default glass).
#include <Eigen/Core>

#include "graintwin/fdem/model.hpp"
#include "graintwin/fdem/primitives.hpp"

namespace graintwin::test {

inline constexpr double kBoxSide = 1e-3, kBoxLength = 2e-3;  // m

inline fdem::Model box_grain(fdem::GrainKind kind) {
  fdem::Model model;
  fdem::add_grain(model, fdem::box_mesh(Eigen::Vector3d(kBoxSide, kBoxSide, kBoxLength), 0.25e-3), Eigen::Vector3d::Zero(), kind, 0, 1);
  return model;
}

}  // namespace graintwin::test
