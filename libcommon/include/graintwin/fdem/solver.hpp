#pragma once
// The explicit FDEM step (docs/methods.md, FDEM): M a + C v = F_ext + F_con - F_int with a lumped mass
// M, damping C = alpha M + beta K (mass- and stiffness-proportional; the latter settles deformable
// grains' own vibrations), optional local non-viscous damping and central differences (velocities at
// half steps, positions at whole steps). Deformable grains (tet4/tet10) move node by node; rigid grains are
// 6-DOF bodies whose nodes follow the body, so contact sees every grain as a moving surface. The
// time step is checked against the element and contact limits; NaN or runaway energy stops the
// run with the step number and the likely cause. A rigid grain's step touches only its body: contact
// places its nodes from the body's pose and sums the forces on them into the body's force and moment,
// and the node arrays are brought up to date only when the state is read.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "graintwin/core/exact_sum.hpp"
#include "graintwin/fdem/contact.hpp"
#include "graintwin/fdem/element.hpp"
#include "graintwin/fdem/implicit_grain.hpp"
#include "graintwin/fdem/model.hpp"
#include "graintwin/fdem/step_times.hpp"

namespace graintwin::io {
class H5File;
}

namespace graintwin::fdem {

/// A rigid grain's 6-DOF state. Velocities are at the half step t - dt/2 once the run has started.
struct RigidBodyState {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();          ///< m, centroid
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  ///< reference frame -> world
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();          ///< m/s
  Eigen::Vector3d angular_momentum = Eigen::Vector3d::Zero();  ///< kg m^2 / s about the centroid, world axes
};

/// Everything a checkpoint holds besides the contact history: a restart from it continues exactly
/// like the uninterrupted run.
struct SolverState {
  std::uint64_t step = 0;
  double time = 0;                    ///< s
  std::vector<Eigen::Vector3d> x;     ///< node positions at `time`, m
  std::vector<Eigen::Vector3d> v;     ///< node velocities at time - dt/2 (at `time` before the first step), m/s
  std::vector<RigidBodyState> bodies; ///< one per grain; used by rigid grains only
  std::vector<PlatenState> platens;
  double dissipated = 0;              ///< J, cumulative: damping (all three kinds), contact dashpots and slip
  double external_work = 0;           ///< J, cumulative: gravity and platens on the grains
  double energy_input = 0;            ///< J, initial mechanical energy plus every positive work increment
};

struct SolverOptions {
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();  ///< m/s^2
  double damping = 0;            ///< alpha of C = alpha M, 1/s
  /// beta of C = beta K, s: a viscous stress beta C : dE in the deformable grains' elements, from
  /// their strain rate at the last half step. It damps a mode of frequency omega at the ratio
  /// beta omega / 2 and shortens the element step (damped_critical_step).
  double stiffness_damping = 0;
  /// Local non-viscous (Cundall) damping: -local_damping |f_k| sign(v_k) on every component k of a
  /// node's (a rigid grain's: its body's force and torque) unbalanced force f, v at the last half
  /// step; in [0, 1).
  double local_damping = 0;
  double element_safety = 0.8;   ///< fraction of the element critical step used as the stable limit
  ContactOptions contact;
  /// Nodes of a rigid grain assumed to touch at once: contact sees each node of a rigid grain as
  /// this share of the body's effective mass at it, which sets the contact dashpots and the stable
  /// step (a few contacts of a few nodes each; a run that breaks the assumption stops as a runaway).
  double rigid_contact_nodes = 12;
  /// A run stops when the mechanical energy exceeds this multiple of the energy put in (plus a floor
  /// of 1e-12 E V summed over the grains, below which energy is round-off).
  double runaway_factor = 10;
  /// Rigid grains get element stresses too: their elastostatic state (elastostatic_stresses) in
  /// element_stress(), the frames and the VTK frames. The contact model then keeps each step's
  /// node forces.
  bool elastostatic_stress = false;
  /// Deformable grains are stepped implicitly in their corotated frame (fdem::ImplicitGrain): their
  /// elements no longer limit the step, and contact sees each of their nodes as it sees a rigid
  /// grain's (the body's effective mass over rigid_contact_nodes), since over such a step the stiff
  /// grain answers a contact as a whole; their best-fit frames go to contact as framed poses, and
  /// membrane balls press their footprints. The scene's [run] deformable_integration = "implicit";
  /// mass damping only (UsageError with stiffness or local damping); no state beyond positions and
  /// velocities (docs/fdemrun.md, implicit grains).
  bool implicit_grains = false;
};

/// Energies at the start of a step (time t_n), J.
struct Energies {
  double kinetic = 0, strain = 0, contact_elastic = 0;
  double dissipated = 0, external_work = 0;  ///< cumulative up to t_n
  double mechanical() const { return kinetic + strain + contact_elastic; }
  /// Kinetic over stored elastic energy (quasi-static below about 0.05); NaN, never an infinity,
  /// while nothing is stored (grains not yet in contact).
  double kinetic_ratio() const {
    const double stored = strain + contact_elastic;
    return stored > 0 ? kinetic / stored : std::numeric_limits<double>::quiet_NaN();
  }
};

/// The stable step of central differences for a mode of undamped critical step `critical` = 2 / omega
/// under stiffness-proportional damping beta (s): (2 / omega)(sqrt(1 + xi^2) - xi) with
/// xi = beta omega / 2, written sqrt(critical^2 + beta^2) - beta without its cancellation. Exact for
/// a damping force from the velocity of the previous half step, as the solver's.
double damped_critical_step(double critical, double beta);
/// Its inverse: the undamped critical step whose damped step is `step`, sqrt(step (step + 2 beta)).
double undamped_critical_step(double step, double beta);

/// The time-step limits, s; infinity where a limit does not apply.
struct StepLimits {
  /// min over deformable elements of k h_min / c (k = 0.671 tet4, 0.327 tet10), or after selective
  /// mass scaling the larger step the node masses guarantee
  double element_critical = 0;
  std::size_t element = 0;       ///< the element that sets the estimate
  bool guaranteed = false;       ///< element_critical is the node masses' guaranteed step
  double stiffness_damping = 0;  ///< beta (s) the element limit allows for
  /// damped_critical_step(element_critical, stiffness_damping) x element_safety
  double element_stable = 0;
  double contact_stable = 0;     ///< ContactModel::stable_time_step(), or infinity without contact
  double boundary_stable = std::numeric_limits<double>::infinity();  ///< Boundary::stable_time_step()
  double stable() const { return std::min({element_stable, contact_stable, boundary_stable}); }
};

struct StepReport {
  Energies energies;              ///< at t_n
  ContactStepStats contact;
};

/// What a boundary did in one step (energies in J).
struct BoundaryStep {
  double kinetic = 0;     ///< of the boundary's own bodies (membrane balls) at the half step
  double elastic = 0;     ///< stored in its springs and contacts now
  double dissipated = 0;  ///< in this step
  double work = 0;        ///< done on the system from outside in this step (confining pressure, moving walls)
};

/// Columns of a keyed row of a step's terms (StepRows).
inline constexpr std::size_t kTermColumns = 5;

/// A step's terms as keyed rows of kTermColumns values each, in increasing key order where they
/// are summed: across ranks each rank sends its rows, and every rank adds every rank's in key
/// order, as one rank adds its own (fdem/rank_state, mpi/distributed_run).
struct StepRows {
  std::vector<std::uint64_t> keys;
  std::vector<double> values;
};

/// A boundary of the sample beyond the platens, stepped with the grains: the triaxial test's servo
/// wall and membrane (fdem/triaxial.hpp). Each step, after the grain contacts and with the grain
/// nodes at t_n, the solver calls add_contact_forces(), moves the grains, then calls finish() with
/// the contact terms of every rank (its own on one rank), which advances the boundary's own state
/// over dt. Every rank holds the whole boundary and advances it alike.
class Boundary {
 public:
  virtual ~Boundary() = default;
  /// Adds the boundary's contact forces on the grains this rank advances (all of them on one rank)
  /// and returns those contacts' terms as rows in key order, for finish().
  virtual StepRows add_contact_forces(ContactModel& contact, std::span<const Eigen::Vector3d> x,
                                      std::span<const Eigen::Vector3d> v, double dt, std::span<Eigen::Vector3d> f) = 0;
  /// Advances the boundary over dt from the contact rows of every rank in key order.
  /// `damping`: the run's mass-proportional alpha (1/s), for the boundary's own bodies too.
  virtual BoundaryStep finish(ContactModel& contact, const StepRows& rows, double dt, double damping, bool first) = 0;
  /// The boundary's own stable time step, s (infinity if it sets none).
  virtual double stable_time_step(const ContactModel& contact) const = 0;
  /// How many bodies of its own it steps (membrane balls), for the run's time accounts.
  virtual std::size_t bodies() const { return 0; }
  /// Checkpoint of the boundary's own state under `group` (Solver::save calls it), and its restore
  /// into a boundary built the same way (DataError when it does not fit).
  virtual void save(io::H5File& file, const std::string& group) const = 0;
  virtual void load(const io::H5File& file, const std::string& group) = 0;
};

/// Per grain, a step's energy terms, J, found in parallel; `bad`: the grain's state became
/// non-finite in the step.
struct GrainStepSums {
  std::vector<double> strain, kinetic, damped, gravity_work;
  std::vector<char> bad;
};

/// A step's sums over the grains and the contact candidates, exact and so the same whatever their
/// order (core/exact_sum): on a run split over ranks each rank adds the grains and candidates it
/// owns, and RankShare::finish_step adds the ranks' accumulators, so every rank count has the
/// one-rank bits.
struct StepTotals {
  ExactSum strain, kinetic, damped, gravity_work;  ///< J
  ExactSum energy_input;                          ///< J, the positive terms of gravity's work
  ExactSum grains, bad;                           ///< grains advanced; those whose state became non-finite
  ExactSum contact_elastic, contact_dissipated;   ///< J
  ExactSum node_contacts;
  std::vector<ExactSum> platens;  ///< per platen: its force's x, y and z (N), then its contacts' normal stiffness (N/m)
  double max_overlap = 0;         ///< m, the deepest of any candidate
  /// Every accumulator, in one fixed order (for adding them across ranks).
  std::vector<ExactSum*> accumulators();
};

/// A run split over ranks (docs/fdemrun.md, across machines; mpi/distributed_run implements it
/// over MPI): the solver advances only the grains this rank owns and finishes each step through
/// this, which completes the step's sums and hands the solver the states of the grains it holds
/// next (set_rigid_state, set_node_state) with their friction history
/// (ContactModel::merge_history).
class RankShare {
 public:
  virtual ~RankShare() = default;
  /// Per grain, its role on this rank in the step about to be taken.
  virtual std::span<const GrainRole> roles() const = 0;
  /// Called by Solver::step once this rank's owned grains have moved, before the energies are
  /// taken. On entry `totals` holds the sums of this rank's grains and candidates, on return the
  /// whole run's. `boundary_rows`: on entry this rank's rows of Boundary::add_contact_forces, on
  /// return every rank's, in key order.
  virtual void finish_step(StepTotals& totals, StepRows& boundary_rows) = 0;
};

class Solver {
 public:
  /// Precomputes elements, masses and rigid-body properties; builds contact when enabled. Node
  /// positions start at the reference, velocities at zero.
  Solver(const Model& model, const SolverOptions& options);
  ~Solver();

