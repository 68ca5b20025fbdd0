#pragma once
// The triaxial test's lateral boundary and its control (docs/methods.md, FDEM and flexible membrane): a rigid servo-
// controlled cylindrical wall, then the bonded-ball membrane (fdem/membrane.hpp) carrying the
// confining pressure, with its ends clamped to the platens; servo laws for the wall and the
// platens, and the measurements of the time series (axial and lateral stress, sample volume by
// eq. 27 and eq. 28, log strains). The model must have platens named "bottom" and "top" (normals
// +z and -z) and a sample cylinder (shapes2mesh writes both).
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <functional>
#include <optional>

#include "graintwin/fdem/membrane.hpp"
#include "graintwin/fdem/solver.hpp"

namespace graintwin::fdem {

struct TriaxialOptions {
  double confining_pressure = 300e3;  ///< sigma_3, Pa (the reference experiment, docs/methods.md)
  MembraneMaterial membrane;          ///< latex, docs/methods.md
  double ball_radius = 0;             ///< m; 0 = choose_ball_radius(sample radius, grains' d50)
  double membrane_friction = 0.0;     ///< Coulomb coefficient between membrane balls and grains
  /// Fastest servo motion, as an inertial number I = strain rate x d50 sqrt(rho / sigma_3) of the
  /// sample (quasi-static below 1e-3).
  double servo_inertial_number = 1e-3;
  double stress_tolerance = 0.01;  ///< consolidation: stresses within this share of sigma_3
};

/// The platen pair of a model: indices of "bottom" and "top". UsageError naming what is missing.
struct PlatenPair {
  std::size_t bottom = 0, top = 0;
};
PlatenPair find_platens(const Model& model);

/// d50 of the model's grains (d50_of_volumes: equivalent spheres, by volume), m.
double grains_d50(const Solver& solver);

/// The lateral boundary: first the rigid wall at the sample radius (or just outside the outermost
/// grain node when the grains reach beyond it), then (install_membrane) the membrane. Stepped by
/// the solver (Solver::set_boundary).
class TriaxialBoundary final : public Boundary {
 public:
  TriaxialBoundary(const Model& model, const TriaxialOptions& options, double d50);

  bool has_membrane() const { return membrane_.has_value(); }
  std::size_t bodies() const override { return membrane_ ? membrane_->balls() : 0; }
  const CylinderWallState& wall() const { return wall_; }
  void set_wall_velocity(double radial_velocity) { wall_.radial_velocity = radial_velocity; }
  /// The platens' heights and vertical velocities for this step: the wall's height, the membrane's
  /// clamped rings move with them.
  void set_platens(double z_bottom, double z_top, double v_bottom, double v_top);
  /// Mean radial stress of the grains on the wall in the last step, Pa.
  double wall_stress() const;
  /// The wall's area between the platens, m^2.
  double wall_area() const;
  /// Normal stiffness of the grains' contacts with the wall in the last step, N/m.
  double wall_stiffness() const { return wall_stiffness_; }
  /// Replaces the wall by the membrane: ball centres on the wall's radius plus a ball radius, rings
  /// from two below the bottom platen to two above the top one; the rings beyond the platens are
  /// clamped (radially fixed, moving with their platen). The confining pressure starts at 0. When
  /// the membrane's own stable step (bonds and ball contact) is below the run's `dt`, its density
  /// is scaled up until it is not (density_scaling(): the factor, 1 when none was needed).
  void install_membrane(const ContactModel& contact, double dt);
  double density_scaling() const { return density_scaling_; }
  void set_pressure(double pressure) { pressure_ = pressure; }
  /// Holds every membrane ball where it is (the forming procedure's fixed membrane) or releases
  /// the balls between the platens again.
  void set_membrane_fixed(bool fixed);
  double pressure() const { return pressure_; }
  const Membrane* membrane() const { return membrane_ ? &*membrane_ : nullptr; }
  const MembraneState* membrane_state() const { return membrane_ ? &membrane_state_ : nullptr; }
  /// Sample volume between the platens now, m^3: pi R^2 H inside the wall; eq. 27 inside the membrane.
  double volume() const;
  /// Eq. 28 inside the membrane (the same as volume() inside the wall).
  double volume_radial() const;
  double ball_radius() const { return ball_radius_; }
  /// The wall's or the balls' contacts with the grains in the last step.
  const BoundaryContactStats& last_contact() const { return last_contact_; }

