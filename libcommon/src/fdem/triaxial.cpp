#include "graintwin/fdem/triaxial.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "graintwin/core/error.hpp"
#include "graintwin/core/statistics.hpp"
#include "graintwin/fdem/vector_io.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/schema.hpp"

namespace graintwin::fdem {
namespace ck = schema::fdem_checkpoint;
namespace {

constexpr double kPi = std::numbers::pi;
/// Rings of membrane beyond each platen (clamped to it).
constexpr int kClampedRings = 2;

bool quasi_static(const StepReport& r) {
  return r.energies.kinetic < kQuasiStaticRatio * (r.energies.contact_elastic + r.energies.strain);
}

}  // namespace

PlatenPair find_platens(const Model& model) {
  std::optional<std::size_t> bottom, top;
  for (std::size_t p = 0; p < model.platens.size(); ++p) {
    const Platen& platen = model.platens[p];
    if (platen.name == kBottomPlaten && platen.normal.normalized().z() > 0.999) bottom = p;
    if (platen.name == kTopPlaten && platen.normal.normalized().z() < -0.999) top = p;
  }
  if (!bottom || !top)
    throw UsageError("a triaxial test needs a platen named 'bottom' with normal +z and one named 'top' with normal -z; "
                     "build the model with shapes2mesh or add them to the scene's [[platens]]");
  return {*bottom, *top};
}

double grains_d50(const Solver& solver) {
  const std::size_t n = solver.model().grains.size();
  std::vector<double> volume(n);
  for (std::size_t g = 0; g < n; ++g) volume[g] = solver.body(g).volume;
  return d50_of_volumes(std::move(volume));
}

TriaxialBoundary::TriaxialBoundary(const Model& model, const TriaxialOptions& options, double d50)
    : options_(options), grain_count_(model.grains.size()) {
  if (!model.sample)
    throw UsageError("a triaxial test needs the model's sample cylinder; build the model with shapes2mesh or give [sample]");
  if (!(options.confining_pressure > 0) || !std::isfinite(options.confining_pressure))
    throw UsageError("the confining pressure must be positive; the reference test uses 300 kPa");
  bond_stiffness(options.membrane);  // refuses nu > 1/3 before any work
  const SampleCylinder& s = *model.sample;
  // The wall starts at the sample radius or just outside the outermost grain, whichever is larger:
  // a CT sample's fitted radius can cut into the outer grains, and a wall starting inside them
  // would fling them inwards (the servo brings it in from there).
  double outermost = 0;
  for (const Eigen::Vector3d& p : model.nodes) outermost = std::max(outermost, (p.head<2>() - s.axis_xy).norm());
  wall_ = {s.axis_xy, std::max(s.radius, outermost), 0.0};
  z_bottom_ = s.z_min;
  z_top_ = s.z_max;
  ball_radius_ = options.ball_radius > 0 ? options.ball_radius : choose_ball_radius(s.radius, d50);
}

void TriaxialBoundary::set_platens(double z_bottom, double z_top, double v_bottom, double v_top) {
  z_bottom_ = z_bottom;
  z_top_ = z_top;
  v_bottom_ = v_bottom;
  v_top_ = v_top;
}

double TriaxialBoundary::wall_area() const { return 2 * kPi * wall_.radius * (z_top_ - z_bottom_); }
double TriaxialBoundary::wall_stress() const { return wall_force_ / wall_area(); }

void TriaxialBoundary::build_membrane_lattice(double centre_radius, double z_min, double z_max, double density_scaling) {
  membrane_ = build_membrane(options_.membrane, wall_.axis_xy, centre_radius, z_min, z_max, ball_radius_);
  membrane_frame_ = {centre_radius, z_min, z_max};
  density_scaling_ = density_scaling;
  membrane_->material.density *= density_scaling;
  membrane_->ball_mass *= density_scaling;
  membrane_->ball_inertia *= density_scaling;
  membrane_state_ = rest_state(*membrane_);
  ++membrane_moves_;
  const std::size_t n = membrane_->balls();
  motion_.assign(n, BallMotion::free);
  clamp_group_.assign(n, 0);
  ball_force_.assign(n, Eigen::Vector3d::Zero());
  ball_moment_.assign(n, Eigen::Vector3d::Zero());
  pressure_force_.assign(n, Eigen::Vector3d::Zero());
}

void TriaxialBoundary::install_membrane(const ContactModel& contact, double dt) {
  if (membrane_) return;
  const double r = ball_radius_;
  const double ring_step = std::sqrt(3.0) * r;  // about: the lattice fixes it from the circumference
  const double z_min = z_bottom_ - (kClampedRings + 0.5) * ring_step, z_max = z_top_ + (kClampedRings + 0.5) * ring_step;
  build_membrane_lattice(wall_.radius + r, z_min, z_max, 1.0);
  // Bond and ball-contact limits both scale with sqrt(ball mass): one factor lifts both to dt.
  const double own_step = stable_time_step(contact);
  if (own_step < dt) build_membrane_lattice(wall_.radius + r, z_min, z_max, 1.0001 * (dt / own_step) * (dt / own_step));
  for (std::size_t b = 0; b < membrane_->balls(); ++b) {
    const double z = membrane_->reference[b].z();
    if (z < z_bottom_) motion_[b] = BallMotion::clamped, clamp_group_[b] = 0;
    if (z > z_top_) motion_[b] = BallMotion::clamped, clamp_group_[b] = 1;
  }
  wall_force_ = 0;
  wall_stiffness_ = 0;
  membrane_started_ = false;
}

void TriaxialBoundary::set_membrane_fixed(bool fixed) {
  if (!membrane_) throw UsageError("install the membrane before fixing or releasing it");
  for (std::size_t b = 0; b < membrane_->balls(); ++b) {
    const double z = membrane_state_.x[b].z();
    const bool beyond = z < z_bottom_ || z > z_top_;
    motion_[b] = fixed || beyond ? BallMotion::clamped : BallMotion::free;
    clamp_group_[b] = fixed && !beyond ? 2 : z < z_bottom_ ? 0 : 1;
  }
}

const EnclosedVolumes& TriaxialBoundary::enclosed() const {
  if (volume_cache_.moves != membrane_moves_ || volume_cache_.z_bottom != z_bottom_ || volume_cache_.z_top != z_top_)
    volume_cache_ = {membrane_moves_, z_bottom_, z_top_, enclosed_volumes(*membrane_, membrane_state_.x, z_bottom_, z_top_)};
  return volume_cache_.volumes;
}

double TriaxialBoundary::volume() const {
  if (!membrane_) return kPi * wall_.radius * wall_.radius * (z_top_ - z_bottom_);
  return enclosed().volume;
}

double TriaxialBoundary::volume_radial() const {
  if (!membrane_) return volume();
  return enclosed().radial;
}

namespace {

/// Rows per membrane contact (force and energies; moment and overlap; spring) and where the
/// membrane's rows begin, after the wall's (one per grain).
constexpr std::uint64_t kBallContactRows = 3;

}  // namespace

StepRows TriaxialBoundary::add_contact_forces(ContactModel& contact, std::span<const Eigen::Vector3d> x,
                                              std::span<const Eigen::Vector3d> v, double dt, std::span<Eigen::Vector3d> f) {
  StepRows rows;
  const auto add = [&rows](std::uint64_t key, std::initializer_list<double> values) {
    rows.keys.push_back(key);
    rows.values.insert(rows.values.end(), values);
  };
  if (!membrane_) {
    for (const WallContactSum& g : contact.add_wall_forces(x, v, wall_, dt, f))
      add(g.grain, {g.radial_force, g.radial_stiffness, g.elastic_energy, g.dissipated, static_cast<double>(g.contacts)});
    return rows;
  }
  const MembraneState& s = membrane_state_;
  const std::uint64_t grains = grain_count_;
  for (const BallContact& c :
       contact.add_ball_forces(x, v, s.x, s.v, s.spin, {membrane_->ball_radius, membrane_->ball_mass, options_.membrane_friction},
                               dt, f)) {
    const std::uint64_t key = grains + kBallContactRows * (c.ball * grains + c.grain);
    add(key, {c.force.x(), c.force.y(), c.force.z(), c.elastic_energy, c.dissipated});
    add(key + 1, {c.moment.x(), c.moment.y(), c.moment.z(), c.overlap, 0.0});
    add(key + 2, {c.spring.x(), c.spring.y(), c.spring.z(), 0.0, 0.0});
  }
  return rows;
}

std::vector<BallContact> TriaxialBoundary::ball_contacts(const StepRows& rows) const {
  const std::uint64_t grains = grain_count_, balls = membrane_->balls();
  if (rows.keys.size() % kBallContactRows != 0)
    throw DataError("the membrane's contact rows do not come in threes; the ranks must run the same program");
  std::vector<BallContact> contacts(rows.keys.size() / kBallContactRows);
  for (std::size_t i = 0; i < contacts.size(); ++i) {
    const std::uint64_t key = rows.keys[kBallContactRows * i];
    const std::uint64_t pair = (key - grains) / kBallContactRows;
    if (key < grains || (key - grains) % kBallContactRows != 0 || pair / grains >= balls ||
        rows.keys[kBallContactRows * i + 1] != key + 1 || rows.keys[kBallContactRows * i + 2] != key + 2)
      throw DataError(fmt::format("a membrane contact came under key {}, which names no ball of {} and grain of {}; the "
                                  "ranks must run the same model and membrane",
                                  key, balls, grains));
    const double* r = rows.values.data() + kTermColumns * kBallContactRows * i;
    BallContact& c = contacts[i];
    c.ball = static_cast<std::uint32_t>(pair / grains);
    c.grain = static_cast<std::uint32_t>(pair % grains);
    c.force = {r[0], r[1], r[2]};
    c.elastic_energy = r[3];
    c.dissipated = r[4];
    c.moment = {r[5], r[6], r[7]};
    c.overlap = r[8];
    c.spring = {r[10], r[11], r[12]};
  }
  return contacts;
}

BoundaryStep TriaxialBoundary::finish(ContactModel& contact, const StepRows& rows, double dt, double damping, bool first) {
  BoundaryStep out;
  if (!membrane_) {
    std::vector<WallContactSum> grains(rows.keys.size());
    for (std::size_t i = 0; i < grains.size(); ++i) {
      const double* r = rows.values.data() + kTermColumns * i;
      grains[i] = {static_cast<std::uint32_t>(rows.keys[i]), static_cast<std::uint32_t>(r[4]), r[0], r[1], r[2], r[3]};
    }
    const BoundaryContactStats s = wall_contact_stats(grains);
    last_contact_ = s;
    wall_force_ = s.radial_force;
    wall_stiffness_ = s.radial_stiffness;
    out.elastic = s.elastic_energy;
    out.dissipated = s.dissipated;
    out.work = -s.radial_force * wall_.radial_velocity * dt;  // the wall pushes inwards
    wall_.radius += dt * wall_.radial_velocity;
    return out;
  }
  const Membrane& m = *membrane_;
  MembraneState& s = membrane_state_;
  ++membrane_moves_;
  std::fill(ball_force_.begin(), ball_force_.end(), Eigen::Vector3d::Zero());
  std::fill(ball_moment_.begin(), ball_moment_.end(), Eigen::Vector3d::Zero());
  const std::vector<BallContact> contacts = ball_contacts(rows);
  contact.set_ball_history(contacts);  // every rank's springs: a grain's next owner finds its own
  const BoundaryContactStats c = add_ball_contacts(contacts, ball_force_, ball_moment_);
  out.elastic = c.elastic_energy + add_bond_forces(m, s, dt, ball_force_, ball_moment_);
  out.dissipated = c.dissipated;
  last_contact_ = c;
  std::fill(pressure_force_.begin(), pressure_force_.end(), Eigen::Vector3d::Zero());
  add_pressure_forces(m, s.x, pressure_, pressure_force_);
  for (std::size_t b = 0; b < m.balls(); ++b) ball_force_[b] += pressure_force_[b];
  before_ = s.x;
  // Clamp groups: 0 with the bottom platen, 1 with the top one, 2 held still (a fixed membrane).
  const Eigen::Vector3d clamp[3] = {Eigen::Vector3d(0, 0, v_bottom_), Eigen::Vector3d(0, 0, v_top_), Eigen::Vector3d::Zero()};
  out.kinetic = integrate_balls(m, s, ball_force_, ball_moment_, dt, damping, motion_, clamp_group_, clamp,
                                first || !membrane_started_);
  membrane_started_ = true;
  for (std::size_t b = 0; b < m.balls(); ++b)
    if (motion_[b] == BallMotion::free) out.work += pressure_force_[b].dot(s.x[b] - before_[b]);
  return out;
}

double TriaxialBoundary::stable_time_step(const ContactModel& contact) const {
  if (!membrane_) return std::numeric_limits<double>::infinity();
  return std::min(membrane_stable_time_step(*membrane_),
                  contact.ball_stable_time_step({membrane_->ball_radius, membrane_->ball_mass, options_.membrane_friction}));
}

void TriaxialBoundary::save(io::H5File& file, const std::string& group) const {
  file.ensure_group(group);
  file.set_attr(group, ck::wall, std::vector<double>{wall_.radius, wall_.radial_velocity, wall_force_, wall_stiffness_});
  file.set_attr(group, ck::boundary_platens, std::vector<double>{z_bottom_, z_top_, v_bottom_, v_top_});
  file.set_attr(group, ck::pressure, pressure_);
  file.set_attr(group, ck::ball_radius, ball_radius_);
  if (!membrane_) return;
  file.set_attr(group, ck::membrane_frame, std::vector<double>{membrane_frame_[0], membrane_frame_[1], membrane_frame_[2],
                                                             density_scaling_, membrane_started_ ? 1.0 : 0.0});
  write_vectors(file, group + "/" + ck::ball_position, membrane_state_.x);
  write_vectors(file, group + "/" + ck::ball_velocity, membrane_state_.v);
  write_vectors(file, group + "/" + ck::ball_spin, membrane_state_.spin);
  write_vectors(file, group + "/" + ck::bond_shear, membrane_state_.shear);
  std::vector<std::uint8_t> motion(motion_.size());
  for (std::size_t b = 0; b < motion_.size(); ++b) motion[b] = static_cast<std::uint8_t>(motion_[b]);
  file.write(group + "/" + ck::ball_motion, motion);
  file.write(group + "/" + ck::ball_clamp_group, clamp_group_);
}

void TriaxialBoundary::load(const io::H5File& file, const std::string& group) {
  const auto values = [&](const char* name, std::size_t count) {
    std::vector<double> v = file.attr_doubles(group, name);
    if (v.size() != count)
      throw DataError(file.path().string() + ": checkpoint " + group + " has no '" + name +
                      "' of the sample boundary; restart with the scene that wrote it");
    return v;
  };
  if (values(ck::ball_radius, 1)[0] != ball_radius_)
    throw DataError(file.path().string() + ": checkpoint " + group + " was written with another membrane ball radius; " +
                    "restart with the scene that wrote it");
  // Checkpoints written before the wall's stiffness was kept hold 3 values (stiffness 0).
  const auto wall = file.attr_doubles(group, ck::wall).size() == 3 ? values(ck::wall, 3) : values(ck::wall, 4);
  const auto platens = values(ck::boundary_platens, 4);
  wall_.radius = wall[0];
  wall_.radial_velocity = wall[1];
  wall_force_ = wall[2];
  wall_stiffness_ = wall.size() == 4 ? wall[3] : 0.0;
  if (!(wall_stiffness_ >= 0) || !std::isfinite(wall_stiffness_))
    throw DataError(file.path().string() + ": checkpoint " + group + " has a wall stiffness of " +
                    std::to_string(wall_stiffness_) + " N/m (must be finite and >= 0); restart with the scene that wrote it");
  set_platens(platens[0], platens[1], platens[2], platens[3]);
  pressure_ = values(ck::pressure, 1)[0];
  membrane_.reset();
  last_contact_ = {};
  if (!file.has_attr(group, ck::membrane_frame)) return;
  const auto frame = values(ck::membrane_frame, 5);
  build_membrane_lattice(frame[0], frame[1], frame[2], frame[3]);
  membrane_started_ = frame[4] != 0;
  const std::size_t balls = membrane_->balls();
  membrane_state_.x = read_vectors(file, group + "/" + ck::ball_position, balls);
  membrane_state_.v = read_vectors(file, group + "/" + ck::ball_velocity, balls);
  membrane_state_.spin = read_vectors(file, group + "/" + ck::ball_spin, balls);
  membrane_state_.shear = read_vectors(file, group + "/" + ck::bond_shear, membrane_->bonds.size());
  ++membrane_moves_;
  const auto motion = file.read<std::uint8_t>(group + "/" + ck::ball_motion);
  clamp_group_ = file.read<std::uint8_t>(group + "/" + ck::ball_clamp_group);
  if (motion.size() != balls || clamp_group_.size() != balls)
    throw DataError(file.path().string() + ": checkpoint " + group + " does not hold the clamps of " + std::to_string(balls) +
                    " membrane balls; restart with the scene that wrote it");
  for (std::size_t b = 0; b < balls; ++b) {
    if (motion[b] > static_cast<std::uint8_t>(BallMotion::clamped) || clamp_group_[b] > 2)
      throw DataError(file.path().string() + ": checkpoint " + group + " has an unknown clamp of membrane ball " +
                      std::to_string(b) + "; restart with the scene that wrote it");
    motion_[b] = static_cast<BallMotion>(motion[b]);
  }
}

TriaxialMeasure measure(const Solver& solver, const TriaxialBoundary& boundary, const PlatenPair& platens) {
  TriaxialMeasure m;
  const auto& state = solver.platens();
  m.height = state[platens.top].point.z() - state[platens.bottom].point.z();
  m.volume = boundary.volume();
  m.volume_radial = boundary.volume_radial();
  // The grains push the bottom platen down and the top one up; their mean over the mean section.
  const double force = 0.5 * (solver.platen_force(platens.top).z() - solver.platen_force(platens.bottom).z());
  m.axial_stress = force / (m.volume / m.height);
  m.lateral_stress = boundary.has_membrane() ? boundary.pressure() : boundary.wall_stress();
  return m;
}

double inertial_number(double strain_rate, double d50, double density, double mean_stress) {
  return strain_rate * d50 * std::sqrt(density / mean_stress);
}

double strain_rate_of(double inertial_number, double d50, double density, double mean_stress) {
  return inertial_number / (d50 * std::sqrt(density / mean_stress));
}

double servo_velocity(double stress, double target, double fastest) {
  return fastest * std::clamp((stress - target) / (0.1 * target), -1.0, 1.0);
}

double stiffness_limited_velocity(double velocity, double force_error, double stiffness, double dt) {
  if (!(stiffness > 0)) return velocity;
  const double stiffest = kServoStepShare * std::abs(force_error) / (stiffness * dt);
  return std::clamp(velocity, -stiffest, stiffest);
}

namespace {

/// Moves both platens apart at +-velocity / 2 (positive: opening) and tells the boundary.
void drive_platens(Solver& solver, TriaxialBoundary& boundary, const PlatenPair& platens, double velocity) {
  const auto& state = solver.platens();
  solver.set_platen_velocity(platens.bottom, Eigen::Vector3d(0, 0, -0.5 * velocity));
  solver.set_platen_velocity(platens.top, Eigen::Vector3d(0, 0, 0.5 * velocity));
  boundary.set_platens(state[platens.bottom].point.z(), state[platens.top].point.z(), -0.5 * velocity, 0.5 * velocity);
}

/// servo_velocity of the platens, no faster than stiffness_limited_velocity allows with the
/// grains against them (each platen moves at half the velocity).
double platen_servo_velocity(const Solver& solver, const PlatenPair& platens, const TriaxialMeasure& m, double target,
                             double fastest, double dt) {
  const double stiffness = solver.platen_stiffness(platens.bottom) + solver.platen_stiffness(platens.top);
  const double force_error = (m.axial_stress - target) * m.volume / m.height;
  return stiffness_limited_velocity(servo_velocity(m.axial_stress, target, fastest), force_error, 0.5 * stiffness, dt);
}

/// servo_velocity of the wall, no faster than stiffness_limited_velocity allows with the grains
/// against it.
double wall_servo_velocity(const TriaxialBoundary& boundary, double target, double fastest, double dt) {
  const double force_error = (boundary.wall_stress() - target) * boundary.wall_area();
  return stiffness_limited_velocity(servo_velocity(boundary.wall_stress(), target, fastest), force_error,
                                    boundary.wall_stiffness(), dt);
}

double servo_rate(const Solver& solver, const TriaxialOptions& options) {
  return strain_rate_of(options.servo_inertial_number, grains_d50(solver), solver.model().materials.front().density,
                        options.confining_pressure);
}

/// The caller's progress, or `local` when it passes none.
TriaxialProgress& progress_or(TriaxialProgress* progress, TriaxialProgress& local) { return progress ? *progress : local; }

}  // namespace

std::size_t consolidate_in_wall(Solver& solver, TriaxialBoundary& boundary, const TriaxialOptions& options, double dt,
                                std::size_t max_steps, const TriaxialObserver& on_step, TriaxialProgress* progress) {
  if (boundary.has_membrane()) throw UsageError("consolidation in the wall must come before the membrane is installed");
  TriaxialProgress local;
  TriaxialProgress& p = progress_or(progress, local);
  if (p.phase != TriaxialProgress::Phase::wall) p = {};
  const PlatenPair platens = find_platens(solver.model());
  const double sigma = options.confining_pressure, rate = servo_rate(solver, options);
  while (p.step < max_steps && p.settled < kSettledSteps) {
    const TriaxialMeasure m = measure(solver, boundary, platens);
    const double radial = wall_servo_velocity(boundary, sigma, rate * boundary.wall().radius, dt);
    drive_platens(solver, boundary, platens, platen_servo_velocity(solver, platens, m, sigma, rate * m.height, dt));
    boundary.set_wall_velocity(radial);
    const StepReport r = solver.step(dt);
    const bool stresses = std::abs(m.axial_stress / sigma - 1) < options.stress_tolerance &&
                          std::abs(boundary.wall_stress() / sigma - 1) < options.stress_tolerance;
    ++p.step;
    p.settled = stresses && quasi_static(r) ? p.settled + 1 : 0;
    if (on_step) on_step(measure(solver, boundary, platens), r);
  }
  drive_platens(solver, boundary, platens, 0.0);
  boundary.set_wall_velocity(0);
  if (p.settled < kSettledSteps)
    throw DataError(fmt::format("isotropic consolidation to {:.4g} kPa did not settle in {} steps (axial {:.4g} kPa, "
                                "lateral {:.4g} kPa); allow more steps or a larger servo inertial number",
                                1e-3 * sigma, max_steps, 1e-3 * measure(solver, boundary, platens).axial_stress,
                                1e-3 * boundary.wall_stress()));
  return p.step;
}

std::size_t consolidate_in_membrane(Solver& solver, TriaxialBoundary& boundary, const TriaxialOptions& options,
                                    double dt, std::size_t ramp_steps, std::size_t max_steps,
                                    const TriaxialObserver& on_step, TriaxialProgress* progress) {
  if (!solver.contact_model()) throw UsageError("the membrane acts through contact; run with contact on");
  using Phase = TriaxialProgress::Phase;
  TriaxialProgress local;
  TriaxialProgress& p = progress_or(progress, local);
  const PlatenPair platens = find_platens(solver.model());
  const double sigma = options.confining_pressure, rate = servo_rate(solver, options);
  if (p.phase != Phase::membrane_fixed && p.phase != Phase::membrane_released) {
    p = {Phase::membrane_fixed};
    solver.stop_grains();
    drive_platens(solver, boundary, platens, 0.0);
    boundary.install_membrane(*solver.contact_model(), dt);
    boundary.set_membrane_fixed(true);
    boundary.set_pressure(0);
  }
  // The grains settle against the fixed membrane (the wall's load is gone: they relax a little).
  if (p.phase == Phase::membrane_fixed) {
    while (p.step < max_steps && p.settled < kSettledSteps) {
      const StepReport r = solver.step(dt);
      ++p.step;
      p.settled = quasi_static(r) ? p.settled + 1 : 0;
      if (on_step) on_step(measure(solver, boundary, platens), r);
    }
    boundary.set_membrane_fixed(false);
    p.phase = Phase::membrane_released;
    p.settled = 0;
    p.released = p.step;
  }
  while (p.step < max_steps && p.settled < kSettledSteps) {
    const double ramp =
        ramp_steps ? std::min(1.0, static_cast<double>(p.step - p.released + 1) / static_cast<double>(ramp_steps)) : 1.0;
    boundary.set_pressure(ramp * sigma);
    const TriaxialMeasure m = measure(solver, boundary, platens);
    drive_platens(solver, boundary, platens, platen_servo_velocity(solver, platens, m, sigma, rate * m.height, dt));
    const StepReport r = solver.step(dt);
    const bool stress = ramp == 1.0 && std::abs(m.axial_stress / sigma - 1) < options.stress_tolerance;
    ++p.step;
    p.settled = stress && quasi_static(r) ? p.settled + 1 : 0;
    if (on_step) on_step(measure(solver, boundary, platens), r);
  }
  drive_platens(solver, boundary, platens, 0.0);
  if (p.settled < kSettledSteps)
    throw DataError(fmt::format("consolidation in the membrane to {:.4g} kPa did not settle in {} steps (axial {:.4g} kPa); "
                                "allow more steps or a larger servo inertial number",
                                1e-3 * sigma, max_steps, 1e-3 * measure(solver, boundary, platens).axial_stress));
  return p.step;
}

std::size_t shear(Solver& solver, TriaxialBoundary& boundary, const TriaxialOptions& options,
                  const ShearOptions& shearing, double dt, const TriaxialObserver& on_step, TriaxialProgress* progress) {
  if (!(shearing.strain_rate > 0) || !(shearing.target_axial_strain > 0))
    throw UsageError("shearing needs a positive strain rate and target axial strain");
  TriaxialProgress local;
  TriaxialProgress& p = progress_or(progress, local);
  const PlatenPair platens = find_platens(solver.model());
  if (p.phase != TriaxialProgress::Phase::shearing)
    p = {TriaxialProgress::Phase::shearing, 0, 0, 0, measure(solver, boundary, platens).height};
  const double h0 = p.h0, wall_rate = servo_rate(solver, options);
  const double ramp_steps = std::ceil(shearing.ramp_strain / (shearing.strain_rate * dt));
  for (;;) {
    const TriaxialMeasure m = measure(solver, boundary, platens);
    if (std::log(h0 / m.height) >= shearing.target_axial_strain) break;
    const double speed = ramp_steps > 0 ? std::min(1.0, double(p.step + 1) / ramp_steps) : 1.0;
    drive_platens(solver, boundary, platens, -speed * shearing.strain_rate * h0);
    if (!boundary.has_membrane())
      boundary.set_wall_velocity(
          wall_servo_velocity(boundary, options.confining_pressure, wall_rate * boundary.wall().radius, dt));
    const StepReport r = solver.step(dt);
    ++p.step;
    if (on_step) on_step(measure(solver, boundary, platens), r);
  }
  drive_platens(solver, boundary, platens, 0.0);
  boundary.set_wall_velocity(0);
  return p.step;
}

}  // namespace graintwin::fdem
