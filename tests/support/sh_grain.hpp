#pragma once
// A grain record for the mesh tests whose SH coefficients (degree 4) describe
// r(d) = c00 Y00 + c20 Y20: a sphere of radius r0 stretched or squashed along z by c20.
#include <Eigen/Core>

#include <cmath>

#include "graintwin/shape/grain_measure.hpp"

namespace graintwin::test {

inline shape::GrainShape sh_grain(double r0, double c20, const Eigen::Vector3d& centroid) {
  shape::GrainShape g;
  g.label = 3;
  g.centroid = centroid;
  g.coeffs = Eigen::VectorXd::Zero(25);
  g.coeffs[0] = r0 * std::sqrt(4.0 * M_PI);
  g.coeffs[6] = c20;  // index n*n + n + m for n = 2, m = 0
  g.equivalent_diameter = 2.0 * r0;
  g.surface_area = 4.0 * M_PI * r0 * r0;
  g.semi_axes = Eigen::Vector3d(r0, r0, r0);
  return g;
}

}  // namespace graintwin::test