  const Model& model() const { return *model_; }
  const SolverOptions& options() const { return options_; }
  /// The whole state. The step moves rigid grains as bodies only; their nodes are placed from the
  /// bodies here, on the first call after a step (a pass over their nodes: per-step readers of the
  /// step, time or platens use the accessors below).
  const SolverState& state() const;
  std::uint64_t step_count() const { return state_.step; }
  double time() const { return state_.time; }  ///< s
  std::span<const PlatenState> platens() const { return state_.platens; }
  std::span<const double> node_mass() const { return mass_; }
  /// The node masses contact uses (dashpots, stable step): node_mass() for deformable grains; for a
  /// rigid grain's node, the body's effective mass there over options().rigid_contact_nodes.
  std::span<const double> contact_node_mass() const { return contact_mass_; }
  const BodyProperties& body(std::size_t grain) const { return bodies_[grain]; }

  /// Gives grain g a rigid velocity V + omega x (X - centroid); only before the first step.
  void set_grain_velocity(std::size_t grain, const Eigen::Vector3d& velocity, const Eigen::Vector3d& angular_velocity);
  /// Sets a platen's velocity (loading stages change it between steps).
  void set_platen_velocity(std::size_t platen, const Eigen::Vector3d& velocity);
  /// Sets the mass-proportional damping alpha, 1/s (loading stages change it between steps).
  void set_damping(double alpha) { options_.damping = alpha; }
  /// Sets the stiffness-proportional damping beta, s, and the local damping (stages change them
  /// between steps; the time step must allow for the largest beta, time_step_limits(beta)).
  /// Stiffness-proportional and local damping (refused with implicit grains, which take
  /// mass-proportional damping only).
  void set_stiffness_damping(double beta);
  void set_local_damping(double local);
  /// Stops every grain: node velocities and rigid bodies' momenta to zero (the forming procedure
  /// stops the grains before the membrane replaces the wall).
  void stop_grains();
  /// The model's density of `grains` changed (mass scaling): their node masses, rigid-body
  /// properties and contact masses are computed again, as a new Solver of the model would have them
  /// with the node masses added by selective mass scaling kept (before the first step; building
  /// one again would redo every grain's elements and the contact trees).
  void refresh_masses(std::span<const std::uint32_t> grains);
  /// Selective mass scaling (mass_scaling.hpp): adds `added[v]` kg to node v's lumped mass (one
  /// per model node, none negative; kept through refresh_masses), and the element critical step
  /// becomes at least `guaranteed_critical` (s, undamped): the step these masses were proven to
  /// allow. Only before the first step.
  void add_node_masses(std::vector<double> added, double guaranteed_critical);
  /// Per node, the mass selective mass scaling added, kg (empty without it).
  std::span<const double> added_node_mass() const { return added_mass_; }
  /// Steps `boundary` with the grains from the next step on (not owned; nullptr removes it).
  /// UsageError without contact (a boundary acts through it).
  void set_boundary(Boundary* boundary);
  /// Contact between the grains, platens and boundaries (nullptr when disabled).
  ContactModel* contact_model() { return contact_.get(); }
  const ContactModel* contact_model() const { return contact_.get(); }

