#include "graintwin/fdem/implicit_grain.hpp"

#include <fmt/format.h>

#include <Eigen/SVD>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/element.hpp"

namespace graintwin::fdem {

ImplicitGrain::ImplicitGrain(const Model& model, std::size_t grain, std::span<const double> node_mass, double dt,
                             double damping)
    : dt_(dt), damping_(damping) {
  const Grain& g = model.grains.at(grain);
  const auto name = [&] { return fmt::format("grain {} (label {})", grain, g.label); };
  if (!(dt > 0)) throw UsageError(fmt::format("implicit grain: the time step must be > 0 (got {} s)", dt));
  if (!(damping >= 0)) throw UsageError(fmt::format("implicit grain: the damping must be >= 0 (got {} /s)", damping));
  if (node_mass.size() != model.nodes.size())
    throw UsageError(fmt::format("implicit grain: {} node masses for a model of {} nodes; pass one per node", node_mass.size(),
                                 model.nodes.size()));
  if (g.element_end <= g.element_begin)
    throw DataError(fmt::format("implicit grain: {} has no elements; mesh it with shapes2mesh.", name()));
  node_count_ = g.node_end - g.node_begin;
  Eigen::Vector3d first = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < node_count_; ++i) {
    mass_.push_back(node_mass[g.node_begin + i]);
    total_mass_ += mass_.back();
    first += mass_.back() * model.nodes[g.node_begin + i];
  }
  if (!(total_mass_ > 0)) throw DataError(fmt::format("implicit grain: {} has no mass; check its material's density.", name()));
  reference_centre_ = first / total_mass_;
  for (std::size_t i = 0; i < node_count_; ++i) reference_.push_back(model.nodes[g.node_begin + i] - reference_centre_);

  const Lame lame = lame_constants(model.materials.at(g.material));
  const std::vector<Eigen::Triplet<double>> lower = grain_stiffness_lower(model, grain, lame);
  stiffness_ = SymmetricNodeBlocks(node_count_, lower);
  std::vector<Eigen::Triplet<double>> system;
  system.reserve(lower.size() + 3 * node_count_);
  for (const Eigen::Triplet<double>& t : lower) system.emplace_back(t.row(), t.col(), dt * dt * t.value());
  for (std::size_t i = 0; i < node_count_; ++i)
    for (int k = 0; k < 3; ++k)
      system.emplace_back(static_cast<int>(3 * i + k), static_cast<int>(3 * i + k), (1 + damping * dt) * mass_[i]);
  factor_ = NodeBlockLdlt(node_count_, system);
  if (!factor_.positive_definite())
    throw DataError(fmt::format("implicit grain: (1 + damping dt) M + dt^2 K of {} is not positive definite (an inverted element or a "
                                "node without mass); mesh the grain again.",
                                name()));
  for (Eigen::VectorXd* v : {&u_, &Ku_, &rhs_, &w_}) v->resize(static_cast<Eigen::Index>(3 * node_count_));
}

ImplicitGrain::Frame ImplicitGrain::frame(std::span<const Eigen::Vector3d> x) const {
  Eigen::Vector3d first = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < node_count_; ++i) first += mass_[i] * x[i];
  const Eigen::Vector3d c = first / total_mass_;
  Eigen::Matrix3d moment = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < node_count_; ++i) moment += mass_[i] * (x[i] - c) * reference_[i].transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(moment, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d flip = Eigen::Matrix3d::Identity();  // a proper rotation, also for a flattened grain
  flip(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return {svd.matrixU() * flip * svd.matrixV().transpose(), c};
}

std::vector<Eigen::Vector3d> ImplicitGrain::displacement(std::span<const Eigen::Vector3d> x) const {
  const auto [R, c] = frame(x);
  std::vector<Eigen::Vector3d> u(node_count_);
  for (std::size_t i = 0; i < node_count_; ++i) u[i] = R.transpose() * (x[i] - c) - reference_[i];
  return u;
}

ImplicitGrain::StepEnergies ImplicitGrain::step(std::span<Eigen::Vector3d> x, std::span<Eigen::Vector3d> v,
                                                std::span<const Eigen::Vector3d> f, const Eigen::Vector3d& gravity, const Frame* at) {
  const auto [R, c] = at ? *at : frame(x);
  Eigen::VectorXd &u = u_, &Ku = Ku_, &rhs = rhs_, &w = w_;
  const auto all = [](Eigen::VectorXd& a) { return std::span<double>(a.data(), static_cast<std::size_t>(a.size())); };
  for (std::size_t i = 0; i < node_count_; ++i)
    u.segment<3>(static_cast<Eigen::Index>(3 * i)) = R.transpose() * (x[i] - c) - reference_[i];
  stiffness_.multiply(all(u), all(Ku));
  StepEnergies e;
  e.strain_start = 0.5 * u.dot(Ku);
  for (std::size_t i = 0; i < node_count_; ++i) {
    const auto k = static_cast<Eigen::Index>(3 * i);
    rhs.segment<3>(k) = mass_[i] * (R.transpose() * v[i]) + dt_ * (R.transpose() * (f[i] + mass_[i] * gravity) - Ku.segment<3>(k));
  }
  factor_.solve(all(rhs), all(w));
  double w_Kw = 0;
  for (std::size_t i = 0; i < node_count_; ++i) {
    const auto k = static_cast<Eigen::Index>(3 * i);
    const Eigen::Vector3d v_end = R * w.segment<3>(k), v_mean = 0.5 * (v[i] + v_end);
    e.kinetic_start += 0.5 * mass_[i] * v[i].squaredNorm();
    e.kinetic_end += 0.5 * mass_[i] * v_end.squaredNorm();
    e.kinetic_mean += 0.5 * mass_[i] * v_mean.squaredNorm();
    e.work += dt_ * (f[i] + mass_[i] * gravity).dot(v_mean);
    e.gravity_work += dt_ * mass_[i] * gravity.dot(v_mean);
    // For the strain energy after the step without another product with K: h^2 K w = rhs - (1 + alpha h) M w.
    w_Kw += w.segment<3>(k).dot(rhs.segment<3>(k) - (1 + damping_ * dt_) * mass_[i] * w.segment<3>(k));
    v[i] = v_end;
    x[i] += dt_ * v_end;
  }
  // Of u' = u + h w (R held; K does not see the rigid part of w).
  e.strain_end = e.strain_start + dt_ * w.dot(Ku) + 0.5 * w_Kw;
  return e;
}

}  // namespace graintwin::fdem
