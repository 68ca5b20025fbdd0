#include "graintwin/fdem/element.hpp"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <cmath>
#include <string>

#include "graintwin/core/error.hpp"
#include "graintwin/core/parallel.hpp"

namespace graintwin::fdem {
namespace {

using Gradients = Eigen::Matrix<double, 10, 3>;

/// Barycentric coordinates L0..L3 of natural coordinates xi and their (constant) derivatives.
std::array<double, 4> barycentric(const Eigen::Vector3d& xi) { return {1.0 - xi.sum(), xi[0], xi[1], xi[2]}; }
Eigen::RowVector3d barycentric_derivative(int k) {
  return k == 0 ? Eigen::RowVector3d(-1, -1, -1) : Eigen::RowVector3d::Unit(k - 1);
}

const std::uint32_t* element_nodes(const Model& model, std::size_t e) {
  return model.element_nodes.data() + model.element_offset[e];
}

/// dX/dxi of element e at xi (reference positions).
Eigen::Matrix3d reference_jacobian(const Model& model, std::size_t e, const Gradients& dN, int n) {
  const std::uint32_t* nodes = element_nodes(model, e);
  Eigen::Matrix3d J = Eigen::Matrix3d::Zero();
  for (int a = 0; a < n; ++a) J += model.nodes[nodes[a]] * dN.row(a);
  return J;
}

std::string element_name(const Model& model, std::size_t e) {
  return "element " + std::to_string(e) + " (grain label " + std::to_string(model.grains[model.element_grain[e]].label) + ")";
}

int checked_node_count(const Model& model, std::size_t e) {
  const std::size_t n = model.nodes_of(e);
  if (n != 4 && n != 10)
    throw DataError(element_name(model, e) + " has " + std::to_string(n) + " nodes; FDEM takes 4- or 10-node tetrahedra only");
  return static_cast<int>(n);
}

}  // namespace

Lame lame_constants(const Material& m) {
  const double nu = m.poisson, E = m.young;
  return {E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))};
}

double dilatational_wave_speed(const Material& m) {
  const double nu = m.poisson;
  return std::sqrt(m.young * (1 - nu) / (m.density * (1 + nu) * (1 - 2 * nu)));
}

void tet_shape_functions(int nodes, const Eigen::Vector3d& xi, double* N) {
  const auto L = barycentric(xi);
  if (nodes == 4) {
    for (int k = 0; k < 4; ++k) N[k] = L[k];
    return;
  }
  for (int k = 0; k < 4; ++k) N[k] = L[k] * (2 * L[k] - 1);
  for (int k = 0; k < 6; ++k) N[4 + k] = 4 * L[kTet10Edges[k][0]] * L[kTet10Edges[k][1]];
}

void tet_shape_derivatives(int nodes, const Eigen::Vector3d& xi, Gradients& dN) {
  const auto L = barycentric(xi);
  if (nodes == 4) {
    for (int k = 0; k < 4; ++k) dN.row(k) = barycentric_derivative(k);
    return;
  }
  for (int k = 0; k < 4; ++k) dN.row(k) = (4 * L[k] - 1) * barycentric_derivative(k);
  for (int k = 0; k < 6; ++k) {
    const int i = kTet10Edges[k][0], j = kTet10Edges[k][1];
    dN.row(4 + k) = 4 * (L[j] * barycentric_derivative(i) + L[i] * barycentric_derivative(j));
  }
}

const TetRule& stiffness_rule(int nodes) {
  static const TetRule one{{Eigen::Vector3d(0.25, 0.25, 0.25)}, {1.0 / 6.0}};
  static const TetRule four = [] {
    const double a = 0.5854101966249685, b = 0.1381966011250105;
    return TetRule{{Eigen::Vector3d(b, b, b), Eigen::Vector3d(a, b, b), Eigen::Vector3d(b, a, b), Eigen::Vector3d(b, b, a)},
                   {1.0 / 24, 1.0 / 24, 1.0 / 24, 1.0 / 24}};
  }();
  return nodes == 4 ? one : four;
}

