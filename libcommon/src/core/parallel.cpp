#include "graintwin/core/parallel.hpp"

#include <omp.h>

#include <Eigen/Core>
#include <algorithm>
#include <limits>

namespace graintwin {

int useful_threads(std::size_t items) {
  const int capped = std::min(omp_get_max_threads(), omp_get_num_procs());
  const auto by_items = static_cast<int>(std::min<std::size_t>(items, std::numeric_limits<int>::max()));
  return std::max(1, std::min(capped, by_items));
}

EigenThreadCap::EigenThreadCap() {
  const int now = Eigen::nbThreads();
  saved_ = now == omp_get_max_threads() ? 0 : now;
  Eigen::setNbThreads(std::min(now, useful_threads(std::numeric_limits<std::size_t>::max())));
}

EigenThreadCap::~EigenThreadCap() { Eigen::setNbThreads(saved_); }

}  // namespace graintwin
