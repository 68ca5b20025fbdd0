#pragma once
// A sum of doubles that does not depend on the order of its terms: every term is added exactly into
// a fixed-point accumulator wide enough for any finite double (a Kulisch accumulator, in chunks of
// 50 bits), and value() rounds the exact sum once to the nearest double. So a sum split over
// threads or MPI ranks, whose parts are merged in any order, has the bits of the one-thread sum;
// across ranks the chunks are added element-wise (MPI_SUM of int64: mpi::sum_over_ranks).
#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace graintwin {

class ExactSum {
 public:
  /// Chunks of the accumulator and their width: bit 0 of chunk 0 weighs 2^kLowestExponent (the
  /// smallest subnormal), the last chunk reaches beyond the largest finite double.
  static constexpr int kChunkBits = 50;
  static constexpr int kLowestExponent = -1074;
  static constexpr std::size_t kChunks = 42;
  /// Accumulators that may be added chunk by chunk without carrying (2^13: each chunk of state()
  /// holds at most 2^49 in magnitude, and int64 holds 2^63).
  static constexpr std::size_t kMaxMerged = 8192;
  /// Words of state(): the chunks, then the counts of NaN, +infinity and -infinity terms.
  static constexpr std::size_t kWords = kChunks + 3;

  /// Adds x exactly (NaN and infinities are counted: value() follows IEEE for them).
  void add(double x);
  /// Adds another accumulator exactly.
  void add(const ExactSum& other);
  /// The exact sum rounded to the nearest double (ties to even); NaN when a term was NaN or both
  /// infinities came, an infinity when one did, or when the sum is beyond the largest double.
  double value() const;

  /// The accumulator's words, normalized (each chunk within 2^49 in magnitude, so a sum of
  /// either sign sets only the chunks its bits span), for adding element-wise across processes (at
  /// most kMaxMerged of them), and its rebuilding from such a sum.
  std::array<std::int64_t, kWords> state() const;
  static ExactSum from_state(std::span<const std::int64_t> words);

  /// The chunks state() sets: [lowest, highest] nonzero (highest < lowest when none).
  struct ChunkSpan {
    int lowest = static_cast<int>(kChunks), highest = -1;
  };
  ChunkSpan chunk_span() const;
  /// state()'s chunks lowest..highest, then its three counts: what a sum over processes needs when
  /// every process's chunks lie within that span; from_window rebuilds the accumulator from a
  /// word-by-word sum of such windows.
  std::vector<std::int64_t> window(ChunkSpan span) const;
  static ExactSum from_window(ChunkSpan span, std::span<const std::int64_t> words);

 private:
  /// Carries each chunk's excess into the next, so that every chunk but the last lies in [0, 2^50).
  void normalize();
  /// Carries so that every chunk but the last lies in [-2^49, 2^49).
  void balance();

  std::array<std::int64_t, kChunks> chunk_{};
  std::int64_t nan_ = 0, plus_infinity_ = 0, minus_infinity_ = 0;
  std::uint32_t since_normalized_ = 0;  ///< terms added since the last normalize()
};

}  // namespace graintwin