const TetRule& exact_rule() {
  static const TetRule rule = [] {
    // Gauss-Legendre on [0, 1]; the map xi = (u, v (1 - u), w (1 - u)(1 - v)) has Jacobian (1 - u)^2 (1 - v).
    const double x[5] = {-0.9061798459386640, -0.5384693101056831, 0.0, 0.5384693101056831, 0.9061798459386640};
    const double w[5] = {0.2369268850561891, 0.4786286704993665, 0.5688888888888889, 0.4786286704993665,
                         0.2369268850561891};
    TetRule r;
    for (int i = 0; i < 5; ++i)
      for (int j = 0; j < 5; ++j)
        for (int k = 0; k < 5; ++k) {
          const double u = 0.5 * (x[i] + 1), v = 0.5 * (x[j] + 1), t = 0.5 * (x[k] + 1);
          r.points.emplace_back(u, v * (1 - u), t * (1 - u) * (1 - v));
          r.weights.push_back(0.125 * w[i] * w[j] * w[k] * (1 - u) * (1 - u) * (1 - v));
        }
    return r;
  }();
  return rule;
}

std::vector<Eigen::Triplet<double>> grain_stiffness_lower(const Model& model, std::size_t grain, const Lame& lame,
                                                          std::span<const char> held) {
  const Grain& g = model.grains.at(grain);
  std::vector<Eigen::Triplet<double>> triplets;
  ElementStiffness Ke;
  const auto free = [&](std::size_t dof) { return held.empty() || !held[dof]; };
  for (std::size_t e = g.element_begin; e < g.element_end; ++e) {
    const int n = element_stiffness(model, e, lame, Ke);
    const std::uint32_t* nodes = model.element_nodes.data() + model.element_offset[e];
    for (int a = 0; a < n; ++a)
      for (int b = 0; b <= a; ++b)
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) {
            std::size_t row = 3 * (nodes[a] - g.node_begin) + static_cast<std::size_t>(i);
            std::size_t col = 3 * (nodes[b] - g.node_begin) + static_cast<std::size_t>(j);
            if (!free(row) || !free(col)) continue;
            if (row < col) {
              if (a == b) continue;  // the diagonal block's upper half: its lower half holds it
              std::swap(row, col);
            }
            triplets.emplace_back(static_cast<int>(row), static_cast<int>(col), Ke(3 * a + i, 3 * b + j));
          }
  }
  return triplets;
}

void map_rule(const Model& model, std::size_t e, const TetRule& rule, std::vector<Eigen::Vector3d>& points,
              std::vector<double>& weights) {
  const int n = checked_node_count(model, e);
  const std::uint32_t* nodes = element_nodes(model, e);
  points.clear();
  weights.clear();
  Gradients dN;
  double N[10];
  for (std::size_t q = 0; q < rule.points.size(); ++q) {
    tet_shape_functions(n, rule.points[q], N);
    tet_shape_derivatives(n, rule.points[q], dN);
    Eigen::Vector3d X = Eigen::Vector3d::Zero();
    for (int a = 0; a < n; ++a) X += N[a] * model.nodes[nodes[a]];
    points.push_back(X);
    weights.push_back(rule.weights[q] * std::abs(reference_jacobian(model, e, dN, n).determinant()));
  }
}

double element_volume(const Model& model, std::size_t e) {
  const int n = checked_node_count(model, e);
  // Degree of det J: 0 for straight elements, 3 for curved 10-node ones.
  const TetRule& rule = n == 4 ? stiffness_rule(4) : exact_rule();
  Gradients dN;
  double v = 0;
  for (std::size_t q = 0; q < rule.points.size(); ++q) {
    tet_shape_derivatives(n, rule.points[q], dN);
    v += rule.weights[q] * reference_jacobian(model, e, dN, n).determinant();
  }
  return v;
}

double element_min_altitude(const Model& model, std::size_t e) {
  const std::uint32_t* c = element_nodes(model, e);
  const Eigen::Vector3d& p0 = model.nodes[c[0]];
  const Eigen::Vector3d &p1 = model.nodes[c[1]], &p2 = model.nodes[c[2]], &p3 = model.nodes[c[3]];
  const double volume = std::abs((p1 - p0).cross(p2 - p0).dot(p3 - p0)) / 6;
  const double area = 0.5 * std::max({(p1 - p0).cross(p2 - p0).norm(), (p1 - p0).cross(p3 - p0).norm(),
                                      (p2 - p0).cross(p3 - p0).norm(), (p2 - p1).cross(p3 - p1).norm()});
  return area > 0 ? 3 * volume / area : 0.0;
}

