#pragma once
// FDEM contact (docs/methods.md, FDEM): surface nodes of one grain against the surface triangles of
// another, penalty normal force with a dashpot (never attractive), Coulomb friction with a
// tangential spring history per node contact, rigid platens with friction. Broad phase: a uniform
// cell grid over skin-inflated grain boxes, rebuilt only when a node moved more than skin / 2.
// Narrow phase: per grain pair, only the surface nodes that were within reach of the other grain
// at the last build (exact: nodes move at most skin / 2 between builds), each searched in the
// other grain's AABB tree (refitted every step, or placed by a rigid grain's pose).
// Rules, equations and measured costs: docs/fdem_contact.md.
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "graintwin/fdem/checkpoint_part.hpp"
#include "graintwin/fdem/model.hpp"

namespace graintwin::io {
class H5File;
}

namespace graintwin::fdem {

struct ContactOptions {
  /// Verlet skin, m: grain boxes are inflated by it and the candidate pairs are rebuilt once some
  /// node moved more than skin / 2. 0 = automatic, 0.05 x the smallest grain's box diagonal.
  double skin = 0;
  /// Test each step only the surface nodes listed at the last build as within reach of the other
  /// grain (max penetration + skin): the same forces, bit for bit, as testing every surface node
  /// (false; kept to verify that).
  bool near_node_lists = true;
  /// Between two rigid grains, remember each listed node's last closest-triangle search in the
  /// other grain's body frame and reuse it while the node has moved too little to change the
  /// answer: the same forces, bit for bit, as searching anew every step (false; kept to verify that).
  bool search_memos = true;
  bool enabled = true;
};

/// A platen's current state, as the loading protocol moves it.
struct PlatenState {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();      ///< m, a point on the plane
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();    ///< unit, into the sample
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();   ///< m/s
  double friction = 0;                                  ///< Coulomb coefficient
};

/// Where a rigid grain is and how it moves. Its node with reference position X sits at
/// centre + rotation (X - reference_centre) and moves at velocity + angular_velocity x rotation (X -
/// reference_centre); its surface tree is placed at rotation X + translation (translation = centre - rotation
/// reference_centre). Contact reads a rigid grain's nodes from its pose, never from the node arrays.
/// A deformable grain may give its best-fit frame instead (`framed`, of_frame: an implicit grain's,
/// whose nodes stay within a strain's worth of it): its nodes are still read from the node arrays,
/// but the frame lets its pairs' near-node lists outlive the broad phase as a rigid pair's do.
struct RigidPose {
  bool rigid = false;  ///< false: a deformable grain (its trees are refitted to its nodes)
  bool framed = false;  ///< a deformable grain with the best-fit frame below (rotation, translation, centres)
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();       ///< m
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();            ///< m, the body's centroid now
  Eigen::Vector3d reference_centre = Eigen::Vector3d::Zero();  ///< m, the centroid in the reference
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();          ///< m/s, of the centroid
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();  ///< rad/s, world axes
  /// m, of a framed grain, set by the contact model: how far its surface nodes lie from where the
  /// frame puts their reference positions, at most.
  double deviation = 0;

