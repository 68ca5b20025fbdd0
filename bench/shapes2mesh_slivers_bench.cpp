// shapes2mesh_slivers_bench: what sliver removal buys fdemrun's element step and what it costs
// shapes2mesh, on the pipeline's twins of sand_small (ctsynth grains) and the real soil crop, 4-
// and 10-node, with the pass off (--min-dihedral 0 --min-altitude 0), on the altitude alone, on the
// dihedral alone, and at the defaults. The element step is fdemrun's own (fdem::Solver's
// time_step_limits: min over deformable elements of k h_min / c_d); what the element size promises
// is the same formula at each grain's median element altitude, the smallest over the grains.
//   shapes2mesh_slivers_bench [--quick]   (--quick: sand_small 10-node, pass off and defaults only)
#include <algorithm>
#include <filesystem>
#include <iostream>

#include <fmt/format.h>

#include "graintwin/fdem/element.hpp"
#include "graintwin/fdem/model_file.hpp"
#include "graintwin/fdem/solver.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/schema.hpp"
#include "harness.hpp"

using namespace graintwin;

namespace {

const std::string kSource = GRAINTWIN_SOURCE_DIR;

/// The pipeline's shapes2mesh parameters for a series (its own file when it has one).
std::string params_for(const std::string& series) {
  const std::filesystem::path own = kSource + "/pipelines/params/" + series + "/shapes2mesh.toml";
  return std::filesystem::exists(own) ? own.string() : kSource + "/pipelines/params/shapes2mesh.toml";
}

struct Variant {
  const char* name;
  std::vector<std::string> options;
};

/// fdemrun's element step of `model` against what its grains' element sizes promise, and the
/// grains whose worst element is more than 3 times below their median.
std::string step_figures(const fdem::Model& model, const fdem::MeshQualityTable& quality) {
  const fdem::Solver solver(model, fdem::SolverOptions{});
  const fdem::StepLimits limits = solver.time_step_limits();
  // The step of the grain's median element: k and c_d are the worst element's (one material).
  const double k_over_c = limits.element_critical / fdem::element_min_altitude(model, limits.element);
  double promised = std::numeric_limits<double>::infinity();
  std::size_t deformable = 0, beyond_3x = 0;
  std::vector<double> ratios;
  for (std::size_t g = 0; g < model.grains.size(); ++g) {
    if (model.grains[g].kind == fdem::GrainKind::rigid) continue;
    ++deformable;
    promised = std::min(promised, k_over_c * quality.median_altitude[g]);
    ratios.push_back(quality.step_ratio[g]);
    beyond_3x += quality.step_ratio[g] < 1.0 / 3.0;
  }
  std::sort(ratios.begin(), ratios.end());
  const std::size_t worst_grain = model.element_grain[limits.element];
  return fmt::format("element step {:.3g} s against {:.3g} s promised: {:.2f} x (set by grain {}, its worst element at {:.2f} "
                     "of its median altitude); per grain min / median altitude {:.2f} at the median grain, {:.2f} at worst; "
                     "{} of {} deformable grains beyond 3 x",
                     limits.element_critical, promised, limits.element_critical / promised, model.grains[worst_grain].label,
                     quality.step_ratio[worst_grain], ratios[ratios.size() / 2], ratios.front(), beyond_3x, deformable);
}

}  // namespace

int main(int argc, char** argv) {
  const bool quick = argc > 1 && std::string(argv[1]) == "--quick";
  bench::Report report("shapes2mesh_slivers_bench", "shapes2mesh: slivers against fdemrun's element step",
                       "The pipeline's twins (runs/SERIES/scan_000 shapes and labels, the pipeline's shapes2mesh parameters, "
                       "-j 2) of sand_small (ctsynth grains) and the real soil crop, 4- and 10-node, meshed with the sliver "
                       "pass off, on the altitude alone (--min-altitude), on the dihedral alone (--min-dihedral) and at the "
                       "defaults: shapes2mesh wall time (one run; the machine is shared), the element step fdemrun computes "
                       "(fdem::Solver::time_step_limits, k h_min / c_d over the deformable elements) against the step the "
                       "element size promises (the same at each grain's median element altitude, the smallest over the "
                       "grains; target: within 3 x), each grain's smallest over median altitude (/mesh/quality), elements "
                       "left below the thresholds, and the seconds of mesh_grain summed over the grains (the pass runs in it). " + bench::machine_summary());
  const std::string tool = (bench::bin_dir() / "shapes2mesh").string();
  const std::vector<Variant> variants = {{"no sliver pass", {"--min-dihedral", "0", "--min-altitude", "0"}},
                                         {"--min-altitude 0.35 alone", {"--min-dihedral", "0", "--min-altitude", "0.35"}},
                                         {"--min-dihedral 12 alone", {"--min-dihedral", "12", "--min-altitude", "0"}},
                                         {"defaults", {}}};
  for (const std::string series : {"sand_small", "soil_crop"}) {
    const std::filesystem::path scan = kSource + "/runs/" + series + "/scan_000";
    if (!std::filesystem::exists(scan / "shapes.h5") || !std::filesystem::exists(scan / "labels.h5")) {
      std::cerr << "no " << scan.string() << "/shapes.h5 and labels.h5: run make -f Makefile.pipeline SERIES=" << series << " shapes\n";
      continue;
    }
    if (quick && series != "sand_small") continue;
    for (const int order : {2, 1}) {
      if (quick && order == 1) continue;
      for (const Variant& v : variants) {
        if (quick && &v != &variants.front() && &v != &variants.back()) continue;
        const std::string model = "/tmp/shapes2mesh_slivers_bench_model.h5";
        std::vector<std::string> args = {tool, (scan / "shapes.h5").string(), (scan / "labels.h5").string(), model, "--force", "-q",
                                         "-j", "2", "--config", params_for(series), "--order", std::to_string(order)};
        args.insert(args.end(), v.options.begin(), v.options.end());
        bench::Row row = bench::run_child(fmt::format("{} scan 0, {}-node", series, order == 2 ? 10 : 4), v.name, args);
        const fdem::Model m = fdem::read_model_file(model);
        const auto quality = fdem::read_mesh_quality(model);
        if (!quality) throw std::runtime_error(model + " has no /mesh/quality");
        std::size_t below = 0;
        for (const auto n : quality->below_thresholds) below += n;
        double grain_seconds = 0;
        for (const double s : io::H5File::open(model).read<double>(schema::fdem_model::mesh::seconds)) grain_seconds += s;
        row.note = fmt::format("{} elements; {}; {} elements left below the thresholds; {:.1f} s in mesh_grain summed over the grains",
                               m.element_count(), step_figures(m, *quality), below, grain_seconds);
        report.add(row);
        std::filesystem::remove(model);
      }
    }
  }
  report.publish("defaults", kSource + "/docs/benchmarks.md");
}
