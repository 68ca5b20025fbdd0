// The contact model's share in a run split over ranks (docs/fdemrun.md, across machines): the
// grains' roles on this rank, the sums of the candidates it owns, and the friction history that
// travels with a grain from rank to rank. Plain code: the exchange itself is mpi/distributed_run's.
#include <fmt/format.h>

#include <algorithm>
#include <bit>

#include "contact_state.hpp"
#include "graintwin/core/error.hpp"

namespace graintwin::fdem {
namespace {

bool same_bits(const HistoryEntry& p, const HistoryEntry& q) {
  for (int k = 0; k < 3; ++k)
    if (std::bit_cast<std::uint64_t>(p.spring[k]) != std::bit_cast<std::uint64_t>(q.spring[k])) return false;
  return std::bit_cast<std::uint64_t>(p.offset) == std::bit_cast<std::uint64_t>(q.offset);
}

bool entry_less(const HistoryEntry& p, const HistoryEntry& q) { return key_less(p, q.a, q.b, q.node); }

}  // namespace

std::vector<BoxPair> ContactModel::State::rank_pairs(std::vector<BoxPair> pairs) const {
  if (!roles.empty())
    std::erase_if(pairs, [&](const BoxPair& p) { return !owned(p.first) && !owned(p.second); });
  return pairs;
}

void ContactModel::set_grain_roles(std::span<const GrainRole> roles) {
  State& s = *state_;
  if (!roles.empty() && roles.size() != s.grains.size())
    throw UsageError(fmt::format("fdem contact: {} grain roles for {} grains; pass one per grain, or none for all owned.",
                                 roles.size(), s.grains.size()));
  if (std::equal(roles.begin(), roles.end(), s.roles.begin(), s.roles.end())) return;
  s.roles.assign(roles.begin(), roles.end());
  s.need_rebuild = true;  // grains came or went: the broad phase's pairs are another set
}

std::span<const PairStepSum> ContactModel::owned_pair_sums() const { return state_->owned_pair_sums; }

std::span<const GrainRole> ContactModel::grain_roles() const { return state_->roles; }

void ContactModel::State::add_grain_work(std::uint32_t a, std::uint32_t b, double work) {
  if (roles.empty()) return;
  if (grain_work.empty()) grain_work.assign(grains.size(), 0.0);
  if (roles[a] == GrainRole::owned) grain_work[a] += work;
  if (b < grains.size() && roles[b] == GrainRole::owned) grain_work[b] += work;
}

std::vector<double> ContactModel::take_grain_work() {
  State& s = *state_;
  std::vector<double> work(s.grains.size(), 0.0);
  if (!s.grain_work.empty()) std::swap(work, s.grain_work);
  s.grain_work.clear();
  return work;
}

void ContactModel::set_contacts(std::vector<ContactRecord> records) { state_->records = std::move(records); }

std::vector<ContactHistoryEntry> ContactModel::history_of(std::span<const std::uint32_t> grains) const {
  std::vector<ContactHistoryEntry> out;
  for (const HistoryEntry& h : state_->history)
    if (std::binary_search(grains.begin(), grains.end(), h.a) || std::binary_search(grains.begin(), grains.end(), h.b))
      out.push_back(h);
  return out;
}

void ContactModel::merge_history(std::span<const ContactHistoryEntry> entries) {
  State& s = *state_;
  std::vector<HistoryEntry> incoming(entries.begin(), entries.end());
  std::sort(incoming.begin(), incoming.end(), entry_less);
  std::vector<HistoryEntry> merged;
  merged.reserve(s.history.size() + incoming.size());
  auto held = s.history.begin();
  for (auto in = incoming.begin(); in != incoming.end(); ++in) {
    if (in->a >= s.grains.size() || in->b <= in->a || in->node >= s.node_count)
      throw DataError(fmt::format("fdem contact: a history entry names grain pair ({}, {}) and node {} outside a model "
                                  "of {} grains and {} nodes; the ranks must run the same model.",
                                  in->a, in->b, in->node, s.grains.size(), s.node_count));
    while (held != s.history.end() && entry_less(*held, *in)) merged.push_back(*held++);
    const bool here = held != s.history.end() && !entry_less(*in, *held);
    const HistoryEntry& known = here ? *held : merged.empty() ? *in : merged.back();
    const bool duplicate = here || (!merged.empty() && !entry_less(merged.back(), *in));
    if (duplicate && !same_bits(known, *in))
      throw DataError(fmt::format("fdem contact: two ranks hold different friction histories for node {} of grain pair "
                                  "({}, {}); every rank evaluating a pair must keep the same history.",
                                  in->node, in->a, in->b));
    if (!duplicate) merged.push_back(*in);
  }
  merged.insert(merged.end(), held, s.history.end());
  s.history = std::move(merged);
}

}  // namespace graintwin::fdem
