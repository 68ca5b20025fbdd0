// volume_io_bench: write and read a CT-like uint16 volume through GrainTwin's HDF5 layer and through
// h5py (the reference researchers use), same chunking and filters, each in its own process so peak
// memory is comparable.   build/bin/volume_io_bench [N=256]
#include <iostream>
#include <random>

#include "graintwin/io/volume_io.hpp"
#include "harness.hpp"

using namespace graintwin;

namespace {
Volume<std::uint16_t> ct_like(std::size_t n) {
  Volume<std::uint16_t> v({n, n, n}, {27.5e-6, 27.5e-6, 27.5e-6});
  std::mt19937_64 rng(1);
  std::normal_distribution<double> noise(20000.0, 3000.0);
  for (auto& x : v.values()) x = static_cast<std::uint16_t>(std::clamp(noise(rng), 0.0, 65535.0));
  return v;
}
}  // namespace

int main(int argc, char** argv) {
  const std::string self = argv[0];
  if (argc >= 3 && std::string(argv[1]) == "--child-write") {
    io::write_volume_file(argv[2], ct_like(std::stoul(argv[3])), {});
    return 0;
  }
  if (argc >= 3 && std::string(argv[1]) == "--child-read") {
    const AnyVolume v = io::read_volume_file(argv[2]);
    std::cout << std::get<Volume<std::uint16_t>>(v).values()[0] << "\n";
    return 0;
  }
  const std::size_t n = argc > 1 ? std::stoul(argv[1]) : 256;
  const std::string tmp = "/tmp/graintwin_volume_io_bench";
  const std::string ours = tmp + "_ours.h5", ref = tmp + "_h5py.h5";
  const std::string py = std::string(GRAINTWIN_SOURCE_DIR) + "/bench/reference/h5py_volume_io.py";
  const std::string label = std::to_string(n) + "^3 uint16";
  bench::Report report("volume_io_bench", "Volume I/O: GrainTwin HDF5 layer vs h5py",
                       "Write (including generating the noisy volume) and full read of a CT-like uint16 volume, "
                       "chunked 16x64x256 with shuffle + gzip level 4, each run in its own process (best of 3); "
                       "the reference is Debian's python3-h5py with numpy.");
  report.add(bench::run_child("write " + label, "h5py", {"/usr/bin/python3", py, "write", ref, std::to_string(n)}, 3));
  report.add(bench::run_child("write " + label, "graintwin", {self, "--child-write", ours, std::to_string(n)}, 3));
  report.add(bench::run_child("read " + label, "h5py", {"/usr/bin/python3", py, "read", ref}, 3));
  report.add(bench::run_child("read " + label, "graintwin", {self, "--child-read", ours}, 3));
  report.publish("h5py", std::string(GRAINTWIN_SOURCE_DIR) + "/docs/benchmarks.md");
  std::remove(ours.c_str());
  std::remove(ref.c_str());
  return 0;
}
