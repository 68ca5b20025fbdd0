#include "graintwin/fdem/solver.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>

#include <fmt/format.h>

#include "graintwin/core/error.hpp"
#include "graintwin/core/interval.hpp"
#include "graintwin/core/parallel.hpp"
#include "graintwin/fdem/elastostatic.hpp"
#include "graintwin/fdem/vector_io.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/schema.hpp"

namespace graintwin::fdem {
namespace ck = schema::fdem_checkpoint;
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();
/// Squared strain below which energy is round-off: a run with almost no energy put in (a grain at
/// rest) must not count 1e-29 J of noise as a runaway. E V eps^2 summed over the grains.
constexpr double kRunawayStrain2 = 1e-12;

/// Critical step factors k in dt = k h_min / c for a regular tetrahedron with lumped mass
/// (element eigenvalue bound; docs/fdemrun.md): 4-node row sum and 10-node HRZ.
constexpr double kCriticalTet4 = 0.671, kCriticalTet10 = 0.327;

Eigen::Quaterniond rotation_by(const Eigen::Vector3d& theta) {
  const double angle = theta.norm();
  if (angle == 0) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, theta / angle));
}

bool finite(const Eigen::Vector3d& v) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); }

/// Local non-viscous damping of an unbalanced force (or torque) f on a DOF moving at v:
/// -local |f_k| sign(v_k) per component.
Eigen::Vector3d local_damping_force(const Eigen::Vector3d& f, const Eigen::Vector3d& v, double local) {
  Eigen::Vector3d d;
  for (int k = 0; k < 3; ++k) d[k] = -local * std::abs(f[k]) * double((v[k] > 0) - (v[k] < 0));
  return d;
}

/// The Love-Weber average stress (1/V) sym(sum_n r_n f_n^T) of a moment sum over a volume.
Eigen::Matrix3d love_weber(const Eigen::Matrix3d& moment, double volume) { return 0.5 * (moment + moment.transpose()) / volume; }

/// The node masses contact uses for its dashpots and its stable step: a deformable grain's lumped
/// node masses; for a rigid grain, the body's effective mass at the node in its stiffest direction,
/// 1 / (1/M + |r|^2 / I_min), shared by the `rigid_contact_nodes` nodes assumed to touch at once
/// (its element-lumped node masses mean nothing for a body that moves as one).
std::vector<double> contact_masses(const Model& model, std::span<const double> lumped,
                                   const std::vector<BodyProperties>& bodies, double rigid_contact_nodes, bool implicit_grains) {
  std::vector<double> mass(lumped.begin(), lumped.end());
  for (std::size_t g = 0; g < model.grains.size(); ++g) {
    const Grain& grain = model.grains[g];
    if (grain.kind != GrainKind::rigid && !implicit_grains) continue;
    const BodyProperties& b = bodies[g];
    const double inertia = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(b.inertia, Eigen::EigenvaluesOnly).eigenvalues()[0];
    for (std::uint32_t i = grain.node_begin; i < grain.node_end; ++i) {
      const double arm2 = (model.nodes[i] - b.centroid).squaredNorm();
      mass[i] = 1.0 / (1.0 / b.mass + arm2 / inertia) / rigid_contact_nodes;
    }
  }
  return mass;
}

void check_implicit_damping(const SolverOptions& options) {
  if (options.implicit_grains && (options.stiffness_damping > 0 || options.local_damping > 0))
    throw UsageError("implicit grains take mass-proportional damping only so far; set stiffness and local damping to 0");
}

}  // namespace

double damped_critical_step(double critical, double beta) {
  if (!std::isfinite(critical)) return critical;
  return critical * critical / (std::sqrt(critical * critical + beta * beta) + beta);
}

double undamped_critical_step(double step, double beta) { return std::sqrt(step * (step + 2 * beta)); }

Solver::Solver(const Model& model, const SolverOptions& options)
    : model_(&model), options_(options), elements_(model), mass_(lumped_masses(model)) {
  if (model.grains.empty()) throw UsageError("the FDEM model has no grain; add grains to the scene");
  const std::size_t grains = model.grains.size();
  bodies_.resize(grains);
  inverse_inertia_.resize(grains);
  state_.bodies.resize(grains);
  parallel_for_each_index(grains, [&](std::size_t g) { bodies_[g] = body_properties(model, g); });
  for (std::size_t g = 0; g < grains; ++g) {
    state_.bodies[g].position = bodies_[g].centroid;
    if (model.grains[g].kind == GrainKind::rigid) inverse_inertia_[g] = bodies_[g].inertia.inverse();
    const Material& material = model.materials[model.grains[g].material];
    runaway_floor_ += kRunawayStrain2 * material.young * bodies_[g].volume;
  }
  state_.x = model.nodes;
  state_.v.assign(model.nodes.size(), Eigen::Vector3d::Zero());
  for (const Platen& p : model.platens) state_.platens.push_back({p.point, p.normal.normalized(), Eigen::Vector3d::Zero(), p.friction});
  platen_force_.assign(model.platens.size(), Eigen::Vector3d::Zero());
  platen_stiffness_.assign(model.platens.size(), 0.0);
  force_.assign(model.nodes.size(), Eigen::Vector3d::Zero());
  viscous_force_.assign(model.nodes.size(), Eigen::Vector3d::Zero());
  rigid_loads_.assign(grains, RigidLoad{});
  if (!(options.stiffness_damping >= 0) || !(options.local_damping >= 0 && options.local_damping < 1))
    throw UsageError(fmt::format("stiffness damping ({:g} s) must not be negative and local damping ({:g}) must lie in [0, 1)",
                                 options.stiffness_damping, options.local_damping));
  if (!(options.rigid_contact_nodes >= 1))
    throw UsageError("rigid_contact_nodes must be at least 1 (the nodes of a rigid grain assumed to touch at once)");
  check_implicit_damping(options);
  contact_mass_ = contact_masses(model, mass_, bodies_, options.rigid_contact_nodes, options.implicit_grains);
  if (options.implicit_grains) {
    implicit_.resize(grains);
    implicit_frames_.resize(grains);
  }
  if (options.contact.enabled) contact_ = std::make_unique<ContactModel>(model, contact_mass_, options.contact);
  if (contact_ && options.elastostatic_stress) contact_->record_node_forces(true);
}

Solver::~Solver() = default;

