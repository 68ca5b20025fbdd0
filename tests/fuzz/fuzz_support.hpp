#pragma once
// Shared pieces of the reader fuzz targets (tests/fuzz/*_fuzz.cpp, docs/testing.md).
//
// Each target file registers one function with GRAINTWIN_FUZZ_TARGET(name). The same function is
// linked two ways: into a libFuzzer program per target (GRAINTWIN_FUZZ=ON, clang, ASan + UBSan),
// and into one replay program of the normal build that ctest runs (label `fuzz`), which feeds it
// the stored corpus and a bounded number of deterministic mutations of it.
//
// The contract every reader keeps under hostile input: it returns, or throws graintwin::Error
// (UsageError, DataError) with a short readable message. Any other exception, a crash, a sanitizer
// report, a hang or an absurd allocation is a defect; expect_clean() turns the escaping exception
// into an abort so that both programs report it with the input that caused it.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>

#include "graintwin/core/volume.hpp"

namespace graintwin::fuzz {

using TargetFn = void (*)(const std::uint8_t* data, std::size_t size);

/// Every target linked into this program, by name.
std::map<std::string, TargetFn>& targets();

struct TargetRegistrar {
  TargetRegistrar(const char* name, TargetFn fn) { targets()[name] = fn; }
};

#define GRAINTWIN_FUZZ_TARGET(name)                                                                  \
  static void graintwin_fuzz_##name(const std::uint8_t* data, std::size_t size);                   \
  static const ::graintwin::fuzz::TargetRegistrar graintwin_fuzz_registrar_##name(#name,           \
                                                                                 graintwin_fuzz_##name); \
  static void graintwin_fuzz_##name(const std::uint8_t* data, std::size_t size)

/// A folder of this process for the files a target writes (removed at exit).
const std::filesystem::path& scratch_dir();
/// Writes `size` bytes to scratch_dir() / name and returns the path.
std::filesystem::path write_scratch(const std::string& name, const std::uint8_t* data, std::size_t size);
/// A valid file of the project (tests/fuzz/base/<name>) that the structure-aware targets mutate.
std::filesystem::path base_file(const std::string& name);

/// Aborts with a message naming `reader` and what went wrong (the fuzzer keeps the input).
[[noreturn]] void defect(const std::string& reader, const std::string& what);
/// Checks the message of a graintwin::Error a reader threw: one readable sentence, not empty, not
/// pages long, no 309-digit numbers (more than 64 digits in a row).
void check_message(const std::string& reader, const std::string& message);

/// A volume a reader returned must be whole: as many values as its shape says.
void check_volume(const std::string& reader, const AnyVolume& v);

/// Runs `read`; graintwin::Error is a clean refusal, anything else escaping is a defect.
void expect_clean(const std::string& reader, void (*read)(void*), void* ctx);
template <class F>
void expect_clean(const std::string& reader, F&& read) {
  expect_clean(reader, [](void* f) { (*static_cast<F*>(f))(); }, &read);
}
/// Runs `read`, which must succeed (the unmutated base file of a structure-aware target).
void expect_success(const std::string& reader, void (*read)(void*), void* ctx);
template <class F>
void expect_success(const std::string& reader, F&& read) {
  expect_success(reader, [](void* f) { (*static_cast<F*>(f))(); }, &read);
}

/// Consumes fuzz input from the front; past the end every value is 0.
class ByteReader {
 public:
  ByteReader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  bool empty() const { return pos_ >= size_; }
  std::uint8_t u8() { return pos_ < size_ ? data_[pos_++] : 0; }
  std::uint16_t u16() { return static_cast<std::uint16_t>(u8() | (u8() << 8)); }
  std::uint32_t u32() { return u16() | (static_cast<std::uint32_t>(u16()) << 16); }
  std::uint64_t u64() { return u32() | (static_cast<std::uint64_t>(u32()) << 32); }
  /// The bytes not consumed yet.
  const std::uint8_t* rest() const { return data_ + std::min(pos_, size_); }
  std::size_t rest_size() const { return pos_ < size_ ? size_ - pos_ : 0; }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

}  // namespace graintwin::fuzz