  /// The pose of a body with centroid `centre` (reference `reference_centre`) turned by `rotation`.
  static RigidPose of_body(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& centre,
                           const Eigen::Vector3d& reference_centre, const Eigen::Vector3d& velocity = Eigen::Vector3d::Zero(),
                           const Eigen::Vector3d& angular_velocity = Eigen::Vector3d::Zero()) {
    return {true, false, rotation, centre - rotation * reference_centre, centre, reference_centre, velocity, angular_velocity};
  }
  /// The best-fit frame of a deformable grain: its nodes near centre + rotation (X - reference_centre).
  static RigidPose of_frame(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& centre, const Eigen::Vector3d& reference_centre) {
    RigidPose frame = of_body(rotation, centre, reference_centre);
    frame.rigid = false;
    frame.framed = true;
    return frame;
  }
  /// How fast the node with reference position X moves.
  Eigen::Vector3d velocity_of(const Eigen::Vector3d& X) const { return velocity + angular_velocity.cross(arm(X)); }
  /// From the centroid to the node with reference position X, now.
  Eigen::Vector3d arm(const Eigen::Vector3d& X) const { return rotation * (X - reference_centre); }
};

/// The contact forces on a rigid grain in one step, about its centroid.
struct RigidLoad {
  Eigen::Vector3d force = Eigen::Vector3d::Zero();   ///< N, sum f
  Eigen::Matrix3d moment = Eigen::Matrix3d::Zero();  ///< N m, sum r f^T, r from the centroid to where f acts
  /// N m, the torque sum r x f (the skew part of `moment`).
  Eigen::Vector3d torque() const {
    return {moment(1, 2) - moment(2, 1), moment(2, 0) - moment(0, 2), moment(0, 1) - moment(1, 0)};
  }
  void add(const Eigen::Vector3d& arm, const Eigen::Vector3d& f) { force += f, moment += arm * f.transpose(); }
  RigidLoad& operator+=(const RigidLoad& o) { return force += o.force, moment += o.moment, *this; }
};

/// Resultant of one grain pair (or grain-platen pair) over its node contacts.
struct ContactRecord {
  std::uint32_t a = 0, b = 0;  ///< grain indices, a < b; b = grains.size() + platen index for platens
  Eigen::Vector3d point = Eigen::Vector3d::Zero();   ///< m, normal-force-weighted mean contact point
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  ///< unit, a -> b (direction of the normal force on b)
  Eigen::Vector3d force = Eigen::Vector3d::Zero();   ///< N, total force on b (minus that on a)
  double overlap = 0;                                ///< m, deepest node penetration of the pair
  /// N/m, the node contacts' normal stiffness summed: how fast the force grows as the pair closes
  /// (a servo driving a platen keeps its step's force change below the force error with it).
  double stiffness = 0;
};

/// A rigid vertical cylindrical wall around the sample (the servo wall of the forming procedure,
/// docs/methods.md, flexible membrane): grain surface nodes farther than `radius` from the axis are pushed back with
/// the platen law (the grain's penalty and dashpot), frictionless.
struct CylinderWallState {
  Eigen::Vector2d axis_xy = Eigen::Vector2d::Zero();  ///< m
  double radius = 0;                                  ///< m
  double radial_velocity = 0;                         ///< m/s, > 0 opening
};

/// What the wall or the membrane balls did in one step.
struct BoundaryContactStats {
  std::size_t contacts = 0;     ///< node-wall or ball-grain contacts
  double radial_force = 0;      ///< N: wall only, the grains' total outward push on the wall
  double radial_stiffness = 0;  ///< N/m: wall only, the node contacts' normal stiffness summed
  double elastic_energy = 0;    ///< J stored in the contact springs now
  double dissipated = 0;        ///< J lost by dashpots and slip in this step
  double max_overlap = 0;       ///< m
};

/// One grain's contacts with the wall in a step, summed over its surface nodes in node order.
struct WallContactSum {
  std::uint32_t grain = 0;
  std::uint32_t contacts = 0;   ///< its nodes beyond the wall
  double radial_force = 0;      ///< N, their outward push on the wall
  double radial_stiffness = 0;  ///< N/m, their normal stiffness
  double elastic_energy = 0;    ///< J
  double dissipated = 0;        ///< J
};
/// Sums the grains' wall contacts in the order given (grain order): what the wall felt.
BoundaryContactStats wall_contact_stats(std::span<const WallContactSum> grains);

/// One membrane ball touching one grain in a step.
struct BallContact {
  std::uint32_t ball = 0, grain = 0;
  Eigen::Vector3d force = Eigen::Vector3d::Zero();   ///< N, on the ball (the grain gets minus it)
  Eigen::Vector3d moment = Eigen::Vector3d::Zero();  ///< N m, the friction moment on the ball
  Eigen::Vector3d spring = Eigen::Vector3d::Zero();  ///< N, the tangential spring the next step starts from
  double elastic_energy = 0;                         ///< J
  double dissipated = 0;                             ///< J
  double overlap = 0;                                ///< m
};
/// Adds the contacts, in the order given ((ball, grain) order), to their balls' force and moment
/// (one entry per ball) and returns what the balls felt.
BoundaryContactStats add_ball_contacts(std::span<const BallContact> contacts, std::span<Eigen::Vector3d> ball_force,
                                       std::span<Eigen::Vector3d> ball_moment);

/// The membrane balls as contact partners of the grains.
struct BallContactOptions {
  double radius = 0;    ///< m
  double mass = 0;      ///< kg, of one ball (dashpot)
  double friction = 0;  ///< Coulomb coefficient between ball and grain
};

/// How deep a grain reaches into another grain, or behind a platen (ContactModel::overlaps).
struct Overlap {
  std::uint32_t a = 0, b = 0;  ///< grain indices, a < b; b = grains.size() + platen index for a platen
  double depth = 0;            ///< m, > 0: the deepest point of one inside the other (or behind the platen)
};

struct ContactStepStats {
  std::size_t pairs = 0;          ///< candidate grain pairs of the broad phase
  std::size_t node_contacts = 0;  ///< active node contacts after this step
  bool rebuilt = false;           ///< the broad phase was rebuilt in this step
  double elastic_energy = 0;      ///< J, stored in the normal and tangential penalty springs now
  double dissipated = 0;          ///< J, by dashpots and friction slip during this step
  double max_overlap = 0;         ///< m
  std::size_t node_checks = 0;      ///< surface nodes tested against another grain's box or a platen
  std::size_t triangle_checks = 0;  ///< closest-point evaluations in the trees
  /// Rigid pairs whose near-node lists were built again this step (they moved a skin relative to
  /// each other since their lists were built), besides the broad phase's rebuilds.
  std::size_t pair_lists_built = 0;
};

/// A grain's part in a run shared by ranks (docs/fdemrun.md, across machines): each rank's
/// contact model sees only the grains it owns and their ghosts.
enum class GrainRole : std::uint8_t {
  absent,  ///< held by other ranks only: takes no part in this rank's contact
  ghost,   ///< another rank's grain copied here: a partner of this rank's grains
  owned,   ///< this rank's: the forces on it here are whole
};

/// One node contact's friction history: the tangential spring and the force-free overlap of node
/// `node` in grain pair (a < b).
struct ContactHistoryEntry {
  std::uint32_t a = 0, b = 0, node = 0;
  Eigen::Vector3d spring = Eigen::Vector3d::Zero();  ///< N
  double offset = 0;  ///< m, the node contact's force-free overlap (keep_initial_overlaps)
};

/// What one candidate (grain pair, or grain and platen) with node contacts added to a step's sums.
struct PairStepSum {
  std::uint32_t a = 0, b = 0;  ///< as ContactRecord
  double elastic_energy = 0;   ///< J
  double dissipated = 0;       ///< J
  double overlap = 0;          ///< m, deepest
  std::uint64_t node_contacts = 0;
  Eigen::Vector3d force = Eigen::Vector3d::Zero();  ///< N, as ContactRecord (a platen's sum needs it)
  double stiffness = 0;                             ///< N/m, as ContactRecord
};

class ContactModel {
 public:
  /// `node_mass` has one lumped mass (kg) per model node; the reference node positions of `model`
  /// give the node areas A_node. Throws DataError when the model has no surface or node masses do
  /// not match the nodes.
  ContactModel(const Model& model, std::span<const double> node_mass, const ContactOptions& options);
  ~ContactModel();
  ContactModel(ContactModel&&) noexcept;
  ContactModel& operator=(ContactModel&&) noexcept;