void Solver::set_grain_velocity(std::size_t g, const Eigen::Vector3d& velocity, const Eigen::Vector3d& omega) {
  if (state_.step != 0) throw UsageError("initial velocities can only be set before the first step");
  const Grain& grain = model_->grains.at(g);
  const Eigen::Vector3d c = grain_centroid(g);
  for (std::uint32_t i = grain.node_begin; i < grain.node_end; ++i) state_.v[i] = velocity + omega.cross(state_.x[i] - c);
  if (grain.kind == GrainKind::rigid) {
    const Eigen::Matrix3d R = state_.bodies[g].orientation.toRotationMatrix();
    state_.bodies[g].velocity = velocity;
    state_.bodies[g].angular_momentum = R * bodies_[g].inertia * R.transpose() * omega;
  }
}

void Solver::refresh_masses(std::span<const std::uint32_t> grains) {
  if (state_.step != 0) throw UsageError("masses can only be refreshed before the first step");
  const Model& m = *model_;
  for (std::uint32_t g : grains) {
    const Grain& grain = m.grains.at(g);
    std::fill(mass_.begin() + grain.node_begin, mass_.begin() + grain.node_end, 0.0);
    add_lumped_masses(m, grain.element_begin, grain.element_end, mass_);
    if (!added_mass_.empty())
      for (std::uint32_t v = grain.node_begin; v < grain.node_end; ++v) mass_[v] += added_mass_[v];
    bodies_[g] = body_properties(m, g);
    if (grain.kind == GrainKind::rigid) inverse_inertia_[g] = bodies_[g].inertia.inverse();
    if (!implicit_.empty()) implicit_[g].reset();  // factored with the old masses
  }
  contact_mass_ = contact_masses(m, mass_, bodies_, options_.rigid_contact_nodes, options_.implicit_grains);
  if (contact_) contact_->set_node_masses(contact_mass_);
}

void Solver::add_node_masses(std::vector<double> added, double guaranteed_critical) {
  if (state_.step != 0) throw UsageError("node masses can only be added before the first step");
  const Model& m = *model_;
  if (added.size() != m.nodes.size() || !std::all_of(added.begin(), added.end(), [](double a) { return a >= 0; }))
    throw UsageError("add_node_masses takes one added mass of at least 0 per model node");
  std::vector<std::uint32_t> grains;
  for (std::size_t g = 0; g < m.grains.size(); ++g)
    for (std::uint32_t v = m.grains[g].node_begin; v < m.grains[g].node_end; ++v)
      if (added[v] != (added_mass_.empty() ? 0.0 : added_mass_[v])) {
        grains.push_back(static_cast<std::uint32_t>(g));
        break;
      }
  added_mass_ = std::move(added);
  guaranteed_critical_ = guaranteed_critical;
  refresh_masses(grains);
}

void Solver::stop_grains() {
  last_dt_ = 0;  // the velocities no longer lead back to where the last step's forces acted
  for (auto& v : state_.v) v.setZero();
  for (RigidBodyState& b : state_.bodies) {
    b.velocity.setZero();
    b.angular_momentum.setZero();
  }
}

void Solver::set_boundary(Boundary* boundary) {
  if (boundary && !contact_) throw UsageError("a sample boundary (wall or membrane) needs contact; enable contact in the scene");
  boundary_ = boundary;
}

void Solver::set_platen_velocity(std::size_t p, const Eigen::Vector3d& velocity) { state_.platens.at(p).velocity = velocity; }

std::vector<double> Solver::element_critical_steps() const {
  std::vector<double> steps(model_->element_count(), kInfinity);
  for (std::size_t e = 0; e < steps.size(); ++e) {
    if (!elements_.is_elastic(e)) continue;
    const Material& m = model_->materials[model_->grains[model_->element_grain[e]].material];
    const double k = model_->nodes_of(e) == 10 ? kCriticalTet10 : kCriticalTet4;
    steps[e] = k * element_min_altitude(*model_, e) / dilatational_wave_speed(m);
  }
  return steps;
}

void Solver::set_stiffness_damping(double beta) {
  SolverOptions next = options_;
  next.stiffness_damping = beta;
  check_implicit_damping(next);
  options_ = next;
}

void Solver::set_local_damping(double local) {
  SolverOptions next = options_;
  next.local_damping = local;
  check_implicit_damping(next);
  options_ = next;
}

StepLimits Solver::time_step_limits(double stiffness_damping) const {
  StepLimits s;
  const std::vector<double> steps = element_critical_steps();
  s.element_critical = kInfinity;
  for (std::size_t e = 0; e < steps.size(); ++e)
    if (steps[e] < s.element_critical) s.element_critical = steps[e], s.element = e;
  // Added mass lowers every frequency, so the estimate still holds beside the guarantee.
  if (guaranteed_critical_ > s.element_critical) s.element_critical = guaranteed_critical_, s.guaranteed = true;
  // The damped step grows with the undamped one, so the element with the shortest sets both.
  s.stiffness_damping = stiffness_damping;
  s.element_stable = options_.implicit_grains ? kInfinity  // implicit grains: their elements limit nothing
                                              : damped_critical_step(s.element_critical, stiffness_damping) * options_.element_safety;
  s.contact_stable = contact_ ? contact_->stable_time_step() : kInfinity;
  s.boundary_stable = boundary_ ? boundary_->stable_time_step(*contact_) : kInfinity;
  return s;
}

void Solver::check_time_step(double dt, double stiffness_damping) const {
  const StepLimits s = time_step_limits(stiffness_damping);
  if (!(dt > 0) || !std::isfinite(dt)) throw UsageError(fmt::format("the time step {:.4g} s must be positive", dt));
  if (dt > s.stable())
    throw UsageError(fmt::format(
        "the time step {:.4g} s is above the stable limit {:.4g} s (elements: {:.4g} s = {} x the critical {:.4g} s {}{}; "
        "contact: {:.4g} s; boundary: {:.4g} s); use at most {:.4g} s, or 0 for automatic",
        dt, s.stable(), s.element_stable, options_.element_safety, s.element_critical,
        s.guaranteed ? std::string("the scaled node masses guarantee") : fmt::format("of element {}", s.element),
        stiffness_damping > 0 ? fmt::format(" damped by stiffness_damping {:.4g} s", stiffness_damping) : "",
        s.contact_stable, s.boundary_stable, s.stable()));
}