  /// Per element, its undamped critical step k h_min / c at its density, s; infinity for elements of
  /// rigid grains. An estimate that holds for meshes as built; selective mass scaling stands on the
  /// proven bound instead (node_stiffness_bounds, mass_scaling.hpp).
  std::vector<double> element_critical_steps() const;
  /// The limits with the solver's stiffness damping, or with `stiffness_damping` (s; a run whose
  /// stages change it takes the largest).
  StepLimits time_step_limits() const { return time_step_limits(options_.stiffness_damping); }
  StepLimits time_step_limits(double stiffness_damping) const;
  /// UsageError with both limits when dt is not below the stable step (or not positive).
  void check_time_step(double dt) const { check_time_step(dt, options_.stiffness_damping); }
  void check_time_step(double dt, double stiffness_damping) const;
  /// One central-difference step. DataError naming the step and the likely cause when the state
  /// becomes non-finite or the energy runs away.
  StepReport step(double dt);

  /// Centroid (m) of grain g now: the body position, or the mass-weighted node mean.
  Eigen::Vector3d grain_centroid(std::size_t grain) const;
  /// Centroid velocity (m/s) of grain g at the last half step.
  Eigen::Vector3d grain_velocity(std::size_t grain) const;
  /// Angular velocity (rad/s, world axes) of grain g at the last half step: a rigid body's, or for
  /// a deformable grain its nodes' angular momentum about the centroid through their inertia now.
  Eigen::Vector3d grain_spin(std::size_t grain) const;
  /// Rotation of grain g from the reference: the body orientation, or the polar part of the
  /// mass-weighted best fit of its nodes (Kabsch).
  Eigen::Quaterniond grain_rotation(std::size_t grain) const;
  /// Volume-averaged Cauchy stress of grain g, tension positive, Pa: of its elements, or for a rigid
  /// grain the Love-Weber average (1/V) sym(sum_n r_n (x) f_n) of the contact and boundary forces on
  /// its nodes in the last step (zero before the first step).
  Eigen::Matrix3d grain_stress(std::size_t grain) const;
  /// Element stresses of rigid grain g, world axes, tension positive, Pa, one per element of its
  /// mesh: its elastostatic state (fdem/elastostatic.hpp) under the last step's contact and
  /// boundary forces on its nodes and gravity, their net force and moment balanced by its rigid
  /// acceleration. Their volume average is its Love-Weber stress with gravity's share. Needs the
  /// contact model recording node forces (contact_model()->record_node_forces(true)) before that
  /// step; throws UsageError otherwise or for a grain that is not rigid.
  std::vector<Eigen::Matrix3d> elastostatic_stresses(std::size_t grain) const;
  /// Volume-averaged Cauchy stress of element e, tension positive, Pa: of a rigid grain's elements
  /// their elastostatic stress with SolverOptions::elastostatic_stress (every rigid grain's is
  /// computed, in parallel, on the first call after a step; NaN for a grain whose mesh has no static
  /// state, e.g. one in several pieces), else zero. Not for concurrent calls.
  Eigen::Matrix3d element_stress(std::size_t element) const;
  /// Whether grain g's elements carry stress: deformable, or rigid with elastostatic_stress.
  bool carries_element_stress(std::size_t grain) const;
  /// Every grain's Love-Weber stress, tension positive, Pa: (1/V) sym(sum_n (x_n - c) (x) f_n) of
  /// the contact and boundary forces f_n on its nodes in the last step, x_n and c where they acted.
  /// A rigid grain's is its grain_stress(); a deformable grain's (V its volume at x_n) equals its
  /// element average when it is at rest in equilibrium without gravity (divergence theorem), so the
  /// difference measures inertia, damping and gravity. A rigid grain's is zero before the first
  /// step; a deformable grain's is NaN while its last step's forces are unknown (before the first
  /// step, after stop_grains, after restoring a checkpoint written before they were kept).
  std::vector<Eigen::Matrix3d> love_weber_stresses() const;
  /// Grain-pair and grain-platen resultants of the last step (empty without contact).
  std::span<const ContactRecord> contacts() const;
  /// Force the grains exert on platen p in the last step, N.
  Eigen::Vector3d platen_force(std::size_t platen) const;
  /// Normal stiffness of the grains' contacts with platen p in the last step, N/m (0 untouched).
  double platen_stiffness(std::size_t platen) const;
  /// Where the steps' time went since the solver was built (step_times.hpp).
  const StepTimes& step_times() const { return times_; }
  bool has_contact() const { return contact_ != nullptr; }