ReferenceGradients reference_gradients(const Model& model, std::size_t e, const Eigen::Vector3d& xi) {
  const int n = checked_node_count(model, e);
  Gradients dN;
  tet_shape_derivatives(n, xi, dN);
  const Eigen::Matrix3d J = reference_jacobian(model, e, dN, n);
  ReferenceGradients r;
  r.det = J.determinant();
  if (!(r.det > 0))
    throw DataError(element_name(model, e) + " is inverted or flat in the reference mesh (det J = " + std::to_string(r.det) +
                    "); remesh the grain");
  r.inverse_jacobian = J.inverse();
  r.gradient.setZero();
  for (int a = 0; a < n; ++a) r.gradient.row(a) = dN.row(a) * r.inverse_jacobian;
  return r;
}

ElasticElements::ElasticElements(const Model& model) : model_(&model) {
  for (const Material& m : model.materials) lame_.push_back(lame_constants(m));
  const std::size_t elements = model.element_count();
  slot_.assign(elements, kNoSlot);
  for (std::size_t e = 0; e < elements; ++e) {
    const Grain& grain = model.grains[model.element_grain[e]];
    if (grain.kind == GrainKind::rigid) continue;
    const int n = checked_node_count(model, e);
    if ((n == 10) != (grain.kind == GrainKind::tet10))
      throw DataError(element_name(model, e) + " has " + std::to_string(n) + " nodes but its grain is declared " +
                      enum_name(kGrainKindNames, grain.kind) + "; rebuild the model with one element order per grain");
    const TetRule& rule = stiffness_rule(n);
    slot_[e] = static_cast<std::uint32_t>(n == 4 ? linear_.size() : weight_.size());
    for (std::size_t q = 0; q < rule.points.size(); ++q) {
      const ReferenceGradients r = reference_gradients(model, e, rule.points[q]);
      if (n == 4) {
        const std::uint32_t* c = element_nodes(model, e);
        // dN_a/dxi of corners 1..3 are the unit rows, so their dN/dX rows are exactly J^-1's.
        linear_.push_back({{c[0], c[1], c[2], c[3]}, grain.material, rule.weights[q] * r.det, r.inverse_jacobian});
        continue;
      }
      weight_.push_back(rule.weights[q] * r.det);
      for (int a = 0; a < n; ++a) gradient_.insert(gradient_.end(), {r.gradient(a, 0), r.gradient(a, 1), r.gradient(a, 2)});
    }
  }
}

Eigen::Matrix3d isotropic_stress(const Eigen::Matrix3d& E, const Lame& L) {
  Eigen::Matrix3d S = 2 * L.mu * E;
  S.diagonal().array() += L.lambda * E.trace();
  return S;
}

int element_stiffness(const Model& model, std::size_t e, const Lame& L, ElementStiffness& K) {
  const int n = checked_node_count(model, e);
  const TetRule& rule = stiffness_rule(n);
  K.topLeftCorner(3 * n, 3 * n).setZero();
  for (std::size_t q = 0; q < rule.points.size(); ++q) {
    const ReferenceGradients r = reference_gradients(model, e, rule.points[q]);
    const double w = rule.weights[q] * r.det;
    for (int a = 0; a < n; ++a)
      for (int b = 0; b <= a; ++b) {
        const Eigen::Vector3d ga = r.gradient.row(a).transpose(), gb = r.gradient.row(b).transpose();
        K.block<3, 3>(3 * a, 3 * b) +=
            w * (L.lambda * ga * gb.transpose() + L.mu * gb * ga.transpose() + L.mu * ga.dot(gb) * Eigen::Matrix3d::Identity());
      }
  }
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < a; ++b) K.block<3, 3>(3 * b, 3 * a) = K.block<3, 3>(3 * a, 3 * b).transpose();
  return n;
}