Eigen::Vector3d Solver::angular_velocity(std::size_t g, const Eigen::Quaterniond& q, const Eigen::Vector3d& L) const {
  const Eigen::Matrix3d R = q.toRotationMatrix();
  return R * (inverse_inertia_[g] * (R.transpose() * L));
}

RigidPose Solver::pose_of(std::size_t g) const {
  const RigidBodyState& b = state_.bodies[g];
  return RigidPose::of_body(b.orientation.toRotationMatrix(), b.position, bodies_[g].centroid, b.velocity,
                            angular_velocity(g, b.orientation, b.angular_momentum));
}

void Solver::place_rigid_nodes() const {
  if (!rigid_nodes_stale_) return;
  const std::size_t grains = model_->grains.size();
#pragma omp parallel for schedule(dynamic, 8) if (model_->nodes.size() > 4096)
  for (std::size_t g = 0; g < grains; ++g) {
    const Grain& grain = model_->grains[g];
    if (grain.kind != GrainKind::rigid) continue;
    const RigidPose body = pose_of(g);
    for (std::uint32_t i = grain.node_begin; i < grain.node_end; ++i) {
      const Eigen::Vector3d r = body.arm(model_->nodes[i]);
      state_.x[i] = body.centre + r;
      state_.v[i] = body.velocity + body.angular_velocity.cross(r);
    }
  }
  rigid_nodes_stale_ = false;
}

const SolverState& Solver::state() const {
  place_rigid_nodes();
  return state_;
}

