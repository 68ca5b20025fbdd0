#include "graintwin/fdem/elastostatic.hpp"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <fmt/format.h>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/element.hpp"

namespace graintwin::fdem {
namespace {

/// Index of the largest |v_k|.
int dominant_axis(const Eigen::Vector3d& v) {
  int k = 0;
  v.cwiseAbs().maxCoeff(&k);
  return k;
}

}  // namespace

ElastostaticGrain::ElastostaticGrain(const Model& model, std::size_t grain, std::span<const double> node_mass) {
  const Grain& g = model.grains.at(grain);
  const auto name = [&] { return fmt::format("grain {} (label {})", grain, g.label); };
  if (node_mass.size() != model.nodes.size())
    throw DataError(fmt::format("elastostatic: {} node masses for {} model nodes; pass one lumped mass per node.",
                                node_mass.size(), model.nodes.size()));
  if (g.element_end <= g.element_begin || g.node_end <= g.node_begin)
    throw DataError(fmt::format("elastostatic: {} has no elements; it needs a tetrahedral mesh.", name()));
  node_begin_ = g.node_begin;
  node_count_ = g.node_end - g.node_begin;
  lame_ = lame_constants(model.materials.at(g.material));

  // Reference gradients at the element forces' quadrature points.
  for (std::size_t e = g.element_begin; e < g.element_end; ++e) {
    Element element;
    element.node_count = static_cast<int>(model.nodes_of(e));
    if (element.node_count != 4 && element.node_count != 10)
      throw DataError(fmt::format("elastostatic: element {} of {} has {} nodes; 4- or 10-node tetrahedra only.", e,
                                  name(), element.node_count));
    const std::uint32_t* nodes = model.element_nodes.data() + model.element_offset[e];
    for (int a = 0; a < element.node_count; ++a) {
      if (nodes[a] < g.node_begin || nodes[a] >= g.node_end)
        throw DataError(fmt::format("elastostatic: element {} of {} uses node {} outside the grain; rebuild the model.", e,
                                    name(), nodes[a]));
      element.nodes[static_cast<std::size_t>(a)] = nodes[a] - g.node_begin;
    }
    const TetRule& rule = stiffness_rule(element.node_count);
    for (std::size_t q = 0; q < rule.points.size(); ++q) {
      const ReferenceGradients r = reference_gradients(model, e, rule.points[q]);
      Point p;
      p.weight = rule.weights[q] * r.det;
      for (int a = 0; a < element.node_count; ++a) p.gradient[static_cast<std::size_t>(a)] = r.gradient.row(a).transpose();
      element.points.push_back(p);
    }
    elements_.push_back(std::move(element));
  }

  // Lumped masses about their mass centre (the inertia relief balances with these).
  Eigen::Vector3d first = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < node_count_; ++i) {
    mass_.push_back(node_mass[node_begin_ + i]);
    total_mass_ += mass_.back();
    first += mass_.back() * model.nodes[node_begin_ + i];
  }
  if (!(total_mass_ > 0)) throw DataError(fmt::format("elastostatic: {} has no mass; check its material's density.", name()));
  const Eigen::Vector3d centre = first / total_mass_;
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < node_count_; ++i) {
    arm_.push_back(model.nodes[node_begin_ + i] - centre);
    const Eigen::Vector3d& r = arm_.back();
    inertia += mass_[i] * (r.squaredNorm() * Eigen::Matrix3d::Identity() - r * r.transpose());
  }
  inverse_inertia_ = inertia.inverse();

  // 3-2-1 supports: A farthest from the centre, B farthest from A, C farthest from the line AB.
  std::size_t A = 0, B = 0, C = 0;
  for (std::size_t i = 0; i < node_count_; ++i)
    if (arm_[i].squaredNorm() > arm_[A].squaredNorm()) A = i;
  for (std::size_t i = 0; i < node_count_; ++i)
    if ((arm_[i] - arm_[A]).squaredNorm() > (arm_[B] - arm_[A]).squaredNorm()) B = i;
  const Eigen::Vector3d d = arm_[B] - arm_[A];
  for (std::size_t i = 0; i < node_count_; ++i)
    if (d.cross(arm_[i] - arm_[A]).squaredNorm() > d.cross(arm_[C] - arm_[A]).squaredNorm()) C = i;
  // With A held, B's two components across d's dominant axis leave only rotation about d, which C's
  // component along the dominant axis of d x (C - A) stops.
  const int m = dominant_axis(d);
  held_ = {3 * A, 3 * A + 1, 3 * A + 2, 3 * B + static_cast<std::size_t>((m + 1) % 3),
           3 * B + static_cast<std::size_t>((m + 2) % 3), 3 * C + static_cast<std::size_t>(dominant_axis(d.cross(arm_[C] - arm_[A])))};
  std::vector<char> held(3 * node_count_, 0);
  for (const std::size_t k : held_) held[k] = 1;

  // The element stiffnesses assembled; only the lower triangle, which the factorisation reads. Held
  // components become identity rows and columns.
  std::vector<Eigen::Triplet<double>> triplets = grain_stiffness_lower(model, grain, lame_, held);
  for (const std::size_t k : held_) triplets.emplace_back(static_cast<int>(k), static_cast<int>(k), 1.0);
  Eigen::SparseMatrix<double> K(static_cast<Eigen::Index>(3 * node_count_), static_cast<Eigen::Index>(3 * node_count_));
  K.setFromTriplets(triplets.begin(), triplets.end());
  // The identity rows stand beside stiffnesses of order E h: scale them alike, so the pivot test
  // below compares like with like.
  double scale = 0;
  for (Eigen::Index k = 0; k < K.outerSize(); ++k) scale = std::max(scale, K.coeff(k, k));  // K is lower triangular here
  for (const std::size_t k : held_) K.coeffRef(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(k)) = scale;
  factor_.compute(K);
  const Eigen::VectorXd pivots = factor_.vectorD();
  if (factor_.info() != Eigen::Success || !(pivots.minCoeff() > 1e-10 * pivots.maxCoeff()))
    throw DataError(fmt::format("elastostatic: the stiffness of {} is singular (its mesh is in several pieces or "
                                "has unconnected nodes); mesh the grain again.", name()));
}

