#pragma once
// The priority-flood engine shared by the marker watershed (watershed.hpp) and the dynamics of the
// EDT maxima that propose h (markers.hpp): a hierarchical queue over quantised EDT levels with a
// FIFO per level, flooding from the highest distance down. Deterministic: the order depends only on
// the input (raster order of the markers, then FIFO order), never on threads.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "graintwin/core/volume.hpp"
#include "graintwin/segment/connectivity.hpp"

namespace graintwin::segment::detail {

/// Queue levels of EDT values: level(d) = round((d / unit)^2 * per_unit2), capped at count - 1.
/// In squared voxel units an isotropic EDT takes integer values, so with per_unit2 >= 1 distinct
/// distances never share a level; per_unit2 is lowered only when the largest distance would need
/// more than kMaxLevels levels.
struct LevelMap {
  static constexpr std::uint32_t kMaxLevels = 1u << 18;
  double scale = 1.0;      ///< per_unit2 / unit^2, applied to d^2 in metres^2
  std::uint32_t count = 1; ///< number of levels
  std::uint32_t operator()(float d) const {
    const double l = static_cast<double>(d) * static_cast<double>(d) * scale + 0.5;
    return l >= static_cast<double>(count - 1) ? count - 1 : static_cast<std::uint32_t>(l);
  }
};

/// Levels for this EDT: unit = smallest voxel size, 8 levels per squared voxel when that fits.
LevelMap make_level_map(const Volume<float>& edt);

/// The hierarchical queue: one FIFO per level, each a chain of fixed-size blocks taken from a shared
/// pool and returned to it as soon as they are consumed. Memory follows the number of waiting
/// entries (the flood front) rather than the history of the queue, blocks never move (so entries
/// can be read while the same level grows), and nothing is copied as a level grows.
template <class Index>
class BucketQueue {
 public:
  static constexpr std::uint32_t kBlock = 1024;  ///< entries per block
  static constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

  explicit BucketQueue(std::uint32_t levels) : head_(levels, kNone), tail_(levels, kNone) {}

  void push(std::uint32_t level, Index p) {
    std::uint32_t t = tail_[level];
    if (t == kNone || count_[t] == kBlock) {
      const std::uint32_t b = take_block();
      if (t == kNone) head_[level] = b;
      else next_[t] = b;
      tail_[level] = t = b;
    }
    storage(t)[count_[t]++] = p;
  }
  std::uint32_t head(std::uint32_t level) const { return head_[level]; }
  std::uint32_t count(std::uint32_t block) const { return count_[block]; }
  std::uint32_t next(std::uint32_t block) const { return next_[block]; }
  const Index* items(std::uint32_t block) const { return slabs_[block / kSlab].get() + std::size_t{block % kSlab} * kBlock; }
  /// Returns the consumed head block of `level` to the pool and makes its successor the head.
  void drop_head(std::uint32_t level) {
    const std::uint32_t b = head_[level];
    head_[level] = next_[b];
    if (head_[level] == kNone) tail_[level] = kNone;
    free_.push_back(b);
  }