StepReport Solver::step(double dt) {
  const Model& m = *model_;
  const std::size_t grains = m.grains.size();
  const bool first = state_.step == 0;
  const double a = 0.5 * options_.damping * dt;  // damping over half a step
  const double beta = options_.stiffness_damping, local = options_.local_damping;
  const Eigen::Vector3d g_acc = options_.gravity;
  // Per-grain sums, added in grain order afterwards so the totals do not depend on the threads
  // (kept between steps: a step allocates nothing).
  std::vector<double>& strain = step_sums_.strain;
  std::vector<double>& kinetic = step_sums_.kinetic;
  std::vector<double>& damped = step_sums_.damped;
  std::vector<double>& gravity_work = step_sums_.gravity_work;
  std::vector<char>& bad = step_sums_.bad;
  for (auto* sum : {&strain, &kinetic, &damped, &gravity_work}) sum->assign(grains, 0.0);
  bad.assign(grains, 0);
  // Threads only pay off beyond a few thousand nodes: a barrier per loop costs more on small scenes.
  const bool parallel = m.nodes.size() > 4096;
  double mark = monotonic_seconds();
  const auto seconds_since = [&mark] {  // seconds since the last call (the step's previous phase)
    const double now = monotonic_seconds(), s = now - mark;
    mark = now;
    return s;
  };

  const std::span<const GrainRole> roles = share_ ? share_->roles() : std::span<const GrainRole>{};
#pragma omp parallel for schedule(dynamic, 8) if (parallel)
  for (std::size_t g = 0; g < grains; ++g) {
    const Grain& grain = m.grains[g];
    if (grain.kind == GrainKind::rigid || (!roles.empty() && roles[g] != GrainRole::owned)) continue;
    for (std::uint32_t i = grain.node_begin; i < grain.node_end; ++i) force_[i].setZero();
    if (options_.implicit_grains) {  // its elastic forces are inside its implicit step
      if (!implicit_[g] || implicit_[g]->time_step() != dt || implicit_[g]->damping() != options_.damping)
        implicit_[g] = std::make_unique<ImplicitGrain>(m, g, mass_, dt, options_.damping);
      const std::span<const Eigen::Vector3d> x_grain(state_.x.data() + grain.node_begin, grain.node_end - grain.node_begin);
      implicit_frames_[g] = implicit_[g]->frame(x_grain);
      continue;
    }
    strain[g] = elements_.add_internal_forces(state_.x, grain.element_begin, grain.element_end, force_);
    if (beta > 0) {  // from the velocities of the last half step: the stable step is damped_critical_step's
      for (std::uint32_t i = grain.node_begin; i < grain.node_end; ++i) viscous_force_[i].setZero();
      elements_.add_viscous_forces(state_.x, state_.v, beta, grain.element_begin, grain.element_end, viscous_force_);
    }
  }

  times_.elements += seconds_since();
  StepReport report;
  if (share_) contact_->set_grain_roles(roles);
  if (contact_) {
    // Contact places rigid grains' nodes and surface trees by their body motion: x = c + R (X - c0);
    // implicit grains give their best-fit frames, which let their pairs' near-node lists last.
    poses_.resize(grains);
    for (std::size_t g = 0; g < grains; ++g) {
      if (m.grains[g].kind == GrainKind::rigid) {
        poses_[g] = pose_of(g);
      } else if (!implicit_.empty() && implicit_[g]) {
        poses_[g] = RigidPose::of_frame(implicit_frames_[g].rotation, implicit_frames_[g].centre, implicit_[g]->reference_centre());
      }
    }
    report.contact = contact_->add_forces(state_.x, state_.v, state_.platens, dt, force_, poses_);
    times_.node_contacts += report.contact.node_contacts;
    times_.node_checks += report.contact.node_checks;
    times_.triangle_checks += report.contact.triangle_checks;
    times_.pair_lists_built += report.contact.pair_lists_built;
  }
  times_.contact += seconds_since();
  StepRows boundary_rows;
  double boundary_seconds = 0;
  if (boundary_) {
    boundary_rows = boundary_->add_contact_forces(*contact_, state_.x, state_.v, dt, force_);
    boundary_seconds = seconds_since();
  }
  if (contact_) {
    const std::span<const RigidLoad> loads = contact_->rigid_loads();
    rigid_loads_.assign(loads.begin(), loads.end());
  }

#pragma omp parallel for schedule(dynamic, 8) if (parallel)
  for (std::size_t g = 0; g < grains; ++g) {
    if (!roles.empty() && roles[g] != GrainRole::owned) continue;  // another rank advances it
    const Grain& grain = m.grains[g];
    if (grain.kind != GrainKind::rigid && options_.implicit_grains) {
      step_implicit_grain(g, dt, g_acc, kinetic[g], damped[g], gravity_work[g], strain[g], bad[g]);
      continue;
    }
    if (grain.kind != GrainKind::rigid) {
      for (std::uint32_t i = grain.node_begin; i < grain.node_end; ++i) {
        const double mi = mass_[i];
        const Eigen::Vector3d v_old = state_.v[i];
        // Damping forces besides the mass-proportional one, booked as dissipated by their work.
        Eigen::Vector3d f_damp = beta > 0 ? viscous_force_[i] : Eigen::Vector3d(Eigen::Vector3d::Zero());
        Eigen::Vector3d f = force_[i] + mi * g_acc + f_damp;
        if (local > 0) {
          const Eigen::Vector3d f_local = local_damping_force(f, v_old, local);
          f += f_local, f_damp += f_local;
        }
        const Eigen::Vector3d v_new = first ? Eigen::Vector3d(v_old + 0.5 * dt * (f / mi - options_.damping * v_old))
                                            : Eigen::Vector3d(((1 - a) * v_old + dt * f / mi) / (1 + a));
        const Eigen::Vector3d v_mid = first ? v_old : Eigen::Vector3d(0.5 * (v_old + v_new));
        kinetic[g] += 0.5 * mi * v_mid.squaredNorm();
        damped[g] += dt * (options_.damping * mi * v_mid.squaredNorm() - f_damp.dot(v_mid));
        gravity_work[g] += dt * mi * g_acc.dot(v_mid);
        state_.v[i] = v_new;
        state_.x[i] += dt * v_new;
        if (!finite(state_.x[i])) bad[g] = 1;
      }
      continue;
    }
    RigidBodyState& b = state_.bodies[g];
    const double M = bodies_[g].mass;
    Eigen::Vector3d F = M * g_acc + rigid_loads_[g].force, T = rigid_loads_[g].torque();
    const Eigen::Vector3d V_old = b.velocity, L_old = b.angular_momentum;
    Eigen::Vector3d F_local = Eigen::Vector3d::Zero(), T_local = Eigen::Vector3d::Zero();
    if (local > 0) {  // on the body's six DOFs, the spin's sign from the last half step's angular velocity
      F_local = local_damping_force(F, V_old, local);
      T_local = local_damping_force(T, angular_velocity(g, b.orientation, L_old), local);
      F += F_local, T += T_local;
    }
    const Eigen::Vector3d V_new = first ? Eigen::Vector3d(V_old + 0.5 * dt * (F / M - options_.damping * V_old))
                                        : Eigen::Vector3d(((1 - a) * V_old + dt * F / M) / (1 + a));
    const Eigen::Vector3d L_new = first ? Eigen::Vector3d(L_old + 0.5 * dt * (T - options_.damping * L_old))
                                        : Eigen::Vector3d(((1 - a) * L_old + dt * T) / (1 + a));
    const Eigen::Vector3d V_mid = first ? V_old : Eigen::Vector3d(0.5 * (V_old + V_new));
    const Eigen::Vector3d L_mid = first ? L_old : Eigen::Vector3d(0.5 * (L_old + L_new));
    const Eigen::Vector3d omega_mid = angular_velocity(g, b.orientation, L_mid);
    const double spin = omega_mid.dot(L_mid);
    kinetic[g] = 0.5 * M * V_mid.squaredNorm() + 0.5 * spin;
    damped[g] = dt * (options_.damping * (M * V_mid.squaredNorm() + spin) - F_local.dot(V_mid) - T_local.dot(omega_mid));
    gravity_work[g] = dt * M * g_acc.dot(V_mid);
    // Orientation: rotate by dt times the angular velocity at the half step, found by fixed point
    // on the midpoint orientation (second order, keeps a free body's energy).
    Eigen::Vector3d omega = angular_velocity(g, b.orientation, L_new);
    for (int it = 0; it < 2; ++it) omega = angular_velocity(g, rotation_by(0.5 * dt * omega) * b.orientation, L_new);
    b.orientation = (rotation_by(dt * omega) * b.orientation).normalized();
    b.velocity = V_new;
    b.angular_momentum = L_new;
    b.position += dt * V_new;
    if (!finite(b.position) || !finite(L_new)) bad[g] = 1;
  }
  rigid_nodes_stale_ = true;  // rigid grains moved; state() places their nodes when read
  StepTotals totals = step_totals(roles);
  if (share_) {
    share_->finish_step(totals, boundary_rows);
    if (totals.grains.value() != static_cast<double>(grains))
      throw DataError(fmt::format("the ranks advanced {} of the {} grains in step {}: every grain needs one owner",
                                  totals.grains.value(), grains, state_.step));
  }
  if (contact_) {
    report.contact.elastic_energy = totals.contact_elastic.value();
    report.contact.dissipated = totals.contact_dissipated.value();
    report.contact.node_contacts = static_cast<std::size_t>(totals.node_contacts.value());
    report.contact.max_overlap = totals.max_overlap;
  }
  for (std::size_t p = 0; p < platen_force_.size(); ++p) {
    for (int k = 0; k < 3; ++k) platen_force_[p][k] = totals.platens[4 * p + k].value();
    platen_stiffness_[p] = totals.platens[4 * p + 3].value();
  }
  times_.motion += seconds_since();
  BoundaryStep boundary;
  if (boundary_) {  // from every rank's contacts with it: every rank moves it alike
    boundary = boundary_->finish(*contact_, boundary_rows, dt, options_.damping, first);
    boundary_seconds += seconds_since();
    times_.boundary += boundary_seconds;
    if (const std::size_t bodies = boundary_->bodies()) times_.body_steps += bodies, times_.body_seconds += boundary_seconds;
  }

  Energies& e = report.energies;
  e.strain = totals.strain.value();
  e.kinetic = totals.bad.value() > 0 ? std::nan("") : totals.kinetic.value();
  state_.dissipated += totals.damped.value();
  state_.external_work += totals.gravity_work.value();
  state_.energy_input += totals.energy_input.value();
  e.contact_elastic = report.contact.elastic_energy + boundary.elastic;
  e.kinetic += boundary.kinetic;
  state_.dissipated += report.contact.dissipated + boundary.dissipated;
  state_.external_work += boundary.work;
  state_.energy_input += std::max(boundary.work, 0.0);
  for (std::size_t p = 0; p < state_.platens.size(); ++p) {
    const double work = -dt * platen_force_[p].dot(state_.platens[p].velocity);  // the platen pushes the grains
    state_.external_work += work;
    state_.energy_input += std::max(work, 0.0);
    state_.platens[p].point += dt * state_.platens[p].velocity;
  }
  if (first) state_.energy_input += e.mechanical();
  e.dissipated = state_.dissipated;
  e.external_work = state_.external_work;
  check_health(e);
  state_.time += dt;
  ++state_.step;
  last_dt_ = dt;
  times_.motion += seconds_since();
  ++times_.steps;
  return report;
}