ElastostaticState ElastostaticGrain::solve(std::span<const Eigen::Vector3d> loads) const {
  if (loads.size() != node_count_)
    throw UsageError(fmt::format("elastostatic: {} loads for a grain of {} nodes; pass one per node.", loads.size(), node_count_));
  ElastostaticState s;
  Eigen::Vector3d force = Eigen::Vector3d::Zero(), moment = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < node_count_; ++i) force += loads[i], moment += arm_[i].cross(loads[i]);
  s.acceleration = force / total_mass_;
  s.angular_acceleration = inverse_inertia_ * moment;
  Eigen::VectorXd b(static_cast<Eigen::Index>(3 * node_count_));
  for (std::size_t i = 0; i < node_count_; ++i)
    b.segment<3>(static_cast<Eigen::Index>(3 * i)) =
        loads[i] - mass_[i] * (s.acceleration + s.angular_acceleration.cross(arm_[i]));
  for (const std::size_t k : held_) b[static_cast<Eigen::Index>(k)] = 0;
  const Eigen::VectorXd u = factor_.solve(b);
  s.displacement.resize(node_count_);
  for (std::size_t i = 0; i < node_count_; ++i) s.displacement[i] = u.segment<3>(static_cast<Eigen::Index>(3 * i));
  s.stress.reserve(elements_.size());
  for (const Element& element : elements_) {
    Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
    double volume = 0;
    for (const Point& p : element.points) {
      Eigen::Matrix3d grad = Eigen::Matrix3d::Zero();  // du/dX
      for (int a = 0; a < element.node_count; ++a)
        grad += s.displacement[element.nodes[static_cast<std::size_t>(a)]] * p.gradient[static_cast<std::size_t>(a)].transpose();
      sum += p.weight * isotropic_stress(0.5 * (grad + grad.transpose()), lame_);
      volume += p.weight;
    }
    s.stress.push_back(sum / volume);
  }
  return s;
}

}  // namespace graintwin::fdem