namespace {

/// Green-Lagrange strain E = (F^T F - I) / 2, St Venant-Kirchhoff stress S = lambda tr(E) I + 2 mu E
/// and the energy density lambda tr(E)^2 / 2 + mu E:E, J/m^3.
double saint_venant_kirchhoff(const Eigen::Matrix3d& F, const Lame& L, Eigen::Matrix3d& S) {
  const Eigen::Matrix3d E = 0.5 * (F.transpose() * F - Eigen::Matrix3d::Identity());
  const double trE = E.trace();
  S = isotropic_stress(E, L);
  return 0.5 * L.lambda * trE * trE + L.mu * E.squaredNorm();
}

/// Stiffness-proportional viscous stress beta C : dE, dE = sym(F^T dF) the Green-Lagrange strain rate.
Eigen::Matrix3d viscous_stress(const Eigen::Matrix3d& F, const Eigen::Matrix3d& dF, const Lame& L, double beta) {
  const Eigen::Matrix3d FtdF = F.transpose() * dF;
  return beta * isotropic_stress(0.5 * (FtdF + FtdF.transpose()), L);
}

using NodeColumns = Eigen::Matrix<double, 3, 10>;
using PointGradients = Eigen::Map<const Eigen::Matrix<double, 10, 3, Eigen::RowMajor>>;

/// The Lame constants of element e's grain's material as it is now: density scaling of the grains
/// (mass_scaling.hpp) gives a grain a copy of its material after the elements were built, beyond
/// the materials they cached.
Lame element_lame(const Model& model, std::size_t e) {
  return lame_constants(model.materials[model.grains[model.element_grain[e]].material]);
}

/// A 10-node element's node positions relative to corner 0, one column each (the gradients sum to
/// zero, so F = X G, without the grain's distance from the origin in the sum).
NodeColumns relative_positions(std::span<const Eigen::Vector3d> x, const std::uint32_t* nodes) {
  NodeColumns X;
  for (int a = 0; a < 10; ++a) X.col(a) = x[nodes[a]] - x[nodes[0]];
  return X;
}

/// dN_a/dX of quadrature point q of the 10-node elements, one row per node.
PointGradients point_gradients(const std::vector<double>& gradients, std::size_t q) {
  return PointGradients(gradients.data() + 3 * 10 * q);
}

}  // namespace

Eigen::Matrix3d ElasticElements::linear_deformation_gradient(std::span<const Eigen::Vector3d> x, const LinearTet& t) {
  const Eigen::Vector3d x0 = x[t.nodes[0]];
  Eigen::Matrix3d D;
  D << x[t.nodes[1]] - x0, x[t.nodes[2]] - x0, x[t.nodes[3]] - x0;
  return D * t.gradients;
}

std::size_t ElasticElements::quadratic_points() { return stiffness_rule(10).points.size(); }

template <class Visit>
void ElasticElements::for_each_point(std::span<const Eigen::Vector3d> x, std::size_t e, Visit&& visit) const {
  const std::uint32_t slot = slot_[e];
  if (slot == kNoSlot) return;
  Eigen::Matrix3d F, S;
  if (model_->nodes_of(e) == 4) {
    const LinearTet& t = linear_[slot];
    F = linear_deformation_gradient(x, t);
    const double psi = saint_venant_kirchhoff(F, lame_[t.material], S);
    visit(t.volume, F, S, psi);
    return;
  }
  const std::uint32_t* nodes = element_nodes(*model_, e);
  const Lame L = element_lame(*model_, e);
  const NodeColumns X = relative_positions(x, nodes);
  for (std::size_t q = slot, end = slot + quadratic_points(); q < end; ++q) {
    F = X * point_gradients(gradient_, q);
    const double psi = saint_venant_kirchhoff(F, L, S);
    visit(weight_[q], F, S, psi);
  }
}

void ElasticElements::add_linear_tet_forces(std::span<const Eigen::Vector3d> x, const LinearTet& t,
                                            std::span<Eigen::Vector3d> f, double& energy) const {
  const Eigen::Matrix3d F = linear_deformation_gradient(x, t);
  Eigen::Matrix3d S;
  energy += t.volume * saint_venant_kirchhoff(F, lame_[t.material], S);
  subtract_linear_tet_forces(t, t.volume * (F * S), f);
}

void ElasticElements::subtract_linear_tet_forces(const LinearTet& t, const Eigen::Matrix3d& stress_volume,
                                                 std::span<Eigen::Vector3d> f) {
  // Column a - 1 is V P dN_a/dX, the force node a = 1..3 takes; node 0 takes minus their sum.
  const Eigen::Matrix3d H = stress_volume * t.gradients.transpose();
  f[t.nodes[1]] -= H.col(0);
  f[t.nodes[2]] -= H.col(1);
  f[t.nodes[3]] -= H.col(2);
  f[t.nodes[0]] += H.rowwise().sum();
}

