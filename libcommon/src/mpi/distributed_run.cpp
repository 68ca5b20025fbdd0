#include "graintwin/mpi/distributed_run.hpp"

#include <fmt/format.h>
#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <thread>
#include <tuple>

#include "graintwin/core/error.hpp"
#include "graintwin/core/interval.hpp"
#include "graintwin/fdem/results_file.hpp"

namespace graintwin::mpi {
namespace {

int int_count(std::size_t n) {
  if (n > static_cast<std::size_t>(std::numeric_limits<int>::max()))
    throw UsageError(fmt::format("{} doubles for one rank exceed MPI's int counts: use more ranks", n));
  return static_cast<int>(n);
}

/// Every rank's buffer for every other (outgoing[r]: to rank r), exchanged: returns, per rank r,
/// what r sent this one (empty: nothing). Sparse, point to point: a rank sends only its non-empty
/// buffers (MPI_Issend) and takes what comes until a barrier, which it enters once all its sends
/// were received (MPI_Ibarrier), is complete on every rank (Hoefler, Siebert and Lumsdaine's
/// NBX, 2010): no collective over all ranks for the counts, and a rank hears only from the ranks
/// that have something for it. Consecutive exchanges take turns between two tags, so that a rank
/// already in the next one cannot be heard in this one (it cannot be two ahead: every exchange
/// waits for every rank's barrier). `waited` (s) gains the time spent polling while nothing
/// arrived: the other ranks' lateness and the messages' latency, not this rank's handling.
std::vector<std::vector<double>> exchange_buffers(const std::vector<std::vector<double>>& outgoing, double* waited = nullptr) {
  const std::size_t ranks = outgoing.size();
  if (ranks == 1) return outgoing;  // one rank sends itself what it has, with or without MPI
  static int exchanges = 0;         // the same sequence on every rank
  const int tag = 1 + (exchanges++ & 1);
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  std::vector<std::vector<double>> incoming(ranks);
  incoming[rank] = outgoing[rank];
  std::vector<MPI_Request> sends;
  for (std::size_t r = 0; r < ranks; ++r)
    if (static_cast<int>(r) != rank && !outgoing[r].empty()) {
      sends.emplace_back();
      MPI_Issend(outgoing[r].data(), int_count(outgoing[r].size()), MPI_DOUBLE, static_cast<int>(r), tag, MPI_COMM_WORLD,
                 &sends.back());
    }
  MPI_Request barrier = MPI_REQUEST_NULL;
  for (bool done = false; !done;) {
    const double polled = waited ? monotonic_seconds() : 0.0;
    int arrived = 0;
    MPI_Status status;
    MPI_Iprobe(MPI_ANY_SOURCE, tag, MPI_COMM_WORLD, &arrived, &status);
    if (arrived) {
      int count = 0;
      MPI_Get_count(&status, MPI_DOUBLE, &count);
      std::vector<double>& into = incoming[status.MPI_SOURCE];
      into.resize(static_cast<std::size_t>(count));
      MPI_Recv(into.data(), count, MPI_DOUBLE, status.MPI_SOURCE, tag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    }
    // Nothing yet: let a rank sharing this core run (oversubscribed ranks, as MPI's own waits do).
    if (!arrived) std::this_thread::yield();
    int finished = 0;
    if (barrier == MPI_REQUEST_NULL) {
      MPI_Testall(static_cast<int>(sends.size()), sends.data(), &finished, MPI_STATUSES_IGNORE);
      if (finished) MPI_Ibarrier(MPI_COMM_WORLD, &barrier);
    } else {
      MPI_Test(&barrier, &finished, MPI_STATUS_IGNORE);
      done = finished;
    }
    if (waited && !arrived) *waited += monotonic_seconds() - polled;
  }
  return incoming;
}

}  // namespace

namespace {

/// A deformable grain's bounding radius grows by this share for its strain (elastic grains strain
/// far less): its ghosts must reach every rank it may touch.
constexpr double kStrainReach = 0.02;

}  // namespace

DistributedRun::DistributedRun(const Session& session, fdem::Solver& solver, const fdem::Aabb& domain)
    : session_(session), solver_(solver), domain_(domain) {
  solver.set_rank_share(this);  // refuses what does not run across ranks
  try {
    const fdem::Model& m = solver.model();
    std::vector<fdem::BodyProperties> bodies(m.grains.size());
    for (std::size_t g = 0; g < bodies.size(); ++g) bodies[g] = solver.body(g);
    radii_ = fdem::grain_bounding_radii(m, bodies);
    surface_ = fdem::grain_surface_nodes(m);
    for (std::size_t g = 0; g < m.grains.size(); ++g) {
      if (m.grains[g].kind == fdem::GrainKind::rigid) surface_[g].clear();  // a body travels
      else radii_[g] *= 1 + kStrainReach, deformable_ = true;
    }
    element_work_ = fdem::element_work(m);
    busy_mark_ = busy_seconds();  // the solver may have stepped alone before
    std::vector<std::uint32_t> every(m.grains.size());
    std::iota(every.begin(), every.end(), 0u);
    const std::span<const fdem::RigidBodyState> states = places(every);
    std::vector<Eigen::Vector3d> centroids;
    for (const fdem::RigidBodyState& s : states) centroids.push_back(s.position);
    subdomains_ = fdem::bisect_domain(centroids, radii_, fdem::surface_node_work(m), domain, session.size(),
                                      solver.contact_model()->skin());
    roles_ = fdem::initial_roles(subdomains_, session.rank(), states, radii_);
    owned_ = fdem::grains_with_role(roles_, fdem::GrainRole::owned);
  } catch (...) {
    solver.set_rank_share(nullptr);
    throw;
  }
}

DistributedRun::~DistributedRun() { solver_.set_rank_share(nullptr); }

double DistributedRun::busy_seconds() const {
  const fdem::StepTimes& t = solver_.step_times();
  return t.elements + t.contact + t.motion - traffic_.exchange_seconds;
}

std::span<const fdem::RigidBodyState> DistributedRun::places(std::span<const std::uint32_t> grains) {
  const fdem::Model& m = solver_.model();
  const std::span<const fdem::RigidBodyState> states = solver_.rigid_states();
  if (!deformable_) return states;
  places_.assign(states.begin(), states.end());
  for (std::uint32_t g : grains)
    if (m.grains[g].kind != fdem::GrainKind::rigid) places_[g].position = solver_.grain_centroid(g);
  return places_;
}

fdem::GrainNodes DistributedRun::nodes_of(std::uint32_t grain, bool whole, bool forces) const {
  const fdem::Grain& g = solver_.model().grains[grain];
  const fdem::SolverState& s = solver_.state();
  const std::span<const Eigen::Vector3d> f = solver_.node_forces();
  fdem::GrainNodes out{grain, whole, forces, {}};
  const auto add = [&](std::uint32_t n) {
    out.values.insert(out.values.end(), {s.x[n].x(), s.x[n].y(), s.x[n].z(), s.v[n].x(), s.v[n].y(), s.v[n].z()});
    if (forces) out.values.insert(out.values.end(), {f[n].x(), f[n].y(), f[n].z()});
  };
  if (whole)
    for (std::uint32_t n = g.node_begin; n < g.node_end; ++n) add(n);
  else
    for (std::uint32_t n : surface_[grain]) add(n);
  return out;
}

void DistributedRun::take_nodes(const fdem::GrainNodes& nodes) {
  const fdem::Model& m = solver_.model();
  const std::size_t per_node = nodes.forces ? 9 : 6;
  if (nodes.grain >= m.grains.size() || m.grains[nodes.grain].kind == fdem::GrainKind::rigid ||
      nodes.values.size() !=
          per_node * (nodes.whole ? m.grains[nodes.grain].node_end - m.grains[nodes.grain].node_begin
                                  : surface_[nodes.grain].size()))
    throw DataError(fmt::format("a rank sent {} node values for grain {}, which are not its nodes in this model; the ranks "
                                "must run the same model",
                                nodes.values.size(), nodes.grain));
  const fdem::Grain& g = m.grains[nodes.grain];
  const double* v = nodes.values.data();
  const auto set = [&](std::uint32_t n) {
    solver_.set_node_state(n, Eigen::Vector3d(v[0], v[1], v[2]), Eigen::Vector3d(v[3], v[4], v[5]));
    if (nodes.forces) solver_.set_node_force(n, Eigen::Vector3d(v[6], v[7], v[8]));
    v += per_node;
  };
  if (nodes.whole)
    for (std::uint32_t n = g.node_begin; n < g.node_end; ++n) set(n);
  else
    for (std::uint32_t n : surface_[nodes.grain]) set(n);
}

std::uint64_t DistributedRun::migration_doubles(int rank, const fdem::RankMessage& message) const {
  std::uint64_t doubles = fdem::kHistoryDoubles * message.history.size();
  for (const fdem::GrainBody& b : message.bodies)
    if (fdem::owner_rank(subdomains_, b.state.position) == rank) doubles += fdem::kBodyDoubles;
  for (const fdem::GrainNodes& n : message.nodes)
    if (n.whole) doubles += 3 + n.values.size();
  return doubles;
}

void DistributedRun::send_nodes(int rank, std::vector<fdem::GrainBody>& bodies, std::vector<fdem::GrainNodes>& nodes) const {
  const fdem::Model& m = solver_.model();
  std::erase_if(bodies, [&](const fdem::GrainBody& b) {
    if (m.grains[b.grain].kind == fdem::GrainKind::rigid) return false;
    nodes.push_back(nodes_of(b.grain, fdem::owner_rank(subdomains_, b.state.position) == rank, false));
    return true;
  });
}

void DistributedRun::finish_step(fdem::StepTotals& totals, fdem::StepRows& boundary_rows) {
  const double start = monotonic_seconds();
  const int rank = session_.rank();
  ++steps_measured_;
  fdem::ExchangePlan plan = fdem::plan_exchange(subdomains_, rank, owned_, places(owned_), radii_, *solver_.contact_model());
  std::vector<std::vector<double>> outgoing(plan.to.size());
  for (std::size_t r = 0; r < plan.to.size(); ++r) {
    if (static_cast<int>(r) == rank) continue;
    fdem::RankMessage& message = plan.to[r];
    message.rows = boundary_rows;
    send_nodes(static_cast<int>(r), message.bodies, message.nodes);
    // A rank with nothing for r sends it nothing (the exchange is point to point).
    if (message.bodies.empty() && message.nodes.empty() && message.history.empty() && message.rows.keys.empty()) continue;
    fdem::pack_message(message, outgoing[r]);
    traffic_.migration_doubles += migration_doubles(static_cast<int>(r), message);
    traffic_.bodies += plan.to[r].bodies.size() + plan.to[r].nodes.size();
    traffic_.history += plan.to[r].history.size();
    traffic_.doubles += outgoing[r].size();
  }
  traffic_.migrations += owned_.size() - plan.kept.size();
  bool migrating = owned_.size() != plan.kept.size();
  const std::vector<std::vector<double>> incoming = exchange_buffers(outgoing, &traffic_.wait_seconds);
  // The step's sums: every rank's exact accumulators added, and the deepest overlap.
  const std::size_t words = sum_over_ranks(session_, totals.accumulators(), totals.max_overlap);
  traffic_.doubles += words;
  traffic_.sum_words += words;
  std::vector<fdem::RankMessage> received;
  std::vector<fdem::StepRows> parts{std::move(boundary_rows)};
  for (std::size_t r = 0; r < incoming.size(); ++r)
    if (static_cast<int>(r) != rank && !incoming[r].empty()) {
      received.push_back(fdem::unpack_message(incoming[r]));
      parts.push_back(std::move(received.back().rows));
    }
  boundary_rows = fdem::sorted_rows(parts);
  roles_ = fdem::roles_after_exchange(subdomains_, rank, roles_.size(), plan, received);
  owned_ = fdem::grains_with_role(roles_, fdem::GrainRole::owned);
  for (const fdem::RankMessage& m : received) {
    for (const fdem::GrainBody& b : m.bodies) solver_.set_rigid_state(b.grain, b.state);
    for (const fdem::GrainNodes& n : m.nodes) take_nodes(n);
    solver_.contact_model()->merge_history(m.history);
  }
  migrating = migrating || owned_.size() != plan.kept.size();  // grains came
  ++traffic_.steps;
  const double seconds = monotonic_seconds() - start;
  traffic_.exchange_seconds += seconds;
  if (migrating) ++traffic_.migration_steps, traffic_.migration_step_seconds += seconds;
}

std::vector<std::uint32_t> DistributedRun::advanced() const {
  // Their owners may have changed since the step; before the first step they are the owned ones.
  const fdem::ContactModel& contact = *solver_.contact_model();
  return fdem::grains_with_role(contact.grain_roles().empty() ? std::span<const fdem::GrainRole>(roles_) : contact.grain_roles(),
                                fdem::GrainRole::owned);
}

void DistributedRun::write_checkpoint(const std::filesystem::path& path, const std::string& scene_digest, char set,
                                      const std::function<void(io::H5File&)>& also) {
  const int rank = session_.rank();
  std::unique_ptr<fdem::CheckpointPartFile> file;
  std::string failure;
  try {
    file = std::make_unique<fdem::CheckpointPartFile>(path, solver_, scene_digest, advanced(), rank, session_.size(), set, also);
    if (rank != 0) file->place();  // the main file names it only once every part is whole
  } catch (const Error& e) {
    failure = e.message();
  }
  const std::uint64_t failed = sum_over_ranks(session_, std::uint64_t{failure.empty() ? 0u : 1u});
  if (failed > 0)
    throw DataError(failure.empty() ? fmt::format("{} other rank(s) could not write their part of checkpoint {}; the last "
                                                  "checkpoint stays as it was",
                                                  failed, path.string())
                                    : failure);
  if (rank == 0) file->place();
  sum_over_ranks(session_, std::uint64_t{0});  // the main file names this set now: the other set's parts can go
  file->drop_other_set();
}

void DistributedRun::gather_output() {
  fdem::ContactModel& contact = *solver_.contact_model();
  // The grains advanced in the last step hold its loads and records.
  const std::span<const fdem::GrainRole> stepped = contact.grain_roles().empty() ? std::span<const fdem::GrainRole>(roles_)
                                                                                   : contact.grain_roles();
  const std::vector<std::uint32_t> advanced = this->advanced();
  fdem::RankMessage mine;
  const fdem::Model& model = solver_.model();
  const std::span<const fdem::RigidBodyState> states = solver_.rigid_states();
  const auto rigid = [&](std::uint32_t g) { return model.grains[g].kind == fdem::GrainKind::rigid; };
  for (std::uint32_t g : owned_)
    if (rigid(g)) mine.bodies.push_back({g, states[g]});
  // A deformable grain's nodes and forces from the rank that advanced it (its state since).
  for (std::uint32_t g : advanced)
    if (rigid(g)) mine.loads.push_back({g, solver_.rigid_load(g)});
    else mine.nodes.push_back(nodes_of(g, true, true));
  for (const fdem::ContactRecord& r : contact.contacts())
    if (stepped[r.a] == fdem::GrainRole::owned) mine.records.push_back(r);
  mine.history = contact.history_of(advanced);
  std::vector<std::vector<double>> outgoing(session_.size());
  if (session_.rank() != 0) fdem::pack_message(mine, outgoing[0]);
  const std::vector<std::vector<double>> incoming = exchange_buffers(outgoing);
  if (session_.rank() != 0) return;
  std::vector<fdem::ContactRecord> records = std::move(mine.records);
  for (std::size_t r = 1; r < incoming.size(); ++r) {
    if (incoming[r].empty()) continue;
    const fdem::RankMessage m = fdem::unpack_message(incoming[r]);
    for (const fdem::GrainBody& b : m.bodies) solver_.set_rigid_state(b.grain, b.state);
    for (const fdem::GrainNodes& n : m.nodes) take_nodes(n);
    for (const fdem::GrainLoad& l : m.loads) solver_.set_rigid_load(l.grain, l.load);
    records.insert(records.end(), m.records.begin(), m.records.end());
    contact.merge_history(m.history);
  }
  // One rank records candidates in (a, b) order, and each candidate has one owner here.
  std::sort(records.begin(), records.end(),
            [](const fdem::ContactRecord& p, const fdem::ContactRecord& q) { return std::tie(p.a, p.b) < std::tie(q.a, q.b); });
  contact.set_contacts(std::move(records));
}

bool DistributedRun::rebalance(bool force) {
  // The ranks' loads are the seconds each spent on its grains since the last decision: one number
  // per rank, not every grain's work and state.
  const double busy = busy_seconds();
  std::vector<double> loads(session_.size(), 0.0);
  loads[session_.rank()] = busy - busy_mark_;
  sum_over_ranks(session_, loads);  // one rank contributes each entry: exact
  // A short window cannot tell imbalance from the machine's jitter: measure on.
  if (!force && *std::max_element(loads.begin(), loads.end()) < kBalanceWindowSeconds) return false;
  fdem::ContactModel& contact = *solver_.contact_model();
  std::vector<double> work = contact.take_grain_work();  // this rank's checks, per grain it owned
  // Its elements each step, and its motion, about one check a step (the motion's share of a
  // one-rank step over its checks, pressed 1 989-grain twin), counted for the grains owned now:
  // close enough for a decision taken every kBalanceCheckSteps.
  const double steps = static_cast<double>(steps_measured_);
  for (std::uint32_t g : owned_) work[g] += std::round(element_work_[g] * steps) + steps;
  steps_measured_ = 0;
  busy_mark_ = busy;
  // The window after a cut holds the one-off cost of the grains taken over (their pairs' lists
  // built): not the balance to judge the cut by.
  const bool settling = just_cut_;
  just_cut_ = false;
  if (!force && (settling || !fdem::needs_rebalance(loads))) return false;
  if (!force) fdem::weigh_by_time(work, loads[session_.rank()]);  // the counts share the rank's seconds
  sum_over_ranks(session_, work);  // each grain's work from the ranks that held it: whole numbers
  for (double& w : work) w = std::max(w, 1.0);  // a grain never weighs nothing
  const std::vector<fdem::RigidBodyState> all = gather_states();
  std::vector<Eigen::Vector3d> centroids;
  for (const fdem::RigidBodyState& s : all) centroids.push_back(s.position), domain_.grow(s.position);
  fdem::Subdomains next;
  try {
    next = fdem::bisect_domain(centroids, radii_, work, domain_, session_.size(), contact.skin());
  } catch (const UsageError&) {
    return false;  // no cut by these weights leaves every box thick enough (on every rank alike): keep this one
  }
  // Every rank takes every grain's state (a deformable grain's nodes from its owner) and every
  // rank's friction history, then its new share.
  const fdem::Model& m = solver_.model();
  std::vector<std::uint32_t> every(all.size());
  std::iota(every.begin(), every.end(), 0u);
  fdem::RankMessage mine;
  mine.history = contact.history_of(every);
  for (std::uint32_t g : owned_)
    if (m.grains[g].kind != fdem::GrainKind::rigid) mine.nodes.push_back(nodes_of(g, true, false));
  std::vector<double> packed;
  fdem::pack_message(mine, packed);
  std::vector<std::vector<double>> outgoing(session_.size(), packed);
  outgoing[session_.rank()].clear();
  for (const auto& buffer : exchange_buffers(outgoing))
    if (!buffer.empty()) {
      const fdem::RankMessage theirs = fdem::unpack_message(buffer);
      contact.merge_history(theirs.history);
      for (const fdem::GrainNodes& n : theirs.nodes) take_nodes(n);
    }
  for (std::size_t g = 0; g < all.size(); ++g)
    if (m.grains[g].kind == fdem::GrainKind::rigid) solver_.set_rigid_state(g, all[g]);
  subdomains_ = std::move(next);
  roles_ = fdem::initial_roles(subdomains_, session_.rank(), all, radii_);
  owned_ = fdem::grains_with_role(roles_, fdem::GrainRole::owned);
  ++rebalances_;
  just_cut_ = true;
  return true;
}

std::vector<fdem::RigidBodyState> DistributedRun::gather_states() const {
  const std::span<const fdem::RigidBodyState> states = solver_.rigid_states();
  fdem::RankMessage mine;
  for (std::uint32_t g : owned_)
    if (solver_.model().grains[g].kind == fdem::GrainKind::rigid) mine.bodies.push_back({g, states[g]});
    else mine.bodies.push_back({g, fdem::RigidBodyState{solver_.grain_centroid(g)}});
  std::vector<double> packed;
  fdem::pack_message(mine, packed);
  std::vector<fdem::RigidBodyState> all(states.size());
  std::vector<char> seen(states.size(), 0);
  for (const auto& buffer : exchange_buffers(std::vector<std::vector<double>>(session_.size(), packed)))
    for (const fdem::GrainBody& b : fdem::unpack_message(buffer).bodies) {
      if (b.grain >= all.size() || seen[b.grain]++)
        throw DataError(fmt::format("grain {} came twice or from outside a model of {} grains: every grain needs one "
                                    "owner",
                                    b.grain, all.size()));
      all[b.grain] = b.state;
    }
  if (const auto missing = std::find(seen.begin(), seen.end(), 0); missing != seen.end())
    throw DataError(fmt::format("no rank owns grain {}: every grain needs one owner", missing - seen.begin()));
  return all;
}

void check_runs_across_ranks(const Session& session, const fdem::Scene& scene, const std::string& where) {
  if (session.size() == 1) return;
  const auto one_rank = [&](const std::string& what) {
    return UsageError(fmt::format("{}: {} runs on one rank so far (docs/fdemrun.md, across machines); run it without "
                                  "mpirun, or with -np 1",
                                  where, what));
  };
  if (scene.elastostatic_stress) throw one_rank("[run] rigid_stress = \"elastostatic\"");
  if (scene.implicit_grains && scene.has_deformable_grains())
    throw one_rank("[run] deformable_integration = \"implicit\" with deformable grains");
}

std::unique_ptr<DistributedRun> split_over_ranks(const Session& session, fdem::Solver& solver) {
  if (session.size() == 1) return nullptr;
  fdem::Aabb domain;  // with room for round-off
  for (const Eigen::Vector3d& x : solver.state().x) domain.grow(x);
  return std::make_unique<DistributedRun>(session, solver, domain.inflated(1e-6 * (domain.hi - domain.lo).norm()));
}

}  // namespace graintwin::mpi
