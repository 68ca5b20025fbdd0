#include "graintwin/mpi/session.hpp"

#include <fmt/format.h>
#include <mpi.h>

#include <algorithm>
#include <exception>
#include <limits>
#include <numeric>

#include "graintwin/core/error.hpp"

// MPI calls keep MPI's default error handler (MPI_ERRORS_ARE_FATAL): a failed call ends the whole
// job with MPI's own message, where an exception on one rank would leave the others waiting.
namespace graintwin::mpi {
namespace {

constexpr int kRoot = 0;

int checked_count(std::size_t n, const char* what) {
  if (n > static_cast<std::size_t>(std::numeric_limits<int>::max()))
    throw UsageError(fmt::format("{} {} exceed MPI's int counts: sum in slices of at most {}", n, what,
                                 std::numeric_limits<int>::max()));
  return static_cast<int>(n);
}

// Offsets of consecutive blocks of the given counts (MPI_Gatherv's displacements).
std::vector<int> offsets_of(const std::vector<int>& counts) {
  std::vector<int> offsets(counts.size(), 0);
  std::exclusive_scan(counts.begin(), counts.end(), offsets.begin(), 0);
  return offsets;
}

/// Rows of keys and `components` values each, in rank order.
template <class Key>
struct Gathered {
  std::vector<Key> keys;
  std::vector<double> values;
};

/// Every rank's rows, gathered at rank 0 (the others receive none) or, `everywhere`, on every rank.
template <class Key>
Gathered<Key> gather_rows(const Session& session, std::span<const Key> keys, std::span<const double> values,
                          std::size_t components, MPI_Datatype key_type, bool everywhere) {
  const int count = checked_count(keys.size(), "keys");
  checked_count(values.size(), "values");
  std::vector<int> key_counts(everywhere || session.rank() == kRoot ? session.size() : 0);
  if (everywhere) MPI_Allgather(&count, 1, MPI_INT, key_counts.data(), 1, MPI_INT, MPI_COMM_WORLD);
  else MPI_Gather(&count, 1, MPI_INT, key_counts.data(), 1, MPI_INT, kRoot, MPI_COMM_WORLD);
  std::vector<int> value_counts(key_counts.size());
  std::transform(key_counts.begin(), key_counts.end(), value_counts.begin(),
                 [&](int n) { return checked_count(static_cast<std::size_t>(n) * components, "values"); });
  const std::size_t total = std::accumulate(key_counts.begin(), key_counts.end(), std::size_t{0});
  Gathered<Key> all{std::vector<Key>(total), std::vector<double>(total * components)};
  const std::vector<int> key_offsets = offsets_of(key_counts), value_offsets = offsets_of(value_counts);
  const int value_count = static_cast<int>(values.size());
  if (everywhere) {
    MPI_Allgatherv(keys.data(), count, key_type, all.keys.data(), key_counts.data(), key_offsets.data(), key_type,
                   MPI_COMM_WORLD);
    MPI_Allgatherv(values.data(), value_count, MPI_DOUBLE, all.values.data(), value_counts.data(), value_offsets.data(),
                   MPI_DOUBLE, MPI_COMM_WORLD);
  } else {
    MPI_Gatherv(keys.data(), count, key_type, all.keys.data(), key_counts.data(), key_offsets.data(), key_type, kRoot,
                MPI_COMM_WORLD);
    MPI_Gatherv(values.data(), value_count, MPI_DOUBLE, all.values.data(), value_counts.data(), value_offsets.data(),
                MPI_DOUBLE, kRoot, MPI_COMM_WORLD);
  }
  return all;
}

/// The row indices of `keys` in increasing key order.
template <class Key>
std::vector<std::size_t> key_order(const std::vector<Key>& keys) {
  std::vector<std::size_t> order(keys.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return keys[a] < keys[b]; });
  return order;
}

}  // namespace

Session::Session(int& argc, char**& argv) : uncaught_at_start_(std::uncaught_exceptions()) {
  int started = 0;
  MPI_Initialized(&started);
  if (started) throw UsageError("MPI was started twice in one process: make one mpi::Session, in main");
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  if (provided < MPI_THREAD_FUNNELED) {
    MPI_Finalize();
    throw UsageError("this MPI library cannot run beside OpenMP threads (no MPI_THREAD_FUNNELED): use Debian's Open MPI");
  }
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
}

Session::~Session() {
  if (std::uncaught_exceptions() > uncaught_at_start_ && size_ > 1) MPI_Abort(MPI_COMM_WORLD, 1);
  MPI_Finalize();
}

std::vector<double> ordered_sum(const Session& session, std::span<const std::uint32_t> grains,
                                std::span<const double> values, std::size_t components) {
  if (components == 0 || values.size() != grains.size() * components)
    throw UsageError(fmt::format("an ordered sum needs {} values per grain: got {} values for {} grains", components,
                                 values.size(), grains.size()));
  const bool root = session.rank() == kRoot;
  const Gathered<std::uint32_t> all = gather_rows(session, grains, values, components, MPI_UINT32_T, false);
  const std::vector<std::uint32_t>& all_grains = all.keys;

  // Broadcast as [twice-contributed grain or -1, sums...]: every rank learns of a refusal alike.
  std::vector<double> result(1 + components, 0.0);
  if (root) {
    const std::vector<std::size_t> order = key_order(all_grains);
    result[0] = -1;
    for (std::size_t i = 0; i < order.size(); ++i) {
      if (i > 0 && all_grains[order[i]] == all_grains[order[i - 1]]) {
        result[0] = all_grains[order[i]];  // exact: grain indices are 32-bit
        break;
      }
      for (std::size_t c = 0; c < components; ++c) result[1 + c] += all.values[order[i] * components + c];
    }
  }
  MPI_Bcast(result.data(), static_cast<int>(result.size()), MPI_DOUBLE, kRoot, MPI_COMM_WORLD);
  if (result[0] >= 0)
    throw DataError(fmt::format("grain {} was summed twice by the ranks: each grain must be contributed by its owner "
                                "alone",
                                static_cast<std::uint32_t>(result[0])));
  return {result.begin() + 1, result.end()};
}

SortedRows gather_sorted(const Session& session, std::span<const std::uint64_t> keys, std::span<const double> values,
                         std::size_t components) {
  if (components == 0 || values.size() != keys.size() * components)
    throw UsageError(fmt::format("rows gathered by key need {} values per key: got {} values for {} keys", components,
                                 values.size(), keys.size()));
  const Gathered<std::uint64_t> all = gather_rows(session, keys, values, components, MPI_UINT64_T, true);
  SortedRows rows;
  rows.keys.reserve(all.keys.size());
  rows.values.reserve(all.values.size());
  for (std::size_t i : key_order(all.keys)) {
    if (!rows.keys.empty() && rows.keys.back() == all.keys[i])
      throw DataError(fmt::format("key {} was gathered twice from the ranks: each row must come from one rank alone",
                                  all.keys[i]));
    rows.keys.push_back(all.keys[i]);
    rows.values.insert(rows.values.end(), all.values.begin() + i * components, all.values.begin() + (i + 1) * components);
  }
  return rows;
}

std::uint64_t sum_over_ranks(const Session& /*MPI is started*/, std::uint64_t count) {
  std::uint64_t total = 0;
  MPI_Allreduce(&count, &total, 1, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
  return total;
}

}  // namespace graintwin::mpi
