// Team sizes with -j far above the processor count: loops with per-thread buffers and Eigen's
// parallel products stop at the processors (and at the work there is).
#include <gtest/gtest.h>
#include <omp.h>

#include <Eigen/Core>
#include <algorithm>

#include "graintwin/core/parallel.hpp"

using namespace graintwin;

TEST(Parallel, UsefulThreadsStopAtTheProcessorsAndTheWork) {
  omp_set_num_threads(1024);
  EXPECT_EQ(useful_threads(1000000), std::min(1024, omp_get_num_procs()));
  EXPECT_EQ(useful_threads(1), 1);
  EXPECT_EQ(useful_threads(0), 1) << "at least one";
  omp_set_num_threads(1);
  EXPECT_EQ(useful_threads(1000000), 1) << "never more than -j";
}

TEST(Parallel, EigenThreadCapHoldsEigenToTheProcessorsWhileItLives) {
  omp_set_num_threads(1024);
  ASSERT_EQ(Eigen::nbThreads(), 1024) << "Eigen follows OpenMP's thread count";
  {
    const EigenThreadCap cap;
    EXPECT_EQ(Eigen::nbThreads(), std::min(1024, omp_get_num_procs()));
  }
  EXPECT_EQ(Eigen::nbThreads(), 1024);
  omp_set_num_threads(3);
  EXPECT_EQ(Eigen::nbThreads(), 3) << "and follows it again afterwards";
}
