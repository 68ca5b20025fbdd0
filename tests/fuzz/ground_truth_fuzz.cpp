// Fuzz target: kind=ground_truth files (ctsynth's truth_NNN.h5): their reader, synth::read_ground_truth
// (validate), and what the benches (bench/ct2labels_accuracy_bench.cpp, bench/labels2contacts_bench.cpp)
// read through these library calls, structure-aware (h5_mutator.hpp).
#include "fuzz_support.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/synth/ground_truth.hpp"
#include "h5_mutator.hpp"

GRAINTWIN_FUZZ_TARGET(ground_truth) {
  graintwin::fuzz::fuzz_h5_reader("ground truth reads", graintwin::fuzz::base_file("ground_truth.h5"), data, size,
                                  [](const std::filesystem::path& p) {
                                    const auto f = graintwin::io::open_kind(p, "ground_truth");
                                    graintwin::io::read_image_as<std::uint32_t>(f, "/labels");
                                    f.read<std::uint32_t>("/grains/label");
                                    f.read<double>("/grains/centroid");
                                    f.read<double>("/grains/equivalent_diameter");
                                    f.read<std::uint32_t>("/contacts/pair");
                                    f.read<double>("/contacts/normal");
                                    f.read<double>("/contacts/overlap");
                                    f.read<std::uint8_t>("/contacts/touching");
                                    graintwin::synth::read_ground_truth(p);
                                  });
}