void ElasticElements::add_quadratic_tet_forces(std::span<const Eigen::Vector3d> x, std::size_t e,
                                               std::span<Eigen::Vector3d> f, double& energy) const {
  const std::uint32_t* nodes = element_nodes(*model_, e);
  const Lame L = element_lame(*model_, e);
  const NodeColumns X = relative_positions(x, nodes);  // gathered once for the 4 points
  NodeColumns forces = NodeColumns::Zero();
  for (std::size_t q = slot_[e], end = slot_[e] + quadratic_points(); q < end; ++q) {
    const PointGradients G = point_gradients(gradient_, q);
    const Eigen::Matrix3d F = X * G;
    Eigen::Matrix3d S;
    energy += weight_[q] * saint_venant_kirchhoff(F, L, S);
    forces.noalias() += (weight_[q] * (F * S)) * G.transpose();
  }
  for (int a = 0; a < 10; ++a) f[nodes[a]] -= forces.col(a);
}

double ElasticElements::add_internal_forces(std::span<const Eigen::Vector3d> x, std::size_t begin, std::size_t end,
                                            std::span<Eigen::Vector3d> f) const {
  double energy = 0;
  for (std::size_t e = begin; e < end; ++e) {
    if (slot_[e] == kNoSlot) continue;
    if (model_->nodes_of(e) == 4)
      add_linear_tet_forces(x, linear_[slot_[e]], f, energy);
    else
      add_quadratic_tet_forces(x, e, f, energy);
  }
  return energy;
}

void ElasticElements::add_viscous_forces(std::span<const Eigen::Vector3d> x, std::span<const Eigen::Vector3d> v, double beta,
                                         std::size_t begin, std::size_t end, std::span<Eigen::Vector3d> f) const {
  for (std::size_t e = begin; e < end; ++e) {
    if (slot_[e] == kNoSlot) continue;
    if (model_->nodes_of(e) == 4) {
      const LinearTet& t = linear_[slot_[e]];
      // The deformation gradient of the velocities is the rate dF (the same linear map).
      const Eigen::Matrix3d F = linear_deformation_gradient(x, t), dF = linear_deformation_gradient(v, t);
      subtract_linear_tet_forces(t, t.volume * (F * viscous_stress(F, dF, lame_[t.material], beta)), f);
      continue;
    }
    const std::uint32_t* nodes = element_nodes(*model_, e);
    const Lame L = element_lame(*model_, e);
    const NodeColumns X = relative_positions(x, nodes), V = relative_positions(v, nodes);
    NodeColumns forces = NodeColumns::Zero();
    for (std::size_t q = slot_[e], last = slot_[e] + quadratic_points(); q < last; ++q) {
      const PointGradients G = point_gradients(gradient_, q);
      const Eigen::Matrix3d F = X * G;
      forces.noalias() += (weight_[q] * (F * viscous_stress(F, V * G, L, beta))) * G.transpose();
    }
    for (int a = 0; a < 10; ++a) f[nodes[a]] -= forces.col(a);
  }
}

double ElasticElements::strain_energy(std::span<const Eigen::Vector3d> x, std::size_t begin, std::size_t end) const {
  double energy = 0;
  for (std::size_t e = begin; e < end; ++e)
    for_each_point(x, e, [&](double w, const Eigen::Matrix3d&, const Eigen::Matrix3d&, double psi) { energy += w * psi; });
  return energy;
}

std::vector<Eigen::Matrix3d> ElasticElements::cauchy_stress(std::span<const Eigen::Vector3d> x, std::size_t e) const {
  std::vector<Eigen::Matrix3d> out;
  for_each_point(x, e, [&](double, const Eigen::Matrix3d& F, const Eigen::Matrix3d& S, double) {
    out.push_back(F * S * F.transpose() / F.determinant());
  });
  return out;
}

std::vector<Eigen::Matrix3d> ElasticElements::deformation_gradient(std::span<const Eigen::Vector3d> x, std::size_t e) const {
  std::vector<Eigen::Matrix3d> out;
  for_each_point(x, e, [&](double, const Eigen::Matrix3d& F, const Eigen::Matrix3d&, double) { out.push_back(F); });
  return out;
}

Eigen::Matrix3d ElasticElements::average_cauchy_stress(std::span<const Eigen::Vector3d> x, std::size_t begin,
                                                       std::size_t end) const {
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  double volume = 0;
  for (std::size_t e = begin; e < end; ++e)
    for_each_point(x, e, [&](double w, const Eigen::Matrix3d& F, const Eigen::Matrix3d& S, double) {
      sum += w * (F * S * F.transpose());  // sigma J dV0 = sigma dv
      volume += w * F.determinant();
    });
  return volume > 0 ? Eigen::Matrix3d(sum / volume) : Eigen::Matrix3d::Zero();
}

