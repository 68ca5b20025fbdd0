// core/exact_sum: the sum is exact until value() rounds it once to the nearest double (ties to
// even), whatever the order of the terms and however the accumulators are split and merged, through
// cancellation, subnormals, overflow and IEEE's NaN and infinities.
#include "graintwin/core/exact_sum.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <vector>

using graintwin::ExactSum;

namespace {

double sum_of(std::initializer_list<double> terms) {
  ExactSum s;
  for (double t : terms) s.add(t);
  return s.value();
}

std::uint64_t bits(double x) { return std::bit_cast<std::uint64_t>(x); }

/// Terms across the whole exponent range, of both signs, some cancelling exactly.
std::vector<double> wide_terms(std::size_t n, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_int_distribution<int> exponent(-1070, 1000);
  std::vector<double> terms;
  for (std::size_t i = 0; i < n; ++i) {
    terms.push_back(std::ldexp(unit(rng), i % 3 == 0 ? exponent(rng) : exponent(rng) / 20));
    if (i % 7 == 0) terms.push_back(-terms.back());
  }
  return terms;
}

}  // namespace

TEST(ExactSum, CancellationLosesNothing) {
  EXPECT_EQ(sum_of({1e16, 1.0, -1e16}), 1.0);
  EXPECT_EQ(sum_of({1e300, 1.0, -1e300}), 1.0);
  EXPECT_EQ(sum_of({1.0, 1e-300, -1.0}), 1e-300);
  EXPECT_EQ(sum_of({0.1, 0.2, -0.1, -0.2}), 0.0);
  EXPECT_EQ(sum_of({}), 0.0);
  // Subnormals are exact too: three of the smallest is three of the smallest.
  const double tiny = std::numeric_limits<double>::denorm_min();
  EXPECT_EQ(sum_of({tiny, tiny, tiny}), 3 * tiny);
  EXPECT_EQ(sum_of({std::numeric_limits<double>::min(), -tiny}), std::numeric_limits<double>::min() - tiny);
}

TEST(ExactSum, RoundsOnceToNearestTiesToEven) {
  const double two53 = 9007199254740992.0;  // 2^53: doubles above it are even integers
  EXPECT_EQ(sum_of({two53, 1.0}), two53) << "a tie goes to the even neighbour";
  EXPECT_EQ(sum_of({two53, 3.0}), two53 + 4.0) << "a tie goes to the even neighbour";
  EXPECT_EQ(sum_of({two53, 1.0, 1e-100}), two53 + 2.0) << "anything beyond the half rounds up";
  EXPECT_EQ(sum_of({two53, 1.0, -1e-100}), two53) << "anything short of the half rounds down";
  EXPECT_EQ(sum_of({-two53, -1.0, -1e-100}), -(two53 + 2.0)) << "negative sums round by magnitude";
  // n copies of x: IEEE multiplication rounds n x once, as the exact sum must (here beyond the
  // accumulator's carry interval).
  for (const double x : {0.1, 1e300 / 3, -7.3e-310, 1.0 / 3.0}) {
    ExactSum s;
    for (int i = 0; i < 100000; ++i) s.add(x);
    EXPECT_EQ(bits(s.value()), bits(100000.0 * x)) << x;
  }
}

TEST(ExactSum, TheOrderAndTheSplitDoNotChangeABit) {
  std::vector<double> terms = wide_terms(20000, 39);
  ExactSum forward;
  for (double t : terms) forward.add(t);
  const double expected = forward.value();
  ASSERT_TRUE(std::isfinite(expected));
  std::mt19937_64 rng(7);
  for (int trial = 0; trial < 5; ++trial) {
    std::shuffle(terms.begin(), terms.end(), rng);
    // Split into parts merged in a shuffled order, and through state() added word by word as MPI
    // adds them across ranks.
    constexpr std::size_t kParts = 7;
    std::vector<ExactSum> parts(kParts);
    for (std::size_t i = 0; i < terms.size(); ++i) parts[(i * 31 + trial) % kParts].add(terms[i]);
    ExactSum merged;
    std::vector<std::size_t> order(kParts);
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), rng);
    std::vector<std::int64_t> words(ExactSum::kWords, 0);
    for (std::size_t p : order) {
      merged.add(parts[p]);
      const auto w = parts[p].state();
      for (std::size_t k = 0; k < words.size(); ++k) words[k] += w[k];
    }
    EXPECT_EQ(bits(merged.value()), bits(expected)) << "trial " << trial;
    EXPECT_EQ(bits(ExactSum::from_state(words).value()), bits(expected)) << "trial " << trial;
  }
  // The plain left-to-right sum is not order-free: the terms above would show it.
  double plain = 0, reversed = 0;
  for (double t : terms) plain += t;
  for (auto t = terms.rbegin(); t != terms.rend(); ++t) reversed += *t;
  EXPECT_NE(bits(plain), bits(reversed)) << "the terms must be hard enough to tell the methods apart";
}

TEST(ExactSum, AWindowOfTheChunksASumSetsIsEnoughToAddItAcrossProcesses) {
  // Sums of either sign set only the chunks their bits span (a negative one is not a long run of
  // borrowed chunks), so processes add the chunks within the union of their spans alone.
  ExactSum negative, positive, far;
  negative.add(-1.0), negative.add(-1e-3);
  positive.add(2.5), positive.add(1e-12);
  far.add(1e-200);
  const ExactSum::ChunkSpan n = negative.chunk_span(), p = positive.chunk_span(), f = far.chunk_span();
  EXPECT_LE(n.highest - n.lowest, 2) << "a negative sum stays compact";
  EXPECT_LE(p.highest - p.lowest, 2);
  EXPECT_EQ(ExactSum().chunk_span().highest, -1) << "nothing set";
  const ExactSum::ChunkSpan all{std::min({n.lowest, p.lowest, f.lowest}), std::max({n.highest, p.highest, f.highest})};
  std::vector<std::int64_t> words(static_cast<std::size_t>(all.highest - all.lowest + 1) + 3, 0);
  ExactSum whole;
  for (const ExactSum* part : {&negative, &positive, &far}) {
    const std::vector<std::int64_t> w = part->window(all);
    ASSERT_EQ(w.size(), words.size());
    for (std::size_t k = 0; k < w.size(); ++k) words[k] += w[k];
    whole.add(*part);
  }
  EXPECT_EQ(bits(ExactSum::from_window(all, words).value()), bits(whole.value()));
  EXPECT_EQ(ExactSum::from_window(all, words).value(), sum_of({-1.0, -1e-3, 2.5, 1e-12, 1e-200}));
}

TEST(ExactSum, NanAndInfinitiesFollowIeee) {
  const double inf = std::numeric_limits<double>::infinity(), max = std::numeric_limits<double>::max();
  EXPECT_TRUE(std::isnan(sum_of({1.0, std::nan(""), 2.0})));
  EXPECT_EQ(sum_of({1.0, inf}), inf);
  EXPECT_EQ(sum_of({1.0, -inf}), -inf);
  EXPECT_TRUE(std::isnan(sum_of({inf, -inf})));
  EXPECT_EQ(sum_of({max, max}), inf) << "beyond the largest double";
  EXPECT_EQ(sum_of({max, max, -max}), max) << "exact in between";
  ExactSum a, b;
  a.add(inf), b.add(-inf);
  a.add(b);
  EXPECT_TRUE(std::isnan(a.value()));
}