  /// Adds penalty + dashpot normal forces and Coulomb friction (tangential spring history per
  /// node contact) to f (one entry per model node) for the current node positions x and
  /// velocities v; platen contacts too. Deterministic for a given thread count. `poses` (empty,
  /// or one per grain) gives rigid grains' motion: their nodes and surface trees are placed by it,
  /// and the forces on them go to rigid_loads(), not to f (their entries in x, v and f are neither
  /// read nor written, here nor by add_wall_forces and add_ball_forces of the same step).
  ContactStepStats add_forces(std::span<const Eigen::Vector3d> x, std::span<const Eigen::Vector3d> v,
                              std::span<const PlatenState> platens, double dt,
                              std::span<Eigen::Vector3d> f, std::span<const RigidPose> poses = {});
  /// The node contacts of the next add_forces() carry no force for the overlap they have then: each
  /// keeps it as an offset, and its force acts on the overlap beyond it; the offset only shrinks
  /// (to the overlap, as the contact opens) and ends with the contact. For twins of scanned grains,
  /// whose meshes overlap slightly wherever the grains touch: the scan's contacts start in place
  /// and force-free (fdemrun's [run] keep_initial_overlaps). `overlaps` (from overlaps() at the
  /// positions of that step) are the grain pairs whose search must look deeper than usual (a tenth
  /// of the smallest grain's smallest box side): for the rest of the run, to their depth and that
  /// tenth beyond.
  void keep_initial_overlaps(std::span<const Overlap> overlaps);
  /// Adds the cylinder wall's forces on the surface nodes of the grains this rank owns (every grain
  /// without roles) to f (call after add_forces of the same step). Returns, in grain order, each
  /// touching grain's sums (wall_contact_stats adds them up), valid until the next call.
  /// Deterministic for a given thread count.
  std::span<const WallContactSum> add_wall_forces(std::span<const Eigen::Vector3d> x, std::span<const Eigen::Vector3d> v,
                                                  const CylinderWallState& wall, double dt, std::span<Eigen::Vector3d> f);
  /// Balls (centres, velocities, spins at the half step) against the surfaces of the grains this
  /// rank owns (call after add_forces of the same step, which refits the trees): penetration =
  /// radius minus the distance from the centre to the surface (plus it, for a centre inside),
  /// pushed along the surface normal; k_n = p_n pi r^2 and k_t = p_t pi r^2 of the grain's
  /// material, its damping ratio, the ball's mass in the dashpot, Coulomb friction with a
  /// tangential spring per (ball, grain). The grain's triangle gets the reaction (barycentric);
  /// the contacts are returned in (ball, grain) order for the balls (add_ball_contacts), valid
  /// until the next call, and their springs become the friction history of the next step.
  std::span<const BallContact> add_ball_forces(std::span<const Eigen::Vector3d> x, std::span<const Eigen::Vector3d> v,
                                               std::span<const Eigen::Vector3d> centres,
                                               std::span<const Eigen::Vector3d> ball_velocity,
                                               std::span<const Eigen::Vector3d> ball_spin, const BallContactOptions& balls,
                                               double dt, std::span<Eigen::Vector3d> f);
  /// The balls' friction history the next step starts from, replaced by the springs of `contacts`
  /// (every rank's, in (ball, grain) order): across ranks, a grain's new owner finds its springs.
  void set_ball_history(std::span<const BallContact> contacts);
  /// Every grain pair, and grain and platen, that overlaps with the nodes at x (every node read from
  /// x, none placed by a pose), sorted by (a, b): for the initial state's check, not for stepping.
  /// Unlike the step, whose search looks no deeper than a tenth of the smallest grain, it finds
  /// overlaps of any depth: each surface node and surface triangle centroid of one grain inside the
  /// other's box is searched in the other's tree without a bound and tested inside by the
  /// pseudonormal (the centroids catch boxes whose corners lie on each other's faces). A pair
  /// costs its points inside the other's box, and pairs come from the broad phase: linear in the
  /// grains for a packing. The next add_forces() rebuilds its pairs.
  /// `moved` (empty: all grains) flags, one per grain, the grains whose nodes changed since the
  /// previous overlaps() call with no add_forces() between: only pairs and platen overlaps with a
  /// flagged grain are measured and returned (the others are unchanged), so that repeated checks
  /// of a relaxation cost what moved.
  std::vector<Overlap> overlaps(std::span<const Eigen::Vector3d> x, std::span<const PlatenState> platens,
                                std::span<const std::uint8_t> moved = {});
  /// Ball contact limit on the time step, s, like stable_time_step() for the stiffest grain material.
  double ball_stable_time_step(const BallContactOptions& balls) const;
  /// Per grain, the forces on the rigid ones (those with a pose) in this step: from add_forces, which
  /// starts them, and add_wall_forces and add_ball_forces after it.
  std::span<const RigidLoad> rigid_loads() const;
  /// Whether each step also keeps its contact and boundary forces node by node, rigid grains'
  /// included (node_forces()): what the elastostatic stress of rigid grains needs. Off by default.
  void record_node_forces(bool on);
  /// With recording on, the forces of this step on every model node, N (from add_forces, which
  /// starts them, and add_wall_forces and add_ball_forces after it): a node's own contact force, and
  /// the reaction on a surface it touched spread over the touched triangle's nodes by its
  /// barycentric weights. Empty with recording off.
  std::span<const Eigen::Vector3d> node_forces() const;
  /// Grain-pair (and grain-platen) resultants of the last step, sorted by (a, b).
  /// Replaces the node masses the contact laws damp with (one per model node).
  void set_node_masses(std::span<const double> node_mass);
  std::span<const ContactRecord> contacts() const;
  /// Contact limit on the time step, s: min over surface nodes of 2 sqrt(m / k_n) x safety (0.2).
  double stable_time_step() const;
  /// The same limit grain by grain (over each grain's surface nodes; infinity for a grain without).
  std::vector<double> grain_time_steps() const;
  /// Number of broad-phase builds so far.
  std::size_t rebuild_count() const;
  /// The skin in use, m (options.skin or the automatic value).
  double skin() const;
  /// Writes the friction history and the last step's records under `group`, for checkpoints (a
  /// restart continues exactly like the uninterrupted run): of `part`'s grains (entries and records
  /// of pairs whose first grain is one), and the membrane balls' friction and the deep pairs when
  /// it holds the shared state.
  void save(io::H5File& file, const std::string& group, const CheckpointPart& part = {}) const;
  /// Reads what save() wrote into `files` (one file, or every part of a checkpoint of several
  /// ranks, the first holding the shared state): their entries and records together, in the
  /// one-rank order. DataError naming the file when a table is damaged or out of this model.
  void load(std::span<const io::H5File* const> files, const std::string& group);
  void load(const io::H5File& file, const std::string& group);

