#pragma once
// The FDEM solver stepping a sample across MPI ranks (docs/fdemrun.md, across machines). Every rank builds the same Solver (the whole model, the same options and initial
// state) and hands it to a DistributedRun, which splits the grains by bisect_domain boxes of their
// centroids and then, each step: the solver advances the grains this rank owns, with contact among
// its owned grains and ghosts (a pair between two ranks' grains is evaluated on both, each keeping
// the force on its own grain); then, in one exchange, each owner sends its grains' states to the
// ranks that ghost them (a rigid grain's body, a deformable grain's surface nodes), a grain whose
// centroid left its owner's box goes to the new owner (a deformable grain with all its nodes) with
// its pairs' friction history, and the ranks add their exact sums of the step (core/exact_sum:
// the same bits in any order). The ghost lists are refreshed every step. A triaxial test's wall or
// membrane is held whole by every rank: each rank's contacts of its grains with it travel as terms
// of the step, and every rank moves the wall or the balls alike from all of them, so the servo
// reads the same stresses everywhere. The plain-data side is fdem/rank_state.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "graintwin/fdem/decomposition.hpp"
#include "graintwin/fdem/rank_state.hpp"
#include "graintwin/fdem/scene.hpp"
#include "graintwin/fdem/solver.hpp"
#include "graintwin/mpi/session.hpp"

namespace graintwin::mpi {

/// What a rank sent since the run started (its own sends; sum_over_ranks for the run's), and the
/// time its steps spent in the exchange (waiting for slower ranks included).
struct RankTraffic {
  std::uint64_t bodies = 0;      ///< grain states sent (ghost updates and migrations; a deformable grain's nodes count one)
  std::uint64_t history = 0;     ///< friction history entries sent with migrating grains
  std::uint64_t migrations = 0;  ///< grains that left this rank for another owner
  std::uint64_t doubles = 0;     ///< 8-byte values sent: the exchanges' doubles and the step sums' words
  std::uint64_t sum_words = 0;   ///< of them, the step sums' words
  std::uint64_t migration_doubles = 0;  ///< of them, the migrating grains' states and friction history
  double exchange_seconds = 0;   ///< s, planning, packing, exchanging and unpacking
  /// s, of them, polling while nothing had arrived: waiting for later ranks and the messages'
  /// latency (the rest is this rank's handling, and the sums' MPI_Allreduce)
  double wait_seconds = 0;
  std::uint64_t steps = 0;       ///< steps exchanged
  /// Steps in which grains left or came to this rank, and the exchange's seconds in them: beside
  /// the other steps' mean, what migrating costs (migration_seconds).
  std::uint64_t migration_steps = 0;
  double migration_step_seconds = 0;
  /// s, the exchange's time in the steps that moved grains beyond the other steps' mean (0 when
  /// no step or every step moved grains): the cost of migrating, packing to taking in.
  double migration_seconds() const {
    if (migration_steps == 0 || migration_steps == steps) return 0.0;
    const double other = (exchange_seconds - migration_step_seconds) / static_cast<double>(steps - migration_steps);
    return migration_step_seconds - other * static_cast<double>(migration_steps);
  }
};

class DistributedRun final : public fdem::RankShare {
 public:
  /// Splits `solver`'s grains over the session's ranks: bisect_domain of the grains' centroids in
  /// `domain` (m, the sample's box; every centroid inside), weighted by their surface nodes, with
  /// the contact model's skin. Collective: every rank passes a solver built alike. The solver must
  /// outlive the run; it steps this rank's share until the run ends. UsageError from
  /// Solver::set_rank_share (no contact) or bisect_domain (too many ranks for the sample:
  /// subdomains thinner than a grain), on every rank alike.
  DistributedRun(const Session& session, fdem::Solver& solver, const fdem::Aabb& domain);
  /// Hands the solver back to stepping every grain (its states of other ranks' grains are stale).
  ~DistributedRun() override;
  DistributedRun(const DistributedRun&) = delete;
  DistributedRun& operator=(const DistributedRun&) = delete;

  /// One step of dt (s) on every rank (collective): the solver's step of the owned grains and the
  /// exchange; the report's energies and contact sums are the whole run's (node_checks,
  /// triangle_checks, pairs and pair_lists_built are this rank's work).
  fdem::StepReport step(double dt) { return solver_.step(dt); }

  const fdem::Subdomains& subdomains() const { return subdomains_; }
  /// Per grain, its role on this rank in the next step.
  std::span<const fdem::GrainRole> roles() const override { return roles_; }
  /// The grains this rank owns now, sorted.
  std::span<const std::uint32_t> owned() const { return owned_; }
  const RankTraffic& traffic() const { return traffic_; }
  /// Every grain's state from its owner, on every rank (collective): for output and checks. A
  /// deformable grain's is its centroid (position) alone.
  std::vector<fdem::RigidBodyState> gather_states() const;
  /// Checks the ranks' balance (collective; the same decision and cut on every rank). The load of a
  /// rank is the seconds it spent on its grains (its step phases outside the exchange, the
  /// boundary's aside) since the last decision: the check sends one number per rank. It decides
  /// once the longest load reaches kBalanceWindowSeconds, and not on the window right after a cut
  /// (the grains taken over build their pairs' lists then). When the loads differ by more than
  /// kRebalanceImbalance (or `force`), it weighs every grain by the work counted since (the checks
  /// of its contact candidates on the rank that owned it, the nodes its pairs' lists visited, its
  /// elements' work and one check for its motion each step), each rank's counts sharing its
  /// seconds (fdem::weigh_by_time), and cuts the sample again with them. A forced cut weighs the
  /// counts alone: the same cut on every run (timings are not). Each rank then holds every
  /// grain's state and the whole friction history, and takes the grains its new box holds; the
  /// run goes on with the same bits. Returns whether it cut again.
  bool rebalance(bool force = false);
  /// Times the sample was cut again since the start.
  std::size_t rebalances() const { return rebalances_; }

