#include "graintwin/core/exact_sum.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

namespace graintwin {
namespace {

constexpr std::int64_t kChunkMask = (std::int64_t{1} << ExactSum::kChunkBits) - 1;
/// Terms added between two normalizations: each adds less than 2^50 to a chunk, so 4 096 of them
/// stay below 2^62 on top of a normalized chunk.
constexpr std::uint32_t kTermsBetweenCarries = 4096;

/// Bits up to the highest one set.
int width_of(unsigned __int128 v) {
  const auto high = static_cast<std::uint64_t>(v >> 64);
  return high ? 64 + std::bit_width(high) : std::bit_width(static_cast<std::uint64_t>(v));
}

}  // namespace

void ExactSum::add(double x) {
  const std::uint64_t bits = std::bit_cast<std::uint64_t>(x);
  const int biased = static_cast<int>((bits >> 52) & 0x7ff);
  const std::uint64_t fraction = bits & ((std::uint64_t{1} << 52) - 1);
  const bool negative = bits >> 63;
  if (biased == 0x7ff) {
    if (fraction != 0) ++nan_;
    else ++(negative ? minus_infinity_ : plus_infinity_);
    return;
  }
  // |x| = mantissa x 2^(lowest bit's exponent), that exponent at least kLowestExponent.
  const std::uint64_t mantissa = biased == 0 ? fraction : fraction | (std::uint64_t{1} << 52);
  if (mantissa == 0) return;
  const int position = (biased == 0 ? 1 : biased) - 1075 - kLowestExponent;
  const auto chunk = static_cast<std::size_t>(position / kChunkBits);
  const unsigned __int128 placed = static_cast<unsigned __int128>(mantissa) << (position % kChunkBits);
  const std::int64_t sign = negative ? -1 : 1;
  for (std::size_t k = 0; k < 3 && chunk + k < kChunks; ++k)
    chunk_[chunk + k] += sign * static_cast<std::int64_t>((placed >> (kChunkBits * k)) & kChunkMask);
  if (++since_normalized_ >= kTermsBetweenCarries) normalize();
}

void ExactSum::add(const ExactSum& other) {
  const std::array<std::int64_t, kWords> words = other.state();
  normalize();
  for (std::size_t k = 0; k < kChunks; ++k) chunk_[k] += words[k];
  nan_ += other.nan_, plus_infinity_ += other.plus_infinity_, minus_infinity_ += other.minus_infinity_;
  normalize();
}

void ExactSum::normalize() {
  for (std::size_t k = 0; k + 1 < kChunks; ++k) {
    const std::int64_t carry = chunk_[k] >> kChunkBits;  // floor: the chunk keeps [0, 2^50)
    chunk_[k] -= carry * (std::int64_t{1} << kChunkBits);
    chunk_[k + 1] += carry;
  }
  since_normalized_ = 0;
}

void ExactSum::balance() {
  constexpr std::int64_t half = std::int64_t{1} << (kChunkBits - 1);
  for (std::size_t k = 0; k + 1 < kChunks; ++k) {
    const std::int64_t carry = (chunk_[k] + half) >> kChunkBits;  // to nearest: the chunk keeps [-2^49, 2^49)
    chunk_[k] -= carry * (std::int64_t{1} << kChunkBits);
    chunk_[k + 1] += carry;
  }
  since_normalized_ = 0;
}

ExactSum::ChunkSpan ExactSum::chunk_span() const {
  const std::array<std::int64_t, kWords> words = state();
  ChunkSpan span;
  for (int k = 0; k < static_cast<int>(kChunks); ++k)
    if (words[k] != 0) span.lowest = std::min(span.lowest, k), span.highest = k;
  return span;
}

std::vector<std::int64_t> ExactSum::window(ChunkSpan span) const {
  const std::array<std::int64_t, kWords> words = state();
  std::vector<std::int64_t> out;
  for (int k = span.lowest; k <= span.highest; ++k) out.push_back(words[k]);
  out.insert(out.end(), words.begin() + kChunks, words.end());
  return out;
}

ExactSum ExactSum::from_window(ChunkSpan span, std::span<const std::int64_t> words) {
  std::array<std::int64_t, kWords> all{};
  std::size_t at = 0;
  for (int k = span.lowest; k <= span.highest && at < words.size(); ++k) all[k] = words[at++];
  for (std::size_t k = kChunks; k < kWords && at < words.size(); ++k) all[k] = words[at++];
  return from_state(all);
}

std::array<std::int64_t, ExactSum::kWords> ExactSum::state() const {
  ExactSum normal = *this;
  normal.balance();
  std::array<std::int64_t, kWords> words{};
  for (std::size_t k = 0; k < kChunks; ++k) words[k] = normal.chunk_[k];
  words[kChunks] = nan_, words[kChunks + 1] = plus_infinity_, words[kChunks + 2] = minus_infinity_;
  return words;
}

ExactSum ExactSum::from_state(std::span<const std::int64_t> words) {
  ExactSum s;
  for (std::size_t k = 0; k < kChunks && k < words.size(); ++k) s.chunk_[k] = words[k];
  if (words.size() >= kWords) s.nan_ = words[kChunks], s.plus_infinity_ = words[kChunks + 1], s.minus_infinity_ = words[kChunks + 2];
  s.normalize();
  return s;
}

double ExactSum::value() const {
  if (nan_ > 0 || (plus_infinity_ > 0 && minus_infinity_ > 0)) return std::numeric_limits<double>::quiet_NaN();
  if (plus_infinity_ > 0) return std::numeric_limits<double>::infinity();
  if (minus_infinity_ > 0) return -std::numeric_limits<double>::infinity();
  ExactSum magnitude = *this;
  magnitude.normalize();  // every chunk in [0, 2^50) but the last, whose sign is the sum's
  const bool negative = magnitude.chunk_[kChunks - 1] < 0;
  if (negative) {
    for (std::int64_t& c : magnitude.chunk_) c = -c;
    magnitude.normalize();
  }
  const std::array<std::int64_t, kChunks>& c = magnitude.chunk_;
  int top = static_cast<int>(kChunks) - 1;
  while (top >= 0 && c[top] == 0) --top;
  if (top < 0) return 0.0;
  // The leading 64 bits or more (at most 114), then whether anything below them is set.
  unsigned __int128 lead = static_cast<std::uint64_t>(c[top]);
  int lowest = top;
  while (width_of(lead) < 64 && lowest > 0) lead = (lead << kChunkBits) | static_cast<std::uint64_t>(c[--lowest]);
  bool sticky = false;
  for (int k = 0; k < lowest && !sticky; ++k) sticky = c[k] != 0;
  const int width = width_of(lead);
  int exponent = kLowestExponent + kChunkBits * lowest;
  std::uint64_t kept = 0;
  if (width <= 53) {
    kept = static_cast<std::uint64_t>(lead);  // exact: nothing below (the loop reached chunk 0)
  } else {
    const int shift = width - 53;
    kept = static_cast<std::uint64_t>(lead >> shift);
    const unsigned __int128 rest = lead & ((static_cast<unsigned __int128>(1) << shift) - 1);
    const unsigned __int128 half = static_cast<unsigned __int128>(1) << (shift - 1);
    if (rest > half || (rest == half && (sticky || (kept & 1)))) ++kept;  // to nearest, ties to even
    exponent += shift;
    if (kept >> 53) kept >>= 1, ++exponent;  // rounded up to the next power of two
  }
  const double result = std::ldexp(static_cast<double>(kept), exponent);
  return negative ? -result : result;
}

}  // namespace graintwin
