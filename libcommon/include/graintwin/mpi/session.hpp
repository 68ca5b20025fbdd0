#pragma once
// The MPI layer of fdemrun across ranks (docs/fdemrun.md, across machines): one Session per process starts and ends MPI,
// and the collective operations the decomposed solver needs take it, so none can run before MPI
// is started. Only this module (library graintwin_mpi) includes <mpi.h>; fdem/decomposition is
// plain code every rank runs alike. Ranks are MPI_COMM_WORLD's. Run through
// `mpirun -np N program` (as root: `--allow-run-as-root`; more ranks than cores: `--oversubscribe`;
// docs/fdemrun.md); a program started without mpirun is a run of one rank.
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "graintwin/core/exact_sum.hpp"

namespace graintwin::mpi {

class Session {
 public:
  /// When a session starts MPI.
  enum class Start {
    always,         ///< with or without a launcher (a program alone is then MPI's one-rank "singleton")
    when_launched,  ///< only under a launcher (mpirun, srun: its environment names the ranks); a program
                    ///< started alone is one rank without MPI, and skips the singleton's start (0.3-0.4 s here)
  };
  /// Starts MPI (MPI_Init_thread, funneled: OpenMP threads inside a rank, MPI calls from the
  /// thread that made the session), or not (`start`). One per process: UsageError when MPI was
  /// started before.
  explicit Session(int& argc, char**& argv, Start start = Start::always);
  /// Ends MPI (MPI_Finalize) on every rank alike. When the session is left by an exception on a
  /// run of several ranks it aborts the whole job (MPI_Abort, exit 1) instead, since the other
  /// ranks may be waiting in a collective for this one and would wait for ever: so let an error
  /// found on one rank alone leave main through the session rather than catching it above it.
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  int rank() const { return rank_; }  ///< 0 .. size() - 1
  int size() const { return size_; }  ///< number of ranks
  /// Ranks of the job on this machine (sharing its memory and cores), this one included.
  int ranks_on_this_machine() const { return local_size_; }
  bool started() const { return started_; }  ///< MPI runs (else one rank, and the collectives below are local)
  /// Ends every rank of the job with exit code `code` (MPI_Abort; without MPI, std::exit): for an
  /// error one rank may have met alone, while the others wait for it in a collective.
  [[noreturn]] void abort(int code) const;

 private:
  int rank_ = 0, size_ = 1, local_size_ = 1;
  bool started_ = false;
  int uncaught_at_start_ = 0;  ///< std::uncaught_exceptions() when made: more at the end means unwinding
};

/// The sum of one count per rank, on every rank (integers: exact in any order).
std::uint64_t sum_over_ranks(const Session& session, std::uint64_t count);
/// Element-wise sums of `values` over the ranks, in place on every rank (MPI_Allreduce). Exact, so
/// the same bits on every rank and count, when the values are whole numbers whose sums stay below
/// 2^53 (counts of work), or when one rank alone contributes each element.
void sum_over_ranks(const Session& session, std::span<double> values);
/// Element-wise sums of whole numbers over the ranks, in place on every rank (MPI_Allreduce).
void sum_over_ranks(const Session& session, std::span<std::int64_t> words);
/// Exact sums (core/exact_sum) added over the ranks, in place on every rank (the same bits on any
/// rank count), and the largest of one value per rank, not negative (`largest`, in place): two
/// collectives whatever the count, the span of chunks each sum sets over the ranks with the
/// largest value (MPI_Allreduce, maximum), then the sums' chunks within those spans (MPI_Allreduce,
/// sum). Returns the 8-byte words this rank sent. UsageError beyond ExactSum::kMaxMerged ranks.
std::size_t sum_over_ranks(const Session& session, std::span<ExactSum* const> sums, double& largest);

}  // namespace graintwin::mpi