void Solver::step_implicit_grain(std::size_t g, double dt, const Eigen::Vector3d& g_acc, double& kinetic, double& damped,
                                 double& gravity_work, double& strain, char& bad) {
  // The forces besides the elastic, damping and gravity ones are contact's, in force_. Contact books
  // its side itself, gravity is external work; the grain books what it lost.
  const Grain& grain = model_->grains[g];
  const std::size_t nodes = grain.node_end - grain.node_begin;
  const ImplicitGrain::StepEnergies e = implicit_[g]->step(std::span<Eigen::Vector3d>(state_.x).subspan(grain.node_begin, nodes),
                                                           std::span<Eigen::Vector3d>(state_.v).subspan(grain.node_begin, nodes),
                                                           std::span<const Eigen::Vector3d>(force_).subspan(grain.node_begin, nodes), g_acc,
                                                           &implicit_frames_[g]);
  for (std::uint32_t i = grain.node_begin; i < grain.node_end; ++i)
    if (!finite(state_.x[i])) bad = 1;
  kinetic = e.kinetic_mean;
  gravity_work = e.gravity_work;
  strain = e.strain_start;
  damped = e.lost();
}

void Solver::check_health(const Energies& e) const {
  const auto limits = [this] {
    const StepLimits s = time_step_limits();
    return fmt::format("stable limit {:.4g} s: elements {:.4g} s, contact {:.4g} s", s.stable(), s.element_stable,
                       s.contact_stable);
  };
  if (!std::isfinite(e.mechanical()))
    throw DataError(fmt::format("step {} (t = {:.6g} s): the state became NaN or infinite; likely cause: a time step above "
                                "the stable limit ({}) or a penalty too stiff for the time step; restart from the last "
                                "checkpoint with a smaller time step",
                                state_.step, state_.time, limits()));
  if (e.mechanical() > options_.runaway_factor * state_.energy_input + runaway_floor_)
    throw DataError(fmt::format("step {} (t = {:.6g} s): the mechanical energy {:.4g} J ran away to more than {} x the "
                                "energy put in ({:.4g} J); likely cause: a time step too close to the stable limit ({}) or "
                                "a penalty too stiff; restart from the last checkpoint with a smaller time step",
                                state_.step, state_.time, e.mechanical(), options_.runaway_factor, state_.energy_input, limits()));
}

Eigen::Vector3d Solver::mass_mean(std::size_t g, const std::vector<Eigen::Vector3d>& values) const {
  const Grain& grain = model_->grains[g];
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double total = 0;
  for (std::uint32_t i = grain.node_begin; i < grain.node_end; ++i) sum += mass_[i] * values[i], total += mass_[i];
  return sum / total;
}

Eigen::Vector3d Solver::grain_centroid(std::size_t g) const {
  return model_->grains.at(g).kind == GrainKind::rigid ? state_.bodies[g].position : mass_mean(g, state_.x);
}

Eigen::Vector3d Solver::grain_velocity(std::size_t g) const {
  return model_->grains.at(g).kind == GrainKind::rigid ? state_.bodies[g].velocity : mass_mean(g, state_.v);
}

Eigen::Vector3d Solver::grain_spin(std::size_t g) const {
  const Grain& grain = model_->grains.at(g);
  if (grain.kind == GrainKind::rigid) {
    const RigidBodyState& b = state_.bodies[g];
    return angular_velocity(g, b.orientation, b.angular_momentum);
  }
  const Eigen::Vector3d c = grain_centroid(g), v = grain_velocity(g);
  Eigen::Vector3d momentum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();
  for (std::uint32_t i = grain.node_begin; i < grain.node_end; ++i) {
    const Eigen::Vector3d r = state_.x[i] - c;
    momentum += mass_[i] * r.cross(state_.v[i] - v);
    inertia += mass_[i] * (r.squaredNorm() * Eigen::Matrix3d::Identity() - r * r.transpose());
  }
  return inertia.ldlt().solve(momentum);
}

