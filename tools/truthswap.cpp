// truthswap: a stage's output with the ground truth of its ctsynth scan put in its place, so the
// stages after it run on exact input (docs/truthswap.md).
//   truthswap truth_000.h5 runs/sand_small/scan_000/labels.h5 exact/labels.h5
#include <spdlog/spdlog.h>

#include "graintwin/cli/tool.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "graintwin/validate/truth_swap.hpp"

namespace fs = std::filesystem;
using namespace graintwin;
using namespace graintwin::validate;

int main(int argc, char** argv) {
  cli::Tool tool(
      "truthswap",
      "Puts the ground truth of a ctsynth scan in place of a stage's output of that scan, so that the stages after it "
      "run on exact input and the error each stage adds downstream (to the twin above all) can be measured. A labels "
      "file (ct2labels) becomes the truth's label image with its grain table, ct2labels' sample cylinder and the true "
      "void ratio in it. A shapes file (labels2shapes) has every grain that its labels reproduce (IoU >= 0.8 with one "
      "true grain) given that grain's exact SH surface and the volume, area, inertia ellipsoid and sphericity measured "
      "on it, with no fit error and no flag; with --positions, its true centroid too. Grains not faithfully segmented "
      "keep their measured shape. The output is a file of the input's kind, which every later stage reads as usual.");
  TruthSwapFiles files;
  ShapeSwapOptions options;
  fs::path output;
  auto& app = tool.cli();
  tool.add_input("truth", files.truth, "The scan's ground truth (truth_NNN.h5, kind=ground_truth, from ctsynth)");
  tool.add_input("input", files.input, "The stage's output for that scan: a labels file (ct2labels) or a shapes file (labels2shapes)");
  tool.add_output("output", output, "File to write, of the input's kind (.h5)");
  app.add_option("--labels", files.labels, "With a shapes file: the labels file it was measured from (matches its grains to the true ones)");
  app.add_flag("--positions", options.positions, "With a shapes file: the true centroids too, not only the true surfaces");
  tool.set_examples({"truthswap sample_volumes/sand_small/truth_000.h5 runs/sand_small/scan_000/labels.h5 exact/scan_000/labels.h5",
                     "truthswap sample_volumes/sand_small/truth_000.h5 exact/scan_000/shapes.h5 exact_shapes/scan_000/shapes.h5 "
                     "--labels exact/scan_000/labels.h5 --positions"});

  return tool.run(argc, argv, [&](cli::RunContext& ctx) {
    check_truth_swap(files, options);
    if (!files.labels.empty()) io::declare_input(files.labels);  // read by option: no output may replace it
    io::AtomicOutput out(output, ctx.force());
    for (const fs::path& p : {files.truth, files.input, files.labels})
      if (!p.empty()) ctx.add_input_history(io::H5File::open(p));
    const TruthSwapSummary s = swap_truth(files, options, out.temp_path(), ctx.history());
    io::commit_outputs({&out});
    spdlog::info("{} file: {} of {} grains take the truth, {} kept as measured", s.kind, s.swapped, s.grains, s.kept);
  });
}