std::vector<double> lumped_masses(const Model& model) {
  std::vector<double> mass(model.nodes.size(), 0.0);
  // A grain's elements touch only its own nodes: grains in parallel, each in element order, give
  // the serial sums bit for bit.
  parallel_for_each_index(model.grains.size(), [&](std::size_t g) {
    add_lumped_masses(model, model.grains[g].element_begin, model.grains[g].element_end, mass);
  });
  return mass;
}

void add_lumped_masses(const Model& model, std::size_t element_begin, std::size_t element_end, std::span<double> mass) {
  std::vector<Eigen::Vector3d> points;
  std::vector<double> weights;
  double N[10];
  for (std::size_t e = element_begin; e < element_end; ++e) {
    const int n = checked_node_count(model, e);
    const double rho = model.materials[model.grains[model.element_grain[e]].material].density;
    const std::uint32_t* nodes = element_nodes(model, e);
    if (n == 4) {
      const double share = rho * std::abs(element_volume(model, e)) / 4;
      for (int a = 0; a < 4; ++a) mass[nodes[a]] += share;
      continue;
    }
    // HRZ: the consistent mass diagonal int rho N_a^2 dV, scaled so that it sums to the element mass.
    const TetRule& rule = exact_rule();
    map_rule(model, e, rule, points, weights);
    double diagonal[10] = {}, total = 0, element_mass = 0;
    for (std::size_t q = 0; q < rule.points.size(); ++q) {
      tet_shape_functions(10, rule.points[q], N);
      for (int a = 0; a < 10; ++a) diagonal[a] += rho * weights[q] * N[a] * N[a];
      element_mass += rho * weights[q];
    }
    for (double d : diagonal) total += d;
    for (int a = 0; a < 10; ++a) mass[nodes[a]] += diagonal[a] * element_mass / total;
  }
}

BodyProperties body_properties(const Model& model, std::size_t grain) {
  const Grain& g = model.grains[grain];
  const double rho = model.materials[g.material].density;
  BodyProperties b;
  std::vector<Eigen::Vector3d> points;
  std::vector<double> weights;
  // Moments about the first node keep the second moments well conditioned far from the origin.
  const Eigen::Vector3d origin = model.nodes[g.node_begin];
  Eigen::Vector3d first = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
  for (std::size_t e = g.element_begin; e < g.element_end; ++e) {
    if (model.nodes_of(e) == 4) {
      // A straight tetrahedron in closed form: int r = V (sum r_i) / 4 and
      // int r r^T = V / 20 (sum r_i r_i^T + (sum r_i)(sum r_i)^T), r_i its corners.
      const std::uint32_t* n = element_nodes(model, e);
      const Eigen::Vector3d r[4] = {model.nodes[n[0]] - origin, model.nodes[n[1]] - origin,
                                    model.nodes[n[2]] - origin, model.nodes[n[3]] - origin};
      const double volume = std::abs((r[1] - r[0]).dot((r[2] - r[0]).cross(r[3] - r[0]))) / 6;
      const Eigen::Vector3d sum = r[0] + r[1] + r[2] + r[3];
      Eigen::Matrix3d outer = sum * sum.transpose();
      for (const Eigen::Vector3d& ri : r) outer += ri * ri.transpose();
      b.volume += volume;
      first += volume / 4 * sum;
      second += volume / 20 * outer;
      continue;
    }
    map_rule(model, e, exact_rule(), points, weights);
    for (std::size_t q = 0; q < points.size(); ++q) {
      const Eigen::Vector3d r = points[q] - origin;
      b.volume += weights[q];
      first += weights[q] * r;
      second += weights[q] * r * r.transpose();
    }
  }
  if (!(b.volume > 0)) throw DataError("grain label " + std::to_string(g.label) + " has no volume; check its mesh");
  b.mass = rho * b.volume;
  const Eigen::Vector3d c = first / b.volume;
  b.centroid = origin + c;
  const Eigen::Matrix3d second_c = rho * (second - b.volume * c * c.transpose());  // int rho r r^T about the centroid
  b.inertia = second_c.trace() * Eigen::Matrix3d::Identity() - second_c;
  return b;
}

}  // namespace graintwin::fdem