Eigen::Quaterniond Solver::grain_rotation(std::size_t g) const {
  const Grain& grain = model_->grains.at(g);
  if (grain.kind == GrainKind::rigid) return state_.bodies[g].orientation;
  const Eigen::Vector3d c = grain_centroid(g), c0 = bodies_[g].centroid;
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  for (std::uint32_t i = grain.node_begin; i < grain.node_end; ++i)
    A += mass_[i] * (state_.x[i] - c) * (model_->nodes[i] - c0).transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(A, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1 : 1;
  return Eigen::Quaterniond(Eigen::Matrix3d(svd.matrixU() * D * svd.matrixV().transpose())).normalized();
}

Eigen::Matrix3d Solver::grain_stress(std::size_t g) const {
  const Grain& grain = model_->grains.at(g);
  if (grain.kind != GrainKind::rigid) return elements_.average_cauchy_stress(state_.x, grain.element_begin, grain.element_end);
  // A rigid body has no strain, but its average stress follows from the forces on its surface
  // (Love-Weber): sigma = (1/V) sum_n r_n (x) f_n, the symmetric part, with the contact and
  // boundary forces of the last step where they acted (gravity acts on the body, not on the nodes).
  return love_weber(rigid_loads_[g].moment, bodies_[g].volume);
}

std::vector<Eigen::Matrix3d> Solver::elastostatic_stresses(std::size_t g) const {
  const Grain& grain = model_->grains.at(g);
  if (grain.kind != GrainKind::rigid)
    throw UsageError(fmt::format("elastostatic stresses are for rigid grains; grain {} (label {}) is deformable and has its own.",
                                 g, grain.label));
  const std::span<const Eigen::Vector3d> forces = contact_ ? contact_->node_forces() : std::span<const Eigen::Vector3d>{};
  if (forces.size() != model_->nodes.size())
    throw UsageError("elastostatic stresses need the node forces of the last step: record them (ContactModel::record_node_forces) before it.");
  const Eigen::Matrix3d R = grain_rotation(g).toRotationMatrix();
  std::vector<Eigen::Vector3d> loads;  // body frame
  for (std::uint32_t i = grain.node_begin; i < grain.node_end; ++i)
    loads.push_back(R.transpose() * (forces[i] + mass_[i] * options_.gravity));
  const ElastostaticGrain body(*model_, g, mass_);
  std::vector<Eigen::Matrix3d> stress = body.solve(loads).stress;
  for (Eigen::Matrix3d& s : stress) s = R * s * R.transpose();
  return stress;
}

std::vector<Eigen::Matrix3d> Solver::love_weber_stresses() const {
  const Model& m = *model_;
  std::vector<Eigen::Matrix3d> out(m.grains.size(), Eigen::Matrix3d::Zero());
  // A deformable grain's contact and boundary forces are what the step added to force_ beside
  // minus its internal forces, f = force_ + f_int, at the positions x_n = x - dt v where they acted
  // (an implicit grain's internal forces are inside its step: force_ holds the others alone).
  std::vector<Eigen::Vector3d> then, internal;
  if (last_dt_ > 0) then.resize(m.nodes.size()), internal.resize(m.nodes.size());
  std::vector<Eigen::Vector3d> points;
  std::vector<double> weights;
  for (std::size_t g = 0; g < m.grains.size(); ++g) {
    const Grain& grain = m.grains[g];
    if (grain.kind == GrainKind::rigid) {
      out[g] = grain_stress(g);
      continue;
    }
    if (!(last_dt_ > 0)) {  // no step since the start, a stop or an old checkpoint: the forces are unknown
      out[g].setConstant(std::numeric_limits<double>::quiet_NaN());
      continue;
    }
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    double mass = 0;
    for (std::uint32_t i = grain.node_begin; i < grain.node_end; ++i) {
      then[i] = state_.x[i] - last_dt_ * state_.v[i];
      internal[i].setZero();
      centroid += mass_[i] * then[i], mass += mass_[i];
    }
    centroid /= mass;
    if (!options_.implicit_grains) elements_.add_internal_forces(then, grain.element_begin, grain.element_end, internal);  // -f_int
    Eigen::Matrix3d moment = Eigen::Matrix3d::Zero();
    for (std::uint32_t i = grain.node_begin; i < grain.node_end; ++i)
      moment += (then[i] - centroid) * (force_[i] - internal[i]).transpose();
    double volume = 0;  // at x_n: sum_q w_q det F_q
    for (std::uint32_t e = grain.element_begin; e < grain.element_end; ++e) {
      map_rule(m, e, stiffness_rule(m.nodes_of(e)), points, weights);
      const std::vector<Eigen::Matrix3d> F = elements_.deformation_gradient(then, e);
      for (std::size_t q = 0; q < F.size(); ++q) volume += weights[q] * F[q].determinant();
    }
    out[g] = love_weber(moment, volume);
  }
  return out;
}

Eigen::Matrix3d Solver::element_stress(std::size_t e) const {
  if (elements_.is_elastic(e)) return elements_.average_cauchy_stress(state_.x, e, e + 1);
  const std::size_t g = model_->element_grain[e];
  if (!options_.elastostatic_stress || model_->grains[g].kind != GrainKind::rigid || !contact_) return Eigen::Matrix3d::Zero();
  if (elastostatic_step_ != static_cast<std::int64_t>(state_.step)) {
    if (contact_->node_forces().empty()) return Eigen::Matrix3d::Zero();  // no step yet
    elastostatic_.assign(model_->grains.size(), {});
    parallel_for_each_index(model_->grains.size(), [&](std::size_t k) {
      const Grain& grain = model_->grains[k];
      if (grain.kind != GrainKind::rigid) return;
      try {
        elastostatic_[k] = elastostatic_stresses(k);
      } catch (const DataError&) {  // a mesh in pieces has no static state: NaN, not the end of the run
        elastostatic_[k].assign(grain.element_end - grain.element_begin,
                                Eigen::Matrix3d::Constant(std::numeric_limits<double>::quiet_NaN()));
      }
    });
    elastostatic_step_ = static_cast<std::int64_t>(state_.step);
  }
  return elastostatic_[g][e - model_->grains[g].element_begin];
}

bool Solver::carries_element_stress(std::size_t g) const {
  return model_->grains.at(g).kind != GrainKind::rigid || (options_.elastostatic_stress && contact_);
}

std::span<const ContactRecord> Solver::contacts() const {
  return contact_ ? contact_->contacts() : std::span<const ContactRecord>{};
}

Eigen::Vector3d Solver::platen_force(std::size_t p) const { return platen_force_.at(p); }
double Solver::platen_stiffness(std::size_t p) const { return platen_stiffness_.at(p); }

std::vector<ExactSum*> StepTotals::accumulators() {
  std::vector<ExactSum*> all{&strain, &kinetic, &damped, &gravity_work, &energy_input, &grains, &bad,
                             &contact_elastic, &contact_dissipated, &node_contacts};
  for (ExactSum& p : platens) all.push_back(&p);
  return all;
}

StepTotals Solver::step_totals(std::span<const GrainRole> roles) const {
  StepTotals t;
  const std::size_t grains = model_->grains.size();
  for (std::size_t g = 0; g < grains; ++g) {
    if (!roles.empty() && roles[g] != GrainRole::owned) continue;
    t.strain.add(step_sums_.strain[g]);
    t.kinetic.add(step_sums_.kinetic[g]);
    t.damped.add(step_sums_.damped[g]);
    t.gravity_work.add(step_sums_.gravity_work[g]);
    t.energy_input.add(std::max(step_sums_.gravity_work[g], 0.0));
    t.grains.add(1.0);
    if (step_sums_.bad[g]) t.bad.add(1.0);
  }
  t.platens.resize(4 * model_->platens.size());
  if (!contact_) return t;
  for (const PairStepSum& p : contact_->owned_pair_sums()) {
    t.contact_elastic.add(p.elastic_energy);
    t.contact_dissipated.add(p.dissipated);
    t.node_contacts.add(static_cast<double>(p.node_contacts));
    t.max_overlap = std::max(t.max_overlap, p.overlap);
    if (p.b < grains) continue;
    for (int k = 0; k < 3; ++k) t.platens[4 * (p.b - grains) + k].add(p.force[k]);
    t.platens[4 * (p.b - grains) + 3].add(p.stiffness);
  }
  return t;
}

void Solver::sum_platen_contacts() {
  const std::size_t grains = model_->grains.size();
  std::vector<ExactSum> sums(4 * platen_force_.size());
  for (const ContactRecord& r : contacts())
    if (r.b >= grains) {
      for (int k = 0; k < 3; ++k) sums[4 * (r.b - grains) + k].add(r.force[k]);
      sums[4 * (r.b - grains) + 3].add(r.stiffness);
    }
  for (std::size_t p = 0; p < platen_force_.size(); ++p) {
    for (int k = 0; k < 3; ++k) platen_force_[p][k] = sums[4 * p + k].value();
    platen_stiffness_[p] = sums[4 * p + 3].value();
  }
}

namespace {

/// The grains a checkpoint file holds the rows of: those it names, or every grain.
std::vector<std::uint32_t> part_grains(const io::H5File& f, const std::string& group, std::size_t grains) {
  if (!f.exists(group + "/" + ck::grains)) {
    std::vector<std::uint32_t> every(grains);
    std::iota(every.begin(), every.end(), 0u);
    return every;
  }
  return f.read<std::uint32_t>(group + "/" + ck::grains);
}

}  // namespace

void Solver::save(io::H5File& f, const std::string& group, const CheckpointPart& part) const {
  place_rigid_nodes();  // the file's node positions are the placed ones
  f.ensure_group(group);
  std::vector<std::uint32_t> every;
  if (!part.grains) every.resize(state_.bodies.size()), std::iota(every.begin(), every.end(), 0u);
  const std::vector<std::uint32_t>& grains = part.grains ? *part.grains : every;
  if (part.grains) f.write(group + "/" + ck::grains, grains);
  io::DatasetOptions exact;
  exact.compress = false;
  // The rows of the part's grains: their nodes (grain by grain), bodies and loads.
  const auto& model_grains = model_->grains;
  const bool deformable = std::any_of(model_grains.begin(), model_grains.end(), [](const Grain& g) { return g.kind != GrainKind::rigid; });
  // A whole checkpoint's nodes are in model order; a part's, grain by grain.
  std::vector<Eigen::Vector3d> x, v, node_force;
  if (!part.grains) x = state_.x, v = state_.v, node_force = deformable ? force_ : node_force;
  std::vector<double> bodies, loads;
  for (std::uint32_t g : grains) {
    const Grain& grain = model_grains.at(g);
    if (part.grains) {
      x.insert(x.end(), state_.x.begin() + grain.node_begin, state_.x.begin() + grain.node_end);
      v.insert(v.end(), state_.v.begin() + grain.node_begin, state_.v.begin() + grain.node_end);
      if (deformable) node_force.insert(node_force.end(), force_.begin() + grain.node_begin, force_.begin() + grain.node_end);
    }
    const RigidBodyState& b = state_.bodies[g];
    const auto& q = b.orientation.coeffs();  // x, y, z, w
    bodies.insert(bodies.end(), {b.position[0], b.position[1], b.position[2], q[3], q[0], q[1], q[2], b.velocity[0],
                                 b.velocity[1], b.velocity[2], b.angular_momentum[0], b.angular_momentum[1],
                                 b.angular_momentum[2]});
    // A frame written before the next step reads the rigid grains' loads (their Love-Weber stress).
    const RigidLoad& l = rigid_loads_[g];
    loads.insert(loads.end(), {l.force[0], l.force[1], l.force[2]});
    for (int r = 0; r < 3; ++r) loads.insert(loads.end(), {l.moment(r, 0), l.moment(r, 1), l.moment(r, 2)});
  }
  write_vectors(f, group + "/" + ck::node_position, x);
  write_vectors(f, group + "/" + ck::node_velocity, v);
  f.write(group + "/" + ck::bodies, bodies.data(), {grains.size(), 13}, exact);
  f.write(group + "/" + ck::rigid_loads, loads.data(), {grains.size(), 12}, exact);
  // Deformable grains' Love-Weber stress reads the last step's node forces (love_weber_stresses).
  if (deformable) write_vectors(f, group + "/" + ck::node_force, node_force);
  if (part.shared) {
    f.set_attr(group, ck::step, static_cast<long long>(state_.step));
    f.set_attr(group, ck::time, state_.time);
    f.set_attr(group, ck::dissipated, state_.dissipated);
    f.set_attr(group, ck::external_work, state_.external_work);
    f.set_attr(group, ck::energy_input, state_.energy_input);
    std::vector<double> platens;
    for (const PlatenState& p : state_.platens)
      platens.insert(platens.end(), {p.point[0], p.point[1], p.point[2], p.normal[0], p.normal[1], p.normal[2], p.velocity[0],
                                     p.velocity[1], p.velocity[2], p.friction});
    f.write(group + "/" + ck::platens, platens.data(), {state_.platens.size(), 10}, exact);
    // A servo reads the last step's platen forces before the next step.
    write_vectors(f, group + "/" + ck::platen_force, platen_force_);
    if (deformable) f.set_attr(group, ck::last_time_step, last_dt_);
    if (boundary_) boundary_->save(f, group + "/" + ck::boundary);
  }
  if (contact_) contact_->save(f, group + "/" + ck::contact, part);
}

void Solver::load(const io::H5File& f, const std::string& group) {
  const io::H5File* one[] = {&f};
  load(one, group);
}

void Solver::load(std::span<const io::H5File* const> files, const std::string& group) {
  const io::H5File& f = *files.front();  // the shared state's
  const auto misfit = [&](const io::H5File& file, const std::string& name) {
    return DataError(file.path().string() + ": checkpoint " + group + "/" + name + " does not fit this model; restart with the scene that wrote it");
  };
  const auto need = [&](const io::H5File& file, const std::string& name, std::size_t size) {
    auto v = file.read<double>(group + "/" + name);
    if (v.size() != size) throw misfit(file, name);
    return v;
  };
  const auto& model_grains = model_->grains;
  const bool deformable = std::any_of(model_grains.begin(), model_grains.end(), [](const Grain& g) { return g.kind != GrainKind::rigid; });
  SolverState s;
  s.step = static_cast<std::uint64_t>(f.attr_int(group, ck::step).value_or(0));
  s.time = f.attr_double(group, ck::time);
  s.dissipated = f.attr_double(group, ck::dissipated);
  s.external_work = f.attr_double(group, ck::external_work);
  s.energy_input = f.attr_double(group, ck::energy_input);
  s.x = state_.x;
  s.v = state_.v;
  s.bodies = state_.bodies;
  std::vector<RigidLoad> rigid_loads(rigid_loads_.size());
  const bool has_forces = f.exists(group + "/" + ck::node_force);
  std::vector<Eigen::Vector3d> node_force(force_.size(), Eigen::Vector3d::Zero());
  // Every grain's rows from the one file that holds them.
  std::vector<char> seen(model_grains.size(), 0);
  for (const io::H5File* part : files) {
    const bool whole = !part->exists(group + "/" + ck::grains);
    const std::vector<std::uint32_t> grains = part_grains(*part, group, model_grains.size());
    std::size_t nodes = 0;
    for (std::uint32_t g : grains) {
      if (g >= model_grains.size() || seen[g]++)
        throw DataError(fmt::format("{}: checkpoint {} names grain {} {}; restart with the checkpoint's own files", part->path().string(),
                                    group, g, g >= model_grains.size() ? "of a model of " + std::to_string(model_grains.size()) + " grains" : "that another of its files holds"));
      nodes += model_grains[g].node_end - model_grains[g].node_begin;
    }
    if (whole) nodes = state_.x.size();
    const auto x = read_vectors(*part, group + "/" + ck::node_position, nodes);
    const auto v = read_vectors(*part, group + "/" + ck::node_velocity, nodes);
    const auto forces = has_forces ? read_vectors(*part, group + "/" + ck::node_force, nodes) : std::vector<Eigen::Vector3d>();
    const auto bodies = need(*part, ck::bodies, 13 * grains.size());
    // Checkpoints written before the loads were kept have none (zero loads).
    const auto loads = part->exists(group + "/" + ck::rigid_loads) ? need(*part, ck::rigid_loads, 12 * grains.size())
                                                                    : std::vector<double>(12 * grains.size(), 0.0);
    std::size_t row = 0;
    for (std::size_t k = 0; k < grains.size(); ++k) {
      const Grain& grain = model_grains[grains[k]];
      for (std::uint32_t i = grain.node_begin; i < grain.node_end; ++i, ++row) {
        const std::size_t from = whole ? i : row;
        s.x[i] = x[from];
        s.v[i] = v[from];
        if (has_forces) node_force[i] = forces[from];
      }
      const double* d = bodies.data() + 13 * k;
      s.bodies[grains[k]] = {Eigen::Vector3d(d[0], d[1], d[2]), Eigen::Quaterniond(d[3], d[4], d[5], d[6]),
                             Eigen::Vector3d(d[7], d[8], d[9]), Eigen::Vector3d(d[10], d[11], d[12])};
      const double* l = loads.data() + 12 * k;
      rigid_loads[grains[k]].force = Eigen::Vector3d(l[0], l[1], l[2]);
      rigid_loads[grains[k]].moment = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(l + 3);
    }
  }
  if (const auto missing = std::find(seen.begin(), seen.end(), 0); missing != seen.end())
    throw DataError(fmt::format("{}: checkpoint {} holds no state of grain {} in any of its files; restart with all of the checkpoint's files",
                                f.path().string(), group, missing - seen.begin()));
  const auto platens = need(f, ck::platens, 10 * state_.platens.size());
  for (std::size_t p = 0; p < state_.platens.size(); ++p) {
    const double* d = platens.data() + 10 * p;
    s.platens.push_back({Eigen::Vector3d(d[0], d[1], d[2]), Eigen::Vector3d(d[3], d[4], d[5]), Eigen::Vector3d(d[6], d[7], d[8]), d[9]});
  }
  const bool has_boundary = f.exists(group + "/" + ck::boundary);
  if (has_boundary != (boundary_ != nullptr))
    throw DataError(f.path().string() + ": checkpoint " + group + (has_boundary ? " holds a sample boundary (wall, membrane)"
                                                                                : " holds no sample boundary") +
                    " and this run " + (boundary_ ? "has one" : "has none") + "; restart with the scene that wrote it");
  const auto platen_force = f.exists(group + "/" + ck::platen_force)
                                ? read_vectors(f, group + "/" + ck::platen_force, platen_force_.size())
                                : std::vector<Eigen::Vector3d>(platen_force_.size(), Eigen::Vector3d::Zero());
  if (contact_) contact_->load(files, group + "/" + ck::contact);
  if (boundary_) boundary_->load(f, group + "/" + ck::boundary);
  state_ = std::move(s);
  force_ = std::move(node_force);
  last_dt_ = has_forces && deformable ? f.attr_double(group, ck::last_time_step) : 0.0;
  sum_platen_contacts();          // the stiffness, from the restored records
  platen_force_ = platen_force;  // as saved: checkpoints of older runs hold no records
  rigid_loads_ = std::move(rigid_loads);
  rigid_nodes_stale_ = true;
}

// A run split over ranks (docs/fdemrun.md, across machines).

void Solver::set_rank_share(RankShare* share) {
  if (share && !contact_) throw UsageError("a run split over ranks needs contact: its ranks meet where grains touch");
  if (!share && share_) contact_->set_grain_roles({});  // every grain in contact again
  share_ = share;
}

void Solver::set_node_state(std::uint32_t node, const Eigen::Vector3d& x, const Eigen::Vector3d& v) {
  state_.x.at(node) = x;
  state_.v.at(node) = v;
}

void Solver::set_rigid_state(std::size_t g, const RigidBodyState& state) {
  if (model_->grains.at(g).kind != GrainKind::rigid)
    throw UsageError(fmt::format("grain {} is not rigid: only a rigid grain's state is set whole", g));
  RigidBodyState& held = state_.bodies[g];
  // The same state (a ghost refreshed, or a gathering before any step) leaves the placed nodes as
  // they are: placing them again would round the initial node velocities differently.
  if (held.position == state.position && held.orientation.coeffs() == state.orientation.coeffs() &&
      held.velocity == state.velocity && held.angular_momentum == state.angular_momentum)
    return;
  held = state;
  rigid_nodes_stale_ = true;
}

}  // namespace graintwin::fdem
