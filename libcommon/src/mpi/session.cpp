#include "graintwin/mpi/session.hpp"

#include <fmt/format.h>
#include <mpi.h>

#include <algorithm>
#include <cstdlib>
#include <exception>
#include <limits>
#include <numeric>

#include "graintwin/core/error.hpp"

// MPI calls keep MPI's default error handler (MPI_ERRORS_ARE_FATAL): a failed call ends the whole
// job with MPI's own message, where an exception on one rank would leave the others waiting.
namespace graintwin::mpi {
namespace {

constexpr int kRoot = 0;

/// Whether a launcher started this process as one of a job's ranks: Open MPI's mpirun, or a PMI
/// or PMIx launcher (srun), names the rank in the environment.
bool launched() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK"})
    if (std::getenv(name)) return true;
  return false;
}

/// [index of a grain contributed twice or -1, per component the sum in grain order]: the root's part
/// of ordered_sum.
std::vector<double> sum_in_grain_order(std::span<const std::uint32_t> grains, std::span<const double> values,
                                       std::size_t components) {
  const std::size_t total = grains.size();
  std::vector<double> result(1 + components, 0.0);
  std::vector<std::size_t> order(total);
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return grains[a] < grains[b]; });
  result[0] = -1;
  for (std::size_t i = 0; i < total; ++i) {
    if (i > 0 && grains[order[i]] == grains[order[i - 1]]) {
      result[0] = grains[order[i]];  // exact: grain indices are 32-bit
      break;
    }
    for (std::size_t c = 0; c < components; ++c) result[1 + c] += values[order[i] * components + c];
  }
  return result;
}

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

}  // namespace

Session::Session(int& argc, char**& argv, Start start) : uncaught_at_start_(std::uncaught_exceptions()) {
  int started = 0;
  MPI_Initialized(&started);
  if (started) throw UsageError("MPI was started twice in one process: make one mpi::Session, in main");
  if (start == Start::when_launched && !launched()) return;
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  if (provided < MPI_THREAD_FUNNELED) {
    MPI_Finalize();
    throw UsageError("this MPI library cannot run beside OpenMP threads (no MPI_THREAD_FUNNELED): use Debian's Open MPI");
  }
  started_ = true;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
  MPI_Comm machine = MPI_COMM_NULL;
  MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, rank_, MPI_INFO_NULL, &machine);
  MPI_Comm_size(machine, &local_size_);
  MPI_Comm_free(&machine);
}

Session::~Session() {
  if (!started_) return;
  if (std::uncaught_exceptions() > uncaught_at_start_ && size_ > 1) MPI_Abort(MPI_COMM_WORLD, 1);
  MPI_Finalize();
}

void Session::abort(int code) const {
  if (started_) MPI_Abort(MPI_COMM_WORLD, code);
  std::exit(code);
}

std::vector<double> ordered_sum(const Session& session, std::span<const std::uint32_t> grains,
                                std::span<const double> values, std::size_t components) {
  if (components == 0 || values.size() != grains.size() * components)
    throw UsageError(fmt::format("an ordered sum needs {} values per grain: got {} values for {} grains", components,
                                 values.size(), grains.size()));
  const int count = checked_count(grains.size(), "grains");
  checked_count(values.size(), "values");
  const bool root = session.rank() == kRoot;
  std::vector<double> result;
  if (!session.started()) {
    result = sum_in_grain_order(grains, values, components);
  } else {

    std::vector<int> grain_counts(root ? session.size() : 0);
    MPI_Gather(&count, 1, MPI_INT, grain_counts.data(), 1, MPI_INT, kRoot, MPI_COMM_WORLD);
    std::vector<int> value_counts(grain_counts.size());
    std::transform(grain_counts.begin(), grain_counts.end(), value_counts.begin(),
                   [&](int n) { return checked_count(static_cast<std::size_t>(n) * components, "values"); });
    const std::size_t total = std::accumulate(grain_counts.begin(), grain_counts.end(), std::size_t{0});
    std::vector<std::uint32_t> all_grains(total);
    std::vector<double> all_values(total * components);
    MPI_Gatherv(grains.data(), count, MPI_UINT32_T, all_grains.data(), grain_counts.data(),
                offsets_of(grain_counts).data(), MPI_UINT32_T, kRoot, MPI_COMM_WORLD);
    MPI_Gatherv(values.data(), static_cast<int>(values.size()), MPI_DOUBLE, all_values.data(), value_counts.data(),
                offsets_of(value_counts).data(), MPI_DOUBLE, kRoot, MPI_COMM_WORLD);
    // Broadcast as [twice-contributed grain or -1, sums...]: every rank learns of a refusal alike.
    result = root ? sum_in_grain_order(all_grains, all_values, components) : std::vector<double>(1 + components, 0.0);
    MPI_Bcast(result.data(), static_cast<int>(result.size()), MPI_DOUBLE, kRoot, MPI_COMM_WORLD);
  }
  if (result[0] >= 0)
    throw DataError(fmt::format("grain {} was summed twice by the ranks: each grain must be contributed by its owner "
                                "alone",
                                static_cast<std::uint32_t>(result[0])));
  return {result.begin() + 1, result.end()};
}

void sum_over_ranks(const Session& session, std::span<double> values) {
  if (!session.started() || values.empty()) return;
  MPI_Allreduce(MPI_IN_PLACE, values.data(), checked_count(values.size(), "values"), MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
}

std::uint64_t sum_over_ranks(const Session& session, std::uint64_t count) {
  if (!session.started()) return count;
  std::uint64_t total = 0;
  MPI_Allreduce(&count, &total, 1, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
  return total;
}

}  // namespace graintwin::mpi