  // A run split over ranks (docs/fdemrun.md, across machines).

  /// Steps only the grains `share` names owned from the next step on, and finishes each step
  /// through it (not owned; nullptr: every grain, one rank). Forces, loads and contacts read
  /// from this solver are then whole for its owned grains only. Needs contact: UsageError
  /// otherwise.
  void set_rank_share(RankShare* share);
  /// Replaces node n's position and velocity (a deformable grain's, from its owner).
  void set_node_state(std::uint32_t node, const Eigen::Vector3d& x, const Eigen::Vector3d& v);
  /// Per node, the forces the last step left on deformable grains' nodes (contact and boundary
  /// minus internal; their Love-Weber stress), and their replacement (gathered for output).
  std::span<const Eigen::Vector3d> node_forces() const { return force_; }
  void set_node_force(std::uint32_t node, const Eigen::Vector3d& force) { force_.at(node) = force; }
  /// Replaces rigid grain g's state (a ghost's, or a grain migrating here, from its owner).
  void set_rigid_state(std::size_t grain, const RigidBodyState& state);
  /// Every grain's body state, without placing rigid grains' nodes (state() does).
  std::span<const RigidBodyState> rigid_states() const { return state_.bodies; }
  /// Rigid grain g's contact and boundary load of the last step (its Love-Weber stress).
  const RigidLoad& rigid_load(std::size_t grain) const { return rigid_loads_.at(grain); }
  /// Replaces it (a run split over ranks gathers the owners' on rank 0 to write them).
  void set_rigid_load(std::size_t grain, const RigidLoad& load) { rigid_loads_.at(grain) = load; }

