// Replays fuzz inputs through the targets without libFuzzer: the stored corpus and regression
// inputs, then a bounded number of deterministic byte mutations of them. ctest runs it per target
// (label `fuzz`) in the normal build as a cheap smoke test; scripts/fuzz.sh does the real fuzzing.
//
//   graintwin_fuzz_replay TARGET [--mutations N] [--seconds S] FILE_OR_FOLDER...
//
// A defect aborts; the input that caused it is first saved as ./fuzz-<target>-defect.bin (rerun
// it with `graintwin_fuzz_replay TARGET fuzz-<target>-defect.bin`, or with the libFuzzer program).
#include <fcntl.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "fuzz_support.hpp"

namespace fs = std::filesystem;
using Bytes = std::vector<std::uint8_t>;

namespace {

// What is being run, for the signal handler (set before each input).
const Bytes* g_input = nullptr;
std::string g_label;
std::string g_defect_file;

extern "C" void save_input_and_die(int sig) {
  if (g_input) {
    const int fd = ::open(g_defect_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      if (!g_input->empty() && ::write(fd, g_input->data(), g_input->size()) < 0) {}
      ::close(fd);
    }
    const std::string msg = "fuzz replay: input " + g_label + " failed; saved as " + g_defect_file + "\n";
    if (::write(2, msg.data(), msg.size()) < 0) {}
  }
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

Bytes read_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return Bytes(std::istreambuf_iterator<char>(in), {});
}

/// One to four random edits of the kinds libFuzzer makes: bit flips, byte values, interesting
/// values, inserted, erased and duplicated ranges, truncation.
Bytes mutate(const Bytes& seed, std::mt19937_64& rng) {
  Bytes b = seed;
  const int edits = 1 + static_cast<int>(rng() % 4);
  const std::uint8_t interesting[] = {0x00, 0x01, 0x7f, 0x80, 0xff, 0xfe, 0x20, 0x0a, '=', '[', '"', '-', '9'};
  for (int e = 0; e < edits; ++e) {
    const std::size_t at = b.empty() ? 0 : rng() % b.size();
    switch (rng() % 7) {
      case 0: if (!b.empty()) b[at] ^= static_cast<std::uint8_t>(1u << (rng() % 8)); break;
      case 1: if (!b.empty()) b[at] = static_cast<std::uint8_t>(rng()); break;
      case 2: if (!b.empty()) b[at] = interesting[rng() % std::size(interesting)]; break;
      case 3: b.insert(b.begin() + static_cast<std::ptrdiff_t>(at), 1 + rng() % 8, static_cast<std::uint8_t>(rng())); break;
      case 4: if (!b.empty()) b.erase(b.begin() + static_cast<std::ptrdiff_t>(at), b.begin() + static_cast<std::ptrdiff_t>(std::min(b.size(), at + 1 + rng() % 16))); break;
      case 5: if (!b.empty()) { const Bytes chunk(b.begin() + static_cast<std::ptrdiff_t>(at), b.begin() + static_cast<std::ptrdiff_t>(std::min(b.size(), at + 1 + rng() % 32))); b.insert(b.begin() + static_cast<std::ptrdiff_t>(rng() % b.size()), chunk.begin(), chunk.end()); } break;
      case 6: b.resize(at); break;
    }
  }
  return b;
}

int usage() {
  std::fprintf(stderr, "usage: graintwin_fuzz_replay TARGET [--mutations N] [--seconds S] FILE_OR_FOLDER...\ntargets:");
  for (const auto& [name, fn] : graintwin::fuzz::targets()) std::fprintf(stderr, " %s", name.c_str());
  std::fprintf(stderr, "\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage();
  const std::string name = argv[1];
  const auto it = graintwin::fuzz::targets().find(name);
  if (it == graintwin::fuzz::targets().end()) return usage();
  long mutations = 0;
  double seconds = 1e9;
  std::vector<fs::path> files;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--mutations" && i + 1 < argc) mutations = std::stol(argv[++i]);
    else if (a == "--seconds" && i + 1 < argc) seconds = std::stod(argv[++i]);
    else if (fs::is_directory(a)) {
      for (const auto& e : fs::directory_iterator(a))
        if (e.is_regular_file()) files.push_back(e.path());
    } else if (fs::is_regular_file(a)) files.push_back(a);
    else if (!fs::exists(a)) { std::fprintf(stderr, "graintwin_fuzz_replay: %s does not exist\n", a.c_str()); return 2; }
  }
  std::sort(files.begin(), files.end());
  g_defect_file = "fuzz-" + name + "-defect.bin";
  for (int sig : {SIGABRT, SIGSEGV, SIGBUS, SIGFPE, SIGILL}) std::signal(sig, save_input_and_die);

  const auto t0 = std::chrono::steady_clock::now();
  const auto run = [&](const Bytes& input, const std::string& label) {
    g_input = &input;
    g_label = label;
    it->second(input.data(), input.size());
  };
  std::vector<Bytes> corpus{Bytes{}};  // the empty input first (a structure-aware target's unmutated base)
  for (const fs::path& f : files) corpus.push_back(read_bytes(f));
  for (std::size_t i = 0; i < corpus.size(); ++i) run(corpus[i], i == 0 ? "(empty)" : files[i - 1].string());
  std::mt19937_64 rng(20240522);
  long done = 0;
  for (; done < mutations; ++done) {
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > seconds) break;
    const std::size_t k = 1 + rng() % std::max<std::size_t>(1, corpus.size() - 1);
    const Bytes m = mutate(corpus[std::min(k, corpus.size() - 1)], rng);
    run(m, "mutation " + std::to_string(done) + " of " + (k < corpus.size() && k > 0 ? files[k - 1].string() : "(empty)"));
  }
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("%s: %zu stored inputs and %ld mutations handled cleanly in %.1f s\n", name.c_str(), corpus.size(), done, secs);
  return 0;
}