  /// The wall's contacts as one row per touching grain (key: the grain), or the membrane's as
  /// three rows per (ball, grain) contact.
  StepRows add_contact_forces(ContactModel& contact, std::span<const Eigen::Vector3d> x, std::span<const Eigen::Vector3d> v,
                              double dt, std::span<Eigen::Vector3d> f) override;
  /// The wall's force and stiffness from every grain's row, then its radius moves; or the balls'
  /// contact forces from every contact's rows (in (ball, grain) order, as one rank adds them), their
  /// friction history, the bonds and the pressure, then the balls move.
  BoundaryStep finish(ContactModel& contact, const StepRows& rows, double dt, double damping, bool first) override;
  double stable_time_step(const ContactModel& contact) const override;
  /// The wall, the platen heights, the pressure and the membrane (where it was built, its density
  /// scaling, its balls' state, clamps and bond shear); the balls' friction springs are in the
  /// contact history.
  void save(io::H5File& file, const std::string& group) const override;
  void load(const io::H5File& file, const std::string& group) override;

 private:
  /// Builds the membrane's lattice with ball centres on `centre_radius` from z_min to z_max, its
  /// density times `density_scaling`, at rest; sizes the per-ball arrays.
  void build_membrane_lattice(double centre_radius, double z_min, double z_max, double density_scaling);

  /// The membrane's contacts from their rows (add_contact_forces' layout). DataError on rows that
  /// name no ball or grain of this run.
  std::vector<BallContact> ball_contacts(const StepRows& rows) const;

