#pragma once
// Team sizes for parallel loops. `-j` may ask for far more threads than the machine has
// processors; a loop that gives each thread a buffer (a histogram, a per-label table) then pays
// memory and merge time per thread for no speed-up, and Eigen's parallel products, which wait by
// spinning, slow down many times over.
#include <cstddef>
#include <exception>

namespace graintwin {

/// Threads worth using for `items` independent pieces of work: OpenMP's thread count (-j), but no
/// more than the processors this process may run on nor than `items`, and at least one. For
/// `num_threads(...)` of loops whose result does not depend on the team size.
int useful_threads(std::size_t items);

/// While it lives, Eigen's own parallel products use at most useful_threads() threads (the
/// processors); afterwards Eigen follows OpenMP's thread count again. Create it on the thread that
/// runs the products, outside parallel regions (Eigen's setting is process-wide).
class EigenThreadCap {
 public:
  EigenThreadCap();
  ~EigenThreadCap();
  EigenThreadCap(const EigenThreadCap&) = delete;
  EigenThreadCap& operator=(const EigenThreadCap&) = delete;

 private:
  int saved_ = 0;  ///< 0: Eigen followed OpenMP's thread count
};

/// Runs work(i) for i in 0..n-1 in parallel (OpenMP, dynamic schedule); the first exception thrown
/// is rethrown after the loop, since an exception must not leave an OpenMP region.
template <class Work>
void parallel_for_each_index(std::size_t n, Work&& work) {
  std::exception_ptr failure;
#pragma omp parallel for schedule(dynamic)
  for (std::size_t i = 0; i < n; ++i) {
    try {
      work(i);
    } catch (...) {
#pragma omp critical(parallel_for_each_failure)
      if (!failure) failure = std::current_exception();
    }
  }
  if (failure) std::rethrow_exception(failure);
}

}  // namespace graintwin
