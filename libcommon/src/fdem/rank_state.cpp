#include "graintwin/fdem/rank_state.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "graintwin/core/error.hpp"

namespace graintwin::fdem {
namespace {

/// Reads packed doubles in order, refusing to read past the end.
class Reader {
 public:
  explicit Reader(std::span<const double> data) : data_(data) {}
  /// The next n doubles, in place.
  const double* take(std::size_t n) {
    if (data_.size() - at_ < n) too_short();
    at_ += n;
    return data_.data() + at_ - n;
  }
  double next() { return *take(1); }
  /// A packed index or count: a whole number in [0, 2^32).
  std::uint32_t index() { return static_cast<std::uint32_t>(whole(4294967296.0)); }
  /// A packed row key: a whole number in [0, 2^53), where doubles hold every integer.
  std::uint64_t key() { return whole(9007199254740992.0); }
  Eigen::Vector3d vector() {
    const double* d = take(3);
    return {d[0], d[1], d[2]};
  }
  /// A packed count of entries of `size` doubles each, checked against what is left before it
  /// sizes anything (a damaged count must not allocate).
  std::size_t count(std::size_t size) {
    const std::uint32_t n = index();
    if (n > (data_.size() - at_) / size) too_short();
    return n;
  }
  bool done() const { return at_ == data_.size(); }