  // A run shared by ranks (docs/fdemrun.md, across machines; contact_ranks.cpp).

  /// One role per grain for the next steps; empty: every grain owned, the one-rank run (as before
  /// any call). Absent grains take no part; a grain pair is a candidate only with an owned grain
  /// in it and a platen only with an owned grain, so the forces on ghosts are partial (their
  /// owners have them whole). A change of roles rebuilds the broad phase. UsageError unless empty
  /// or one per grain.
  void set_grain_roles(std::span<const GrainRole> roles);
  /// The last step's sums of the candidates with node contacts whose grain a is owned (every grain
  /// without roles), in candidate order, (a, b); each candidate of the run is owned by exactly one
  /// rank.
  std::span<const PairStepSum> owned_pair_sums() const;
  /// The friction history of the pairs with one of `grains` in them, sorted by (a, b, node).
  std::vector<ContactHistoryEntry> history_of(std::span<const std::uint32_t> grains) const;
  /// Adds the entries of `entries` the history lacks (a grain that migrated here brings its
  /// pairs'). An entry it already holds must be the same, bit for bit: the ranks evaluating a pair
  /// keep the same history, else DataError naming the entry.
  void merge_history(std::span<const ContactHistoryEntry> entries);
  /// The grains' roles of the last step (set_grain_roles; empty: every grain owned).
  std::span<const GrainRole> grain_roles() const;
  /// Per grain, the node and triangle checks of the candidates it was in while owned here, since
  /// the last call (zeros without roles), and starts counting again: the measured work a run
  /// split over ranks balances.
  std::vector<double> take_grain_work();
  /// Replaces the last step's records (contacts()) with `records`, in candidate order: a run split
  /// over ranks gathers every rank's on rank 0 to write them. The next step makes its own.
  void set_contacts(std::vector<ContactRecord> records);

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace graintwin::fdem
