#include "graintwin/mpi/session.hpp"

#include <fmt/format.h>
#include <mpi.h>

#include <algorithm>
#include <bit>
#include <cstdlib>
#include <exception>
#include <limits>

#include "graintwin/core/error.hpp"

// MPI calls keep MPI's default error handler (MPI_ERRORS_ARE_FATAL): a failed call ends the whole
// job with MPI's own message, where an exception on one rank would leave the others waiting.
namespace graintwin::mpi {
namespace {

/// Whether a launcher started this process as one of a job's ranks: Open MPI's mpirun, or a PMI
/// or PMIx launcher (srun), names the rank in the environment.
bool launched() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK"})
    if (std::getenv(name)) return true;
  return false;
}

int checked_count(std::size_t n, const char* what) {
  if (n > static_cast<std::size_t>(std::numeric_limits<int>::max()))
    throw UsageError(fmt::format("{} {} exceed MPI's int counts: sum in slices of at most {}", n, what,
                                 std::numeric_limits<int>::max()));
  return static_cast<int>(n);
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

void sum_over_ranks(const Session& session, std::span<double> values) {
  if (!session.started() || values.empty()) return;
  MPI_Allreduce(MPI_IN_PLACE, values.data(), checked_count(values.size(), "values"), MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
}

void sum_over_ranks(const Session& session, std::span<std::int64_t> words) {
  if (!session.started() || words.empty()) return;
  MPI_Allreduce(MPI_IN_PLACE, words.data(), checked_count(words.size(), "words"), MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD);
}

std::size_t sum_over_ranks(const Session& session, std::span<ExactSum* const> sums, double& largest) {
  if (session.size() > static_cast<int>(ExactSum::kMaxMerged))
    throw UsageError(fmt::format("{} ranks: exact sums add at most {} ranks' accumulators; run on fewer ranks", session.size(),
                                 ExactSum::kMaxMerged));
  // First every sum's span of chunks over the ranks (the lowest as its negative, so that one maximum
  // takes both) and the largest value, whose bits order as the values do when they are not negative.
  std::vector<std::int64_t> bounds;
  for (const ExactSum* s : sums) {
    const ExactSum::ChunkSpan span = s->chunk_span();
    bounds.insert(bounds.end(), {-span.lowest, span.highest});
  }
  bounds.push_back(std::bit_cast<std::int64_t>(largest));
  if (session.started())
    MPI_Allreduce(MPI_IN_PLACE, bounds.data(), checked_count(bounds.size(), "bounds"), MPI_INT64_T, MPI_MAX, MPI_COMM_WORLD);
  largest = std::bit_cast<double>(bounds.back());
  // Then the chunks within the spans, added.
  std::vector<ExactSum::ChunkSpan> spans;
  std::vector<std::int64_t> words;
  for (std::size_t i = 0; i < sums.size(); ++i) {
    spans.push_back({static_cast<int>(-bounds[2 * i]), static_cast<int>(bounds[2 * i + 1])});
    const std::vector<std::int64_t> w = sums[i]->window(spans.back());
    words.insert(words.end(), w.begin(), w.end());
  }
  sum_over_ranks(session, words);
  std::size_t at = 0;
  for (std::size_t i = 0; i < sums.size(); ++i) {
    const std::size_t n = static_cast<std::size_t>(std::max(0, spans[i].highest - spans[i].lowest + 1)) + 3;
    *sums[i] = ExactSum::from_window(spans[i], std::span<const std::int64_t>(words).subspan(at, n));
    at += n;
  }
  return bounds.size() + words.size();
}

std::uint64_t sum_over_ranks(const Session& session, std::uint64_t count) {
  if (!session.started()) return count;
  std::uint64_t total = 0;
  MPI_Allreduce(&count, &total, 1, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
  return total;
}

}  // namespace graintwin::mpi