 private:
  static constexpr std::uint32_t kSlab = 64;  ///< blocks allocated together
  Index* storage(std::uint32_t block) { return slabs_[block / kSlab].get() + std::size_t{block % kSlab} * kBlock; }
  std::uint32_t take_block() {
    if (free_.empty()) {
      const auto first = static_cast<std::uint32_t>(count_.size());
      slabs_.push_back(std::make_unique<Index[]>(std::size_t{kSlab} * kBlock));
      count_.resize(count_.size() + kSlab);
      next_.resize(next_.size() + kSlab);
      for (std::uint32_t b = first + kSlab; b-- > first;) free_.push_back(b);
    }
    const std::uint32_t b = free_.back();
    free_.pop_back();
    count_[b] = 0;
    next_[b] = kNone;
    return b;
  }
  std::vector<std::uint32_t> head_, tail_;
  std::vector<std::unique_ptr<Index[]>> slabs_;
  std::vector<std::uint32_t> count_, next_, free_;
};

/// During a flood the top bit of a label slot says "labelled"; an unlabelled solid voxel's slot holds
/// its queue level instead, so the hot loop reads one array, not the labels and the distances.
constexpr std::uint32_t kLabelled = 1u << 31;
/// Largest marker label a flood accepts.
constexpr std::uint32_t kMaxLabel = kLabelled - 1;

/// Floods `labels` (same shape as edt; 1..kMaxLabel = marker, 0 = none) over the voxels with
/// edt > 0 in order of decreasing EDT, each unlabelled neighbour taking the label of the voxel
/// that reaches it first. Marker voxels outside the mask are dropped (set to 0); mask voxels that
/// no marker reaches stay 0.
/// on_meet(p, q, label_p, label_q, level) is called whenever a popped voxel p sees a neighbour q
/// that already holds a different label (the two basins touch), `level` being the queue level being processed;
/// q may still be waiting in the queue, possibly at a lower level, as labels are given on entry.
/// Index: uint32 or uint64 queue entries.
template <class Index, class OnMeet>
void priority_flood(const Volume<float>& edt, std::uint32_t* labels, Connectivity c, const LevelMap& levels,
                    OnMeet&& on_meet) {
  const Shape3& s = edt.shape();
  const float* f = edt.data();
  const std::size_t n = edt.size();
  // Background is "labelled 0", so the flood never enters it.
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < n; ++i)
    labels[i] = !(f[i] > 0.0f) ? kLabelled : labels[i] != 0 ? labels[i] | kLabelled : levels(f[i]);
  BucketQueue<Index> queue(levels.count);
  for (std::size_t i = 0; i < n; ++i)
    if (labels[i] != kLabelled && (labels[i] & kLabelled)) queue.push(levels(f[i]), static_cast<Index>(i));
  const std::vector<NeighbourStep> steps = neighbour_steps(c, s);
  const IndexSplitter split(s);
  // The flood visits voxels all over the volume, so nearly every neighbourhood is a cache miss;
  // prefetching the 3x3 label rows around a voxel a few pops ahead overlaps those misses (the
  // neighbours of one voxel span 9 rows, each within a cache line or two).
  constexpr std::uint32_t kAhead = 32;
  const std::ptrdiff_t sy = static_cast<std::ptrdiff_t>(s[2]), sz = static_cast<std::ptrdiff_t>(s[1] * s[2]);
  const std::ptrdiff_t rows[9] = {-sz - sy, -sz, -sz + sy, -sy, 0, sy, sz - sy, sz, sz + sy};
  for (std::uint32_t level = levels.count; level-- > 0;) {
    // Entries pushed at this level while it is being processed are appended (to the same block or
    // a new one linked after it) and handled in turn.
    for (std::uint32_t b = queue.head(level); b != BucketQueue<Index>::kNone; b = queue.head(level)) {
      const Index* items = queue.items(b);
      for (std::uint32_t i = 0; i < queue.count(b); ++i) {
        if (i + kAhead < queue.count(b)) {
          const std::size_t a = items[i + kAhead];
          const std::ptrdiff_t lo = -std::min<std::ptrdiff_t>(static_cast<std::ptrdiff_t>(a), sz + sy + 1);
          const std::ptrdiff_t hi = std::min<std::ptrdiff_t>(static_cast<std::ptrdiff_t>(n - 1 - a), sz + sy + 1);
          // Unrolled and not in a lambda: otherwise GCC deletes a loop whose only statements are prefetches.
#pragma GCC unroll 9
          for (int r = 0; r < 9; ++r) __builtin_prefetch(labels + a + std::clamp(rows[r], lo, hi));
        }
        const Index p = items[i];
        const std::uint32_t lp = labels[p];
        const auto visit = [&](std::size_t q) {
          const std::uint32_t lq = labels[q];
          if (!(lq & kLabelled)) {
            labels[q] = lp;
            queue.push(std::min(lq, level), static_cast<Index>(q));
          } else if (lq != lp && lq != kLabelled) {
            on_meet(static_cast<std::size_t>(p), q, lp & kMaxLabel, lq & kMaxLabel, level);
          }
        };
        for_each_neighbour(steps, s, split, p, visit);
      }
      // Fully read: only the tail block grows, and a full tail gets a successor before growing.
      queue.drop_head(level);
    }
  }
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < n; ++i) labels[i] = labels[i] & kLabelled ? labels[i] & kMaxLabel : 0;
}

}  // namespace graintwin::segment::detail