  /// Gives rank 0's solver what one rank's solver would hold after the last step (collective):
  /// every grain's state, every rigid grain's load, every deformable grain's node forces, the
  /// contact records in candidate order and the friction history, sent by their owners. Rank 0 then writes frames and checkpoints alone.
  /// The other ranks' solvers are unchanged, and so is stepping: what rank 0 received for the
  /// grains it ghosts is what their owners sent it, and its absent grains take no part in its steps.
  void gather_output();

  /// Writes a checkpoint at `path` with every rank at once (collective; fdem::write_checkpoint_part):
  /// each rank the rows of the grains it advanced in the last step, rank 0 the main file with the
  /// shared state and `also`'s, the others their part of `set` beside it. The main file takes its
  /// place once every part is whole, and the parts of the other set go then. DataError on every
  /// rank when one could not write (the last checkpoint stays whole).
  void write_checkpoint(const std::filesystem::path& path, const std::string& scene_digest, char set,
                        const std::function<void(io::H5File&)>& also);

  /// The exchange, from within the solver's step once the owned grains moved: sends the owned
  /// grains' states to their ghost ranks, migrants with their pairs' history to their new owners
  /// and this rank's contacts with the wall or the membrane to every rank, takes the others', adds
  /// the ranks' exact sums of the step (energies, contact sums, platen forces) and sets the roles
  /// for the next step. Messages point to point to the ranks this one has something for and a
  /// barrier (the exchange), and two MPI_Allreduce (the sums).
  void finish_step(fdem::StepTotals& totals, fdem::StepRows& boundary_rows) override;

 private:

  /// The grains this rank advanced in the last step (before any step, those it owns), sorted: it
  /// holds their loads, node forces, contact records and friction history.
  std::vector<std::uint32_t> advanced() const;
  /// s this rank's solver spent stepping (its step phases but the boundary's, which every rank
  /// does whole) outside the exchange, since the start.
  double busy_seconds() const;
  /// Every grain's state as a body for the exchange's plan: `grains`' (the owned ones) current,
  /// a deformable grain's centroid as its position.
  std::span<const fdem::RigidBodyState> places(std::span<const std::uint32_t> grains);
  /// Deformable grain g's nodes as they travel (whole: all of them, else its surface).
  fdem::GrainNodes nodes_of(std::uint32_t grain, bool whole, bool forces) const;
  /// Sets the nodes a message brought. DataError when they do not fit the grain.
  void take_nodes(const fdem::GrainNodes& nodes);
  /// The doubles of `message` (to `rank`) that carry grains changing owner to it: their states and
  /// the friction history of their pairs.
  std::uint64_t migration_doubles(int rank, const fdem::RankMessage& message) const;
  /// Moves each deformable grain of `bodies` (a plan's states for `rank`) into `nodes`: all its
  /// nodes when `rank` owns it from now on, else its surface.
  void send_nodes(int rank, std::vector<fdem::GrainBody>& bodies, std::vector<fdem::GrainNodes>& nodes) const;

  const Session& session_;
  fdem::Solver& solver_;
  std::vector<std::vector<std::uint32_t>> surface_;  ///< per deformable grain, its surface nodes
  bool deformable_ = false;                          ///< the model has deformable grains
  std::vector<double> element_work_;                 ///< per grain, its elements' work a step
  std::vector<fdem::RigidBodyState> places_;         ///< scratch of places()
  std::uint64_t steps_measured_ = 0;                 ///< steps since the work was last taken
  double busy_mark_ = 0;                             ///< busy_seconds() when the work was last taken
  bool just_cut_ = false;                            ///< the last decision cut the sample again
  std::vector<double> radii_;  ///< per grain, m (grain_bounding_radii)
  fdem::Aabb domain_;          ///< the box cut at the start, grown by the grains that left it
  std::size_t rebalances_ = 0;
  fdem::Subdomains subdomains_;
  std::vector<fdem::GrainRole> roles_;
  std::vector<std::uint32_t> owned_;
  RankTraffic traffic_;
};

/// What a scene asks for that runs on one rank only, refused (UsageError naming `where`, the scene
/// file) on several ranks before the model is built: [run] rigid_stress = "elastostatic", and
/// deformable_integration = "implicit" where the model holds deformable grains.
/// Nothing on one rank.
void check_runs_across_ranks(const Session& session, const fdem::Scene& scene, const std::string& where);

/// The run of `solver` split over the session's ranks (collective), or nullptr on one rank: the
/// sample's box is that of every node where it is now (after a restart, where the grains are then).
std::unique_ptr<DistributedRun> split_over_ranks(const Session& session, fdem::Solver& solver);

/// Steps between two checks of the ranks' balance (DistributedRun::rebalance): an MPI_Allreduce of
/// one number per rank.
inline constexpr std::uint64_t kBalanceCheckSteps = 100;
/// s, the least a rank's measured load spans before the balance is judged: the machine's jitter
/// (ms) stays a few per cent of it, and a cut again (every grain's state gathered, lists built
/// again) costs tens of ms at 2 000 grains.
inline constexpr double kBalanceWindowSeconds = 0.25;

}  // namespace graintwin::mpi