  TriaxialOptions options_;
  std::size_t grain_count_ = 0;  ///< the model's: the membrane's row keys hold (ball, grain)
  CylinderWallState wall_;
  double wall_force_ = 0;      ///< N, last step
  double wall_stiffness_ = 0;  ///< N/m, last step
  BoundaryContactStats last_contact_;
  double z_bottom_ = 0, z_top_ = 0, v_bottom_ = 0, v_top_ = 0;
  double ball_radius_ = 0;
  double pressure_ = 0;
  std::optional<Membrane> membrane_;
  MembraneState membrane_state_;
  /// The enclosed volumes are read several times a step (servo, observer, results row) and cost a
  /// pass over every membrane triangle: they are kept until the balls or the platens move.
  struct VolumeCache {
    std::uint64_t moves = ~std::uint64_t{0};
    double z_bottom = 0, z_top = 0;
    EnclosedVolumes volumes;
  };
  std::uint64_t membrane_moves_ = 0;  ///< counts the changes of membrane_state_
  mutable VolumeCache volume_cache_;
  /// Both enclosed volumes of the membrane now (computed once per membrane move or platen move).
  const EnclosedVolumes& enclosed() const;
  std::vector<BallMotion> motion_;
  std::vector<std::uint8_t> clamp_group_;  ///< 0 bottom, 1 top
  std::vector<Eigen::Vector3d> ball_force_, ball_moment_;  ///< per ball, scratch of apply()
  std::vector<Eigen::Vector3d> pressure_force_, before_;   ///< per ball, scratch: the pressure's work
  bool membrane_started_ = false;
  double density_scaling_ = 1;
  std::array<double, 3> membrane_frame_{};  ///< centre radius, z_min, z_max the membrane was built with
};

/// One row of the triaxial time series.
struct TriaxialMeasure {
  double axial_stress = 0;    ///< sigma_1, Pa: mean platen force / (V / H), compression positive
  double lateral_stress = 0;  ///< sigma_3, Pa: the wall's, or the membrane pressure
  double height = 0;          ///< m, platen gap
  double volume = 0;          ///< m^3 (eq. 27 with the membrane)
  double volume_radial = 0;   ///< m^3 (eq. 28)
};
TriaxialMeasure measure(const Solver& solver, const TriaxialBoundary& boundary, const PlatenPair& platens);

/// Called after every step of the procedures below with the measurement after it and the step's
/// report (e.g. to write the time series, show progress or stop on an interrupt by throwing).
using TriaxialObserver = std::function<void(const TriaxialMeasure&, const StepReport&)>;

/// Kinetic energy below this share of the elastic energy (contact and strain) counts as
/// quasi-static (docs/methods.md, FDEM).
inline constexpr double kQuasiStaticRatio = 0.05;
/// A consolidation is over when the stresses and the kinetic energy stay settled this many steps.
inline constexpr std::size_t kSettledSteps = 100;
/// The inertial number of a sample sheared at `strain_rate` (1/s): strain rate x d50 x
/// sqrt(density / mean stress); quasi-static below 1e-3.
double inertial_number(double strain_rate, double d50, double density, double mean_stress);
/// The strain rate of a given inertial number (inverse of inertial_number), 1/s.
double strain_rate_of(double inertial_number, double d50, double density, double mean_stress);

/// Where a procedure below stands after a step, so a checkpoint taken in an observer can resume it
/// there (fdemrun --restart). Each procedure starts afresh unless `progress` is in one of its own
/// phases, and updates it before it calls its observer.
struct TriaxialProgress {
  enum class Phase : std::uint8_t { wall = 0, membrane_fixed, membrane_released, shearing };
  Phase phase = Phase::wall;
  std::uint64_t step = 0;      ///< steps taken in the current procedure
  std::uint64_t settled = 0;   ///< consecutive settled steps (consolidations)
  std::uint64_t released = 0;  ///< consolidate_in_membrane: its step count when the membrane was released
  double h0 = 0;               ///< shear: the platen gap at its start, m
};

/// Servo velocity for a stress error: the fastest speed while the error is above 10 % of the
/// target, proportional below (m/s, positive = the boundary should open).
double servo_velocity(double stress, double target, double fastest);

/// Share of its force error a servo may remove in one step, judged by the stiffness of the
/// contacts it drives (as YADE's triaxial controllers do): above about 1 the servo overshoots every
/// step and never settles; the stress wave through a tall sample needs a margin below that.
inline constexpr double kServoStepShare = 0.25;
/// `velocity` (m/s), slowed so that one step of it changes the force of contacts of total normal
/// stiffness `stiffness` (N/m, driven together) by at most kServoStepShare of `force_error` (N).
/// A stiff packing under a fast servo would otherwise swing about its target: the platens of a
/// 6 x 12.5 mm sample of 3 099 rigid grains never settled within 1 % at servo inertial number 1e-2.
/// Unchanged where nothing touches (stiffness 0).
double stiffness_limited_velocity(double velocity, double force_error, double stiffness, double dt);

/// The forming procedure's second half (docs/methods.md, flexible membrane): the grains are stopped, the membrane
/// replaces the wall and is held fixed while the grains settle against it, then it is released
/// between the platens under the confining pressure (ramped up over `ramp_steps`), while the
/// platens servo to sigma_3, until the axial stress is within options.stress_tolerance of
/// sigma_3 and the kinetic energy below 5 % of the elastic energy for 100 steps, or `max_steps`
/// (DataError). Returns the steps taken.
std::size_t consolidate_in_membrane(Solver& solver, TriaxialBoundary& boundary, const TriaxialOptions& options,
                                    double dt, std::size_t ramp_steps, std::size_t max_steps,
                                    const TriaxialObserver& on_step = {}, TriaxialProgress* progress = nullptr);

/// Strain-controlled shearing (docs/methods.md, flexible membrane): both platens move towards each other at
/// strain_rate x H0 / 2 each, under the membrane pressure (or inside the wall, which servos to
/// sigma_3 as in consolidation), until the axial strain ln(H0 / H) reaches target_axial_strain.
/// `on_step` gets every step's measurement and report. Returns the steps taken.
struct ShearOptions {
  double strain_rate = 0;          ///< 1/s, of the platen gap
  double target_axial_strain = 0;  ///< log strain, compression positive
  /// The platens speed up linearly from rest over the steps full speed would take to this strain
  /// (a sudden start shakes the sample out of quasi-static equilibrium); 0 = full speed at once.
  double ramp_strain = 0;
};
std::size_t shear(Solver& solver, TriaxialBoundary& boundary, const TriaxialOptions& options,
                  const ShearOptions& shearing, double dt, const TriaxialObserver& on_step,
                  TriaxialProgress* progress = nullptr);

/// Isotropic consolidation inside the wall: the wall and both platens servo to sigma_3 until all
/// three stresses are within options.stress_tolerance of it and the kinetic energy is below 5 % of
/// the contact elastic energy for 100 consecutive steps, or `max_steps`. Returns the steps taken.
std::size_t consolidate_in_wall(Solver& solver, TriaxialBoundary& boundary, const TriaxialOptions& options,
                                double dt, std::size_t max_steps, const TriaxialObserver& on_step = {},
                                TriaxialProgress* progress = nullptr);

}  // namespace graintwin::fdem