  /// Checkpoint: the state, the last step's platen forces, the contact history (membrane balls'
  /// included) and the boundary's state when one is set, under `group`; of `part`'s grains only,
  /// and without what every rank holds alike unless part.shared (one file of a checkpoint written
  /// by several ranks at once).
  void save(io::H5File& file, const std::string& group, const CheckpointPart& part = {}) const;
  /// Restores what save() wrote for the same model (and a boundary built the same way, set before);
  /// DataError when sizes disagree or the checkpoint's boundary does not match the one set.
  void load(const io::H5File& file, const std::string& group);
  /// The same from the files of a checkpoint written by several ranks (the first holding the
  /// shared state): DataError naming a file when two hold a grain or none holds one.
  void load(std::span<const io::H5File* const> files, const std::string& group);

 private:
  /// Rigid grain g's pose and motion now, as contact places its nodes.
  RigidPose pose_of(std::size_t grain) const;
  /// Places every rigid grain's nodes (x, v) from its body (pose_of), if a step moved them since.
  void place_rigid_nodes() const;
  /// Platen forces and stiffnesses from the last step's contact records.
  void sum_platen_contacts();
  /// Mass-weighted mean of per-node `values` over grain g's nodes.
  Eigen::Vector3d mass_mean(std::size_t grain, const std::vector<Eigen::Vector3d>& values) const;
  Eigen::Vector3d angular_velocity(std::size_t grain, const Eigen::Quaterniond& q, const Eigen::Vector3d& L) const;
  void check_health(const Energies& e) const;
  /// Advances deformable grain g implicitly (options.implicit_grains) under this step's contact
  /// forces (force_), gravity and mass damping, and sets its step terms: kinetic and strain energy
  /// after the step, the energy lost (damping and the implicit step's own), gravity's work, bad.
  void step_implicit_grain(std::size_t g, double dt, const Eigen::Vector3d& g_acc, double& kinetic, double& damped,
                           double& gravity_work, double& strain, char& bad);

