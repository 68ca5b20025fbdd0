#pragma once
// The plain-data side of a run split over ranks (docs/fdemrun.md, across machines): what travels
// between ranks after each step (rigid grains' states, and the friction history of a grain that
// changes owner) packed as doubles, who must receive what, each grain's role on a rank after the
// exchange, and the step's sums rebuilt in the one-rank order from the rows the ranks exchanged.
// No MPI here: mpi/distributed_run moves the buffers. Every rank keeps the whole model (grains'
// shapes never change), so only state and history travel.
#include <Eigen/Core>
#include <cstdint>
#include <span>
#include <vector>

#include "graintwin/fdem/contact.hpp"
#include "graintwin/fdem/decomposition.hpp"
#include "graintwin/fdem/model.hpp"
#include "graintwin/fdem/solver.hpp"

namespace graintwin::fdem {

/// A rigid grain's state as it travels: its global index and its 6-DOF state.
struct GrainBody {
  std::uint32_t grain = 0;
  RigidBodyState state;
};

/// A rigid grain's last-step load as it travels to rank 0 for output.
struct GrainLoad {
  std::uint32_t grain = 0;
  RigidLoad load;
};

/// A deformable grain's nodes as they travel: to a rank that ghosts it, its surface nodes
/// (grain_surface_nodes order); to its new owner, or to rank 0 for output, all its nodes (node
/// order), for output with the forces the last step left on them (Solver::node_forces).
struct GrainNodes {
  std::uint32_t grain = 0;
  bool whole = false;   ///< all its nodes, else its surface nodes
  bool forces = false;  ///< each node's force follows its velocity
  std::vector<double> values;  ///< per node: position (3), velocity (3)[, force (3)]
};

/// What one rank sends another after a step: the states of the grains the receiver owns or ghosts
/// from now on (rigid grains' bodies, deformable grains' nodes), the friction history of the pairs
/// of those among them that change owner, and the sender's contacts with the wall or the membrane
/// (its boundary rows, the same to every rank). For output (a frame or a checkpoint written by rank 0) a rank sends rank 0 instead
/// the states of the grains it owns, and for the grains it advanced in the last step their loads,
/// the records of the candidates it owned and their pairs' history.
struct RankMessage {
  std::vector<GrainBody> bodies;
  std::vector<GrainNodes> nodes;
  std::vector<ContactHistoryEntry> history;
  StepRows rows;
  std::vector<GrainLoad> loads;
  std::vector<ContactRecord> records;
};

/// Doubles per packed RigidBodyState (position 3, quaternion w x y z, velocity 3, angular
/// momentum 3), per packed GrainBody (the grain's index, then its state) and per packed
/// ContactHistoryEntry (a, b, node, spring 3, offset).
inline constexpr std::size_t kStateDoubles = 13, kBodyDoubles = 1 + kStateDoubles, kHistoryDoubles = 7;
/// Doubles per packed GrainLoad (the grain's index, force 3, moment 9 row by row) and per packed
/// ContactRecord (a, b, point 3, normal 3, force 3, overlap, stiffness).
inline constexpr std::size_t kLoadDoubles = 13, kRecordDoubles = 13;

/// Appends `message` to `out` as doubles: [bodies, kBodyDoubles each..., grains of nodes, (grain,
/// 1 whole + 2 forces, values, the values) each..., entries, kHistoryDoubles each..., rows, (key,
/// kTermColumns values) each..., loads, kLoadDoubles each..., records, kRecordDoubles each...];
/// indices and keys are exact (below 2^53), values keep their bits.
void pack_message(const RankMessage& message, std::vector<double>& out);
/// The message pack_message wrote into `packed` (all of it). DataError when its counts do not
/// fit its length or an index is not a whole number in [0, 2^32) (a row key: [0, 2^53)).
RankMessage unpack_message(std::span<const double> packed);

/// A rank's sends after a step and what stays with it.
struct ExchangePlan {
  std::vector<RankMessage> to;          ///< per rank (this rank's own entry stays empty)
  std::vector<std::uint32_t> kept;      ///< owned grains still owned here, sorted
  std::vector<std::uint32_t> ghosted;   ///< owned grains that left but stay ghosts here, sorted
};

/// Who must hear of this rank's owned grains after a step.
///
/// Inputs:
///   subdomains  the ranks' boxes (bisect_domain); R = subdomains.ranks()
///   rank        this rank, in [0, R)
///   owned       the grains this rank advanced in the step, sorted
///   bodies      every grain's state, indexed by grain (the owned ones current)
///   radii       every grain's bounding radius about its centroid, m (grain_bounding_radii)
///   contact     this rank's contact model: the friction history of leaving grains
/// Returns, per grain g of `owned` with new owner o = owner_rank(centroid): its state to o and to
/// every rank of ghost_ranks(centroid, radius, o), this rank excepted; when o is another rank,
/// also the history of g's pairs to o. A grain that leaves stays here as a ghost when this rank is
/// one of its ghost ranks.
ExchangePlan plan_exchange(const Subdomains& subdomains, int rank, std::span<const std::uint32_t> owned,
                           std::span<const RigidBodyState> bodies, std::span<const double> radii,
                           const ContactModel& contact);

/// Every grain's role on `rank` after an exchange: owned if it stayed (plan.kept) or arrived with
/// its centroid in this rank's box (a deformable grain: with all its nodes), ghost if it left but
/// stays in reach (plan.ghosted) or arrived for another owner, else absent. `received`: the
/// messages from the other ranks.
std::vector<GrainRole> roles_after_exchange(const Subdomains& subdomains, int rank, std::size_t grains,
                                            const ExchangePlan& plan, std::span<const RankMessage> received);

/// Every grain's role on `rank` at the start, when every rank holds every grain's state: owned by
/// its centroid's box, ghost when `rank` is one of its ghost ranks.
std::vector<GrainRole> initial_roles(const Subdomains& subdomains, int rank, std::span<const RigidBodyState> bodies,
                                     std::span<const double> radii);

/// The sorted grains whose role is `role`.
std::vector<std::uint32_t> grains_with_role(std::span<const GrainRole> roles, GrainRole role);

/// Per grain, the radius of a sphere about its reference centroid (bodies[g].centroid) holding
/// all its nodes, m: a rigid grain's reach in any pose.
std::vector<double> grain_bounding_radii(const Model& model, std::span<const BodyProperties> bodies);

/// Per grain, its surface nodes (those of its triangles), sorted.
std::vector<std::vector<std::uint32_t>> grain_surface_nodes(const Model& model);

/// Work of one element's internal forces in a step, in node checks of contact (the unit of
/// ContactModel::take_grain_work), for 4- and 10-node elements: fdemrun's time accounts of 48
/// churning boxes gave 31 and 208 ns an element against 37 and 46 ns a check.
inline constexpr double kTet4ElementWork = 0.85, kTet10ElementWork = 4.5;

/// Per grain, its elements' work in one step (kTet4ElementWork, kTet10ElementWork; 0 for rigid
/// grains).
std::vector<double> element_work(const Model& model);

/// Per grain, its number of surface nodes plus its elements' work: the work weight of
/// bisect_domain until measured weights replace it (contact cost grows with the surface nodes).
std::vector<double> surface_node_work(const Model& model);

/// Every rank's boundary rows (Boundary::add_contact_forces) as one set in increasing key order.
/// DataError when a key comes twice (two ranks owning one grain).
StepRows sorted_rows(std::span<const StepRows> parts);

}  // namespace graintwin::fdem