 private:
  std::uint64_t whole(double below) {
    const double d = next();
    if (!(d >= 0 && d < below) || d != std::floor(d))
      throw DataError(fmt::format("a rank's message holds {} where an index belongs; the ranks must run the same program", d));
    return static_cast<std::uint64_t>(d);
  }
  [[noreturn]] void too_short() const {
    throw DataError(fmt::format("a rank's message of {} doubles ends inside an entry; the ranks must run the same program",
                                data_.size()));
  }
  std::span<const double> data_;
  std::size_t at_ = 0;
};

void append(std::vector<double>& out, const Eigen::Vector3d& v) { out.insert(out.end(), {v[0], v[1], v[2]}); }

/// Appends a state's kStateDoubles to `out`, bits kept.
void append_state(const RigidBodyState& s, std::vector<double>& out) {
  append(out, s.position);
  out.insert(out.end(), {s.orientation.w(), s.orientation.x(), s.orientation.y(), s.orientation.z()});
  append(out, s.velocity);
  append(out, s.angular_momentum);
}

/// The state append_state wrote at `d`.
RigidBodyState state_from(const double* d) {
  return {Eigen::Vector3d(d[0], d[1], d[2]), Eigen::Quaterniond(d[3], d[4], d[5], d[6]), Eigen::Vector3d(d[7], d[8], d[9]),
          Eigen::Vector3d(d[10], d[11], d[12])};
}

}  // namespace

void pack_message(const RankMessage& message, std::vector<double>& out) {
  out.push_back(static_cast<double>(message.bodies.size()));
  for (const GrainBody& b : message.bodies) {
    out.push_back(b.grain);
    append_state(b.state, out);
  }
  out.push_back(static_cast<double>(message.nodes.size()));
  for (const GrainNodes& n : message.nodes) {
    out.insert(out.end(), {double(n.grain), double(n.whole) + 2.0 * double(n.forces), double(n.values.size())});
    out.insert(out.end(), n.values.begin(), n.values.end());
  }
  out.push_back(static_cast<double>(message.history.size()));
  for (const ContactHistoryEntry& h : message.history) {
    out.insert(out.end(), {double(h.a), double(h.b), double(h.node)});
    append(out, h.spring);
    out.push_back(h.offset);
  }
  out.push_back(static_cast<double>(message.rows.keys.size()));
  for (std::size_t i = 0; i < message.rows.keys.size(); ++i) {
    out.push_back(static_cast<double>(message.rows.keys[i]));
    out.insert(out.end(), message.rows.values.begin() + i * kTermColumns,
               message.rows.values.begin() + (i + 1) * kTermColumns);
  }
  out.push_back(static_cast<double>(message.loads.size()));
  for (const GrainLoad& l : message.loads) {
    out.push_back(l.grain);
    append(out, l.load.force);
    for (int r = 0; r < 3; ++r) append(out, l.load.moment.row(r).transpose());
  }
  out.push_back(static_cast<double>(message.records.size()));
  for (const ContactRecord& c : message.records) {
    out.insert(out.end(), {double(c.a), double(c.b)});
    append(out, c.point);
    append(out, c.normal);
    append(out, c.force);
    out.insert(out.end(), {c.overlap, c.stiffness});
  }
}

RankMessage unpack_message(std::span<const double> packed) {
  Reader in(packed);
  RankMessage m;
  m.bodies.resize(in.count(kBodyDoubles));
  for (GrainBody& b : m.bodies) {
    b.grain = in.index();
    b.state = state_from(in.take(kStateDoubles));
  }
  m.nodes.resize(in.count(3));
  for (GrainNodes& n : m.nodes) {
    n.grain = in.index();
    const std::uint32_t flags = in.index();
    if (flags > 3)
      throw DataError(fmt::format("a rank's message holds node flags {}; the ranks must run the same program", flags));
    n.whole = flags & 1;
    n.forces = flags & 2;
    const std::size_t count = in.count(1);
    if (count % (n.forces ? 9 : 6) != 0)
      throw DataError(fmt::format("a rank's message holds {} node values for grain {}, not whole nodes; the ranks must "
                                  "run the same program",
                                  count, n.grain));
    const double* v = in.take(count);
    n.values.assign(v, v + count);
  }
  m.history.resize(in.count(kHistoryDoubles));
  for (ContactHistoryEntry& h : m.history) {
    h.a = in.index(), h.b = in.index(), h.node = in.index();
    h.spring = in.vector();
    h.offset = in.next();
  }
  const std::size_t rows = in.count(1 + kTermColumns);
  for (std::size_t i = 0; i < rows; ++i) {
    m.rows.keys.push_back(in.key());
    const double* v = in.take(kTermColumns);
    m.rows.values.insert(m.rows.values.end(), v, v + kTermColumns);
  }
  m.loads.resize(in.count(kLoadDoubles));
  for (GrainLoad& l : m.loads) {
    l.grain = in.index();
    l.load.force = in.vector();
    for (int r = 0; r < 3; ++r) l.load.moment.row(r) = in.vector().transpose();
  }
  m.records.resize(in.count(kRecordDoubles));
  for (ContactRecord& c : m.records) {
    c.a = in.index(), c.b = in.index();
    c.point = in.vector();
    c.normal = in.vector();
    c.force = in.vector();
    c.overlap = in.next();
    c.stiffness = in.next();
  }
  if (!in.done())
    throw DataError(fmt::format("a rank's message of {} doubles holds more than its counts say; the ranks must run the "
                                "same program",
                                packed.size()));
  return m;
}

ExchangePlan plan_exchange(const Subdomains& subdomains, int rank, std::span<const std::uint32_t> owned,
                           std::span<const RigidBodyState> bodies, std::span<const double> radii,
                           const ContactModel& contact) {
  ExchangePlan plan;
  plan.to.resize(subdomains.ranks());
  std::vector<std::vector<std::uint32_t>> leaving(subdomains.ranks());  // per new owner
  for (std::uint32_t g : owned) {
    const Eigen::Vector3d& centre = bodies[g].position;
    const int owner = owner_rank(subdomains, centre);
    std::vector<int> receivers = ghost_ranks(subdomains, centre, radii[g], owner);
    if (owner == rank) {
      plan.kept.push_back(g);
    } else {
      leaving[owner].push_back(g);
      if (std::binary_search(receivers.begin(), receivers.end(), rank)) plan.ghosted.push_back(g);
      receivers.push_back(owner);
    }
    for (int r : receivers)
      if (r != rank) plan.to[r].bodies.push_back({g, bodies[g]});
  }
  for (int r = 0; r < subdomains.ranks(); ++r)
    if (!leaving[r].empty()) plan.to[r].history = contact.history_of(leaving[r]);
  return plan;
}

std::vector<GrainRole> roles_after_exchange(const Subdomains& subdomains, int rank, std::size_t grains,
                                            const ExchangePlan& plan, std::span<const RankMessage> received) {
  std::vector<GrainRole> roles(grains, GrainRole::absent);
  const auto role_of = [&](std::uint32_t g) -> GrainRole& {
    if (g >= grains)
      throw DataError(fmt::format("a rank sent the state of grain {} of a model of {} grains; the ranks must run the "
                                  "same model",
                                  g, grains));
    return roles[g];
  };
  for (std::uint32_t g : plan.kept) role_of(g) = GrainRole::owned;
  for (std::uint32_t g : plan.ghosted) role_of(g) = GrainRole::ghost;
  for (const RankMessage& m : received) {
    for (const GrainBody& b : m.bodies)
      role_of(b.grain) = owner_rank(subdomains, b.state.position) == rank ? GrainRole::owned : GrainRole::ghost;
    for (const GrainNodes& n : m.nodes) role_of(n.grain) = n.whole ? GrainRole::owned : GrainRole::ghost;
  }
  return roles;
}

std::vector<GrainRole> initial_roles(const Subdomains& subdomains, int rank, std::span<const RigidBodyState> bodies,
                                     std::span<const double> radii) {
  std::vector<GrainRole> roles(bodies.size(), GrainRole::absent);
  for (std::size_t g = 0; g < bodies.size(); ++g) {
    const int owner = owner_rank(subdomains, bodies[g].position);
    const std::vector<int> ghosts = ghost_ranks(subdomains, bodies[g].position, radii[g], owner);
    if (owner == rank) roles[g] = GrainRole::owned;
    else if (std::binary_search(ghosts.begin(), ghosts.end(), rank)) roles[g] = GrainRole::ghost;
  }
  return roles;
}

std::vector<std::uint32_t> grains_with_role(std::span<const GrainRole> roles, GrainRole role) {
  std::vector<std::uint32_t> out;
  for (std::uint32_t g = 0; g < roles.size(); ++g)
    if (roles[g] == role) out.push_back(g);
  return out;
}

std::vector<double> grain_bounding_radii(const Model& model, std::span<const BodyProperties> bodies) {
  std::vector<double> radii(model.grains.size(), 0.0);
  for (std::size_t g = 0; g < model.grains.size(); ++g)
    for (std::uint32_t i = model.grains[g].node_begin; i < model.grains[g].node_end; ++i)
      radii[g] = std::max(radii[g], (model.nodes[i] - bodies[g].centroid).norm());
  return radii;
}

std::vector<std::vector<std::uint32_t>> grain_surface_nodes(const Model& model) {
  std::vector<std::vector<std::uint32_t>> surface(model.grains.size());
  for (std::size_t g = 0; g < model.grains.size(); ++g) {
    std::vector<std::uint32_t>& nodes = surface[g];
    for (std::uint32_t t = model.grains[g].triangle_begin; t < model.grains[g].triangle_end; ++t)
      nodes.insert(nodes.end(), model.triangles[t].begin(), model.triangles[t].end());
    std::sort(nodes.begin(), nodes.end());
    nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
  }
  return surface;
}

std::vector<double> element_work(const Model& model) {
  std::vector<double> work(model.grains.size(), 0.0);
  for (std::size_t g = 0; g < model.grains.size(); ++g) {
    const Grain& grain = model.grains[g];
    const double per_element = grain.kind == GrainKind::tet10 ? kTet10ElementWork
                               : grain.kind == GrainKind::tet4 ? kTet4ElementWork
                                                               : 0.0;
    work[g] = per_element * (grain.element_end - grain.element_begin);
  }
  return work;
}

std::vector<double> surface_node_work(const Model& model) {
  std::vector<double> work = element_work(model);
  const std::vector<std::vector<std::uint32_t>> surface = grain_surface_nodes(model);
  for (std::size_t g = 0; g < work.size(); ++g) work[g] += static_cast<double>(surface[g].size());
  return work;
}

StepRows sorted_rows(std::span<const StepRows> parts) {
  std::vector<std::pair<std::uint64_t, const double*>> all;
  for (const StepRows& part : parts)
    for (std::size_t i = 0; i < part.keys.size(); ++i) all.emplace_back(part.keys[i], part.values.data() + i * kTermColumns);
  std::sort(all.begin(), all.end(), [](const auto& p, const auto& q) { return p.first < q.first; });
  StepRows rows;
  for (const auto& [key, values] : all) {
    if (!rows.keys.empty() && rows.keys.back() == key)
      throw DataError(fmt::format("two ranks sent a boundary contact under key {}: each grain must have one owner", key));
    rows.keys.push_back(key);
    rows.values.insert(rows.values.end(), values, values + kTermColumns);
  }
  return rows;
}

}  // namespace graintwin::fdem