  const Model* model_;
  SolverOptions options_;
  ElasticElements elements_;
  std::vector<double> mass_;
  std::vector<double> contact_mass_;
  std::vector<BodyProperties> bodies_;         ///< per grain, in the reference configuration
  std::vector<Eigen::Matrix3d> inverse_inertia_;  ///< per grain, reference axes
  std::unique_ptr<ContactModel> contact_;
  /// Per deformable grain with options.implicit_grains, its implicit stepper for the last step's dt
  /// (made again when dt changes).
  std::vector<std::unique_ptr<ImplicitGrain>> implicit_;
  /// Per implicit grain, scratch: its best-fit frame at this step's positions (its step's, and its
  /// pose for contact).
  std::vector<ImplicitGrain::Frame> implicit_frames_;
  Boundary* boundary_ = nullptr;
  double runaway_floor_ = 0;                   ///< J: energy below it is never a runaway (round-off)
  /// Per node, the last step's forces on deformable grains (a rigid grain's nodes hold none).
  std::vector<Eigen::Vector3d> force_;
  /// Per node, the last step's stiffness-proportional damping forces (with stiffness damping only).
  std::vector<Eigen::Vector3d> viscous_force_;
  /// Per node, the mass selective mass scaling added, kg; empty without it.
  std::vector<double> added_mass_;
  /// s: the undamped critical step the node masses guarantee after selective mass scaling (0 without).
  double guaranteed_critical_ = 0;
  /// Per grain, the contact and boundary forces on the rigid ones in the last step (ContactModel::rigid_loads).
  std::vector<RigidLoad> rigid_loads_;
  /// The last step's time step (0 before the first): with the half-step velocities it gives the
  /// positions where force_ acted, for the Love-Weber stress of deformable grains.
  double last_dt_ = 0;
  std::vector<RigidPose> poses_;               ///< per grain, scratch: rigid grains' motion, implicit ones' frames, for contact
  std::vector<Eigen::Vector3d> platen_force_;  ///< per platen, last step
  std::vector<double> platen_stiffness_;       ///< per platen, last step, N/m
  StepTimes times_;
  /// Per grain, the step's energy terms before their ordered sum (scratch of step()).
  GrainStepSums step_sums_;
  /// This step's totals of the owned grains' terms and the owned candidates' sums.
  StepTotals step_totals(std::span<const GrainRole> roles) const;
  RankShare* share_ = nullptr;  ///< set_rank_share: this rank's part of a run split over ranks
  /// Mutable: state() places rigid grains' nodes on demand (rigid_nodes_stale_).
  mutable SolverState state_;
  mutable bool rigid_nodes_stale_ = false;
  /// Rigid grains' elastostatic element stresses (per grain, world axes) and the step they are of.
  mutable std::vector<std::vector<Eigen::Matrix3d>> elastostatic_;
  mutable std::int64_t elastostatic_step_ = -1;
};

}  // namespace graintwin::fdem
