// validate: a pipeline run scored against the ground truth of the ctsynth series it was made from
// (docs/validate.md): the error budget of every stage, written as validation.json.
//   validate runs/sand_small sample_volumes/sand_small runs/sand_small/validation.json
#include <spdlog/spdlog.h>

#include "graintwin/cli/tool.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "graintwin/validate/run_validation.hpp"

namespace fs = std::filesystem;
using namespace graintwin;
using namespace graintwin::validate;

int main(int argc, char** argv) {
  cli::Tool tool(
      "validate",
      "Scores a pipeline run against the ground truth of the ctsynth series it was made from and writes the error budget "
      "as JSON. RUNDIR is what Makefile.pipeline wrote (every scan_*/labels.h5, with contacts.h5 and shapes.h5 where the "
      "stages ran, tracks.h5, micro.h5, simulation.h5); SERIESDIR holds the truth_NNN.h5 beside each scan_NNN.h5. "
      "Lines, per scan or increment: segmentation (true grains reproduced with IoU >= 0.8, split, merged, missed; void "
      "ratio against the truth's in ct2labels' sample cylinder), contacts between faithfully segmented grains (found, "
      "missed, false; normal error in degrees; fabric anisotropy), shapes (SH invariant, volume and diameter errors), "
      "tracking (right, wrong, lost; displacement and rotation errors), D2min and eps_q (Spearman rank correlation with "
      "the truth's, computed by the micro module with the run's parameters), high-D2min clusters (Jaccard index), and "
      "the twin (the simulation's stress ratio and volumetric strain against a simulated series' loading curve; null for "
      "prescribed loading). A stage the run lacks leaves its line empty.");
  fs::path run_dir, series_dir, output;
  ValidationOptions vo;
  auto& app = tool.cli();
  tool.add_input("rundir", run_dir, "Run directory of Makefile.pipeline (runs/<series>)", false);
  tool.add_input("seriesdir", series_dir, "The ctsynth series the run was made from (sample_volumes/<series>, with truth_NNN.h5)", false);
  tool.add_output("validation", output, "JSON file to write (validation.json)");
  app.add_flag("--all-contacts", vo.all_contacts,
               "Count every contact of the contacts files, not only those labels2contacts accepted (counted in Z and the fabric)");
  tool.set_examples({"validate runs/sand_small sample_volumes/sand_small runs/sand_small/validation.json"});

  return tool.run(argc, argv, [&](cli::RunContext& ctx) {
    if (output.extension() != ".json") throw UsageError("the output " + output.string() + " must end in .json");
    io::AtomicOutput out(output, ctx.force());
    const ValidationFiles files = locate_validation_files(run_dir, series_dir);
    for (const fs::path& p : files.all()) {
      if (p.extension() == ".h5") ctx.add_input_history(io::H5File::open(p));
    }
    Validation v = validate_run(files, vo, ctx.progress_callback("scoring"));
    v.history = ctx.history();
    const BudgetSummary s = summarise(v);
    spdlog::info("{:.1f} % of true grains right; tracking {} right, {} wrong, {} lost; D2min Spearman {:.3f}; twin: {}",
                 100.0 * s.grains_right, s.tracking_right, s.tracking_wrong, s.tracking_lost, s.d2min_spearman,
                 v.twin.simulated ? fmt::format("stress ratio RMS {:.3f}", v.twin.stress_ratio_rms_rel) : std::string("prescribed loading"));
    write_validation(out.temp_path(), v);
    io::commit_outputs({&out});
  });
}
