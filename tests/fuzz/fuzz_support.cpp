#include "fuzz_support.hpp"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <typeinfo>

#include "graintwin/core/error.hpp"

namespace graintwin::fuzz {

namespace fs = std::filesystem;

std::map<std::string, TargetFn>& targets() {
  static std::map<std::string, TargetFn> all;
  return all;
}

namespace {
struct Scratch {
  fs::path dir;
  Scratch() {
    dir = fs::temp_directory_path() / ("graintwin-fuzz-" + std::to_string(::getpid()));
    fs::create_directories(dir);
  }
  ~Scratch() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};
}  // namespace

const fs::path& scratch_dir() {
  static Scratch s;
  return s.dir;
}

fs::path write_scratch(const std::string& name, const std::uint8_t* data, std::size_t size) {
  const fs::path p = scratch_dir() / name;
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  if (!out) defect("fuzz support", "cannot write " + p.string());
  return p;
}

fs::path base_file(const std::string& name) { return fs::path(GRAINTWIN_FUZZ_BASE_DIR) / name; }

void defect(const std::string& reader, const std::string& what) {
  std::fprintf(stderr, "\nFUZZ DEFECT in %s: %s\n", reader.c_str(), what.c_str());
  std::fflush(stderr);
  std::abort();
}

void check_message(const std::string& reader, const std::string& message) {
  if (message.empty()) defect(reader, "threw a graintwin::Error with an empty message");
  if (message.size() > 2000) defect(reader, "threw a message of " + std::to_string(message.size()) + " characters: " + message.substr(0, 300));
  std::size_t digits = 0;
  for (char c : message) {
    digits = (c >= '0' && c <= '9') ? digits + 1 : 0;
    // 64: an excerpt of the file's text (at most 60 characters) may be digits; a computed number
    // printed in full (309 digits of 1e308) is not.
    if (digits > 64) defect(reader, "printed a number of more than 64 digits: " + message);
  }
}

void check_volume(const std::string& reader, const AnyVolume& v) {
  const Shape3& s = shape_of_any(v);
  const std::size_t values = std::visit([](const auto& vol) { return vol.size(); }, v);
  const long double want = static_cast<long double>(s[0]) * s[1] * s[2];
  if (want != static_cast<long double>(values))
    defect(reader, "returned a volume of shape " + std::to_string(s[0]) + " x " + std::to_string(s[1]) + " x " +
                       std::to_string(s[2]) + " holding " + std::to_string(values) + " values");
}

void expect_clean(const std::string& reader, void (*read)(void*), void* ctx) {
  try {
    read(ctx);
  } catch (const Error& e) {
    check_message(reader, e.message());
  } catch (const std::exception& e) {
    defect(reader, std::string("let a ") + typeid(e).name() + " escape instead of a graintwin::Error: " + e.what());
  } catch (...) {
    defect(reader, "let an exception of unknown type escape");
  }
}

void expect_success(const std::string& reader, void (*read)(void*), void* ctx) {
  try {
    read(ctx);
  } catch (const Error& e) {
    defect(reader, "refused its unmutated base file (" + e.message() +
                       "); regenerate tests/fuzz/base with tests/fuzz/make_base_files.sh");
  } catch (const std::exception& e) {
    defect(reader, std::string("failed on its unmutated base file: ") + e.what());
  }
}

}  // namespace graintwin::fuzz
