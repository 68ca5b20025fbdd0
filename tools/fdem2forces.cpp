// fdem2forces: contact-force and grain-stress statistics of a simulation (docs/methods.md, micro-mechanics).
//   fdem2forces runs/sand_small/results.h5 runs/sand_small/forces.h5 --chains runs/sand_small/chains
#include <spdlog/spdlog.h>

#include <optional>

#include "graintwin/cli/option_checks.hpp"
#include "graintwin/cli/tool.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/micro/forces_analysis.hpp"

namespace fs = std::filesystem;
using namespace graintwin;
using namespace graintwin::micro;

namespace {

void log_statistics(const ForcesFile& content, std::size_t grains, const ForcesOptions& o) {
  for (const FrameForces& ff : content.frames)
    spdlog::debug("frame {}: {} grain contacts, <f_n> {:.4g} N, {} strong", ff.frame, ff.contacts, ff.distribution.mean, ff.strong);
  for (const VolatilityWindow& w : content.windows) {
    spdlog::info("window {} -> {}: Pearson r of volatility against D2min {:.3f} (p = {:.3g}) over {} grains", w.from, w.to,
                 w.correlation.r, w.correlation.p_value, w.correlation.count);
    if (w.correlation.count < 3) spdlog::warn("window {} -> {}: fewer than 3 grains have both a volatility and a D2min", w.from, w.to);
  }
  const FrameForces& end = content.frames.back();
  spdlog::info("{} grains, frames {}..{}; last frame: {} grain contacts, <f_n> {:.4g} N, {} strong (f_n >= {:g} <f_n>); "
               "strong scale {:.3g}, weak theta {:.3g}",
               grains, o.first, o.last, end.contacts, end.distribution.mean, end.strong, o.chain_threshold,
               end.distribution.strong.scale, end.distribution.weak.theta);
}

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool(
      "fdem2forces",
      "Contact-force and grain-stress statistics of a simulation (kind=fdem_results, from fdemrun), per saved frame: "
      "the PDF of f = f_n/<f_n> over the grain-grain contacts (platen contacts left out) in log bins, with a "
      "maximum-likelihood exponential fit of the strong forces (f >= 1, P ~ exp(-(f-1)/scale)) and a power law of the "
      "weak ones (f < 1, P ~ f^theta); the rose of mean normal force per direction; force chains as VTK lines "
      "(--chains: the strong network, contacts with f_n >= --chain-threshold x <f_n>; 1 = the usual definition, "
      "Radjai et al. 1998); the grain stress q = sqrt(1/2 s_ij s_ij), s the deviatoric part of the volume-averaged grain "
      "stress (the CT-FDEM paper's definition; for rigid grains fdemrun stores the Love-Weber average of their contact forces); per strain window of --window "
      "frames the volatility of q (sample standard deviation of ln(q_i/q_{i-1})) and Pearson's r against D2min (from "
      "--micro, else Falk-Langer D2min over --radius-d50 from the frames' centroids) with its two-sided p-value. "
      "Writes kind=forces (.h5).");
  fs::path input, output, chains, micro_path;
  long long from = -1, to = -1;
  std::size_t window = 0, min_neighbours = 3;
  double threshold = 1.0, per_decade = 5.0, radius_d50 = 1.5;
  int theta_bins = 9, phi_bins = 36;
  auto& app = tool.cli();
  tool.add_input("results", input, "Simulation results (.h5, kind=fdem_results, from fdemrun)");
  tool.add_output("forces", output, "Force statistics file to write (.h5, kind=forces)");
  using cli::above, cli::closed, cli::number_in, cli::whole_number_in;
  app.add_option("--from", from, "First frame analysed (default 0)")->check(whole_number_in(0, 1000000000));
  app.add_option("--to", to, "Last frame analysed (default the last)")->check(whole_number_in(0, 1000000000));
  app.add_option("--window", window,
                 "Strain window of the volatility, in frames: windows from, from+W, ... (each W frames, W returns of q); "
                 "0 = one window over every analysed frame")
      ->check(whole_number_in(0, 1000000000, "frames"))->capture_default_str();
  app.add_option("--chain-threshold", threshold,
                 "Force chains: contacts with f_n >= this x <f_n> (1: the strong network of Radjai et al. 1998)")
      ->check(number_in(above(0, 1000)))->capture_default_str();
  app.add_option("--chains", chains,
                 "Folder to write the force chains to: chains_<frame>.vtp (VTK lines between contacting grain centroids, "
                 "cell data normal_force in N) and chains.pvd (ParaView time series)");
  app.add_option("--micro", micro_path,
                 "D2min from this kind=micro file (tracks2micro on the same results file; it needs the increment of each "
                 "window) instead of computing it from the frames' centroids");
  app.add_option("--radius-d50", radius_d50, "D2min neighbourhood radius in d50 (without --micro)")
      ->check(number_in(above(0, 100, "d50")))->capture_default_str();
  app.add_option("--min-neighbours", min_neighbours, "Fewest neighbours for D2min (without --micro)")
      ->check(whole_number_in(3, 1000))->capture_default_str();
  app.add_option("--pdf-bins-per-decade", per_decade, "Log bins per decade of the force PDF")
      ->check(number_in(closed(1, 100)))->capture_default_str();
  app.add_option("--rose-theta-bins", theta_bins, "Rose bins of the polar angle from +z over [0, 90] deg")
      ->check(whole_number_in(1, 180))->capture_default_str();
  app.add_option("--rose-phi-bins", phi_bins, "Rose bins of the azimuth from +x over [0, 360] deg")
      ->check(whole_number_in(1, 360))->capture_default_str();
  tool.set_examples({"fdem2forces runs/sand_small/results.h5 runs/sand_small/forces.h5 --chains runs/sand_small/chains",
                     "fdem2forces results.h5 forces.h5 --window 4 --micro micro.h5"});

  return tool.run(argc, argv, [&](cli::RunContext& ctx) {
    // Options and files first, before reading any frame.
    if (output.extension() != ".h5") throw UsageError("the forces file " + output.string() + " must end in .h5");
    if (window == 1) throw UsageError("--window 1 gives one return of q per grain and no volatility; use 2 or more (or 0 for all frames)");
    io::AtomicOutput out(output, ctx.force());
    std::optional<io::AtomicOutput> chains_out;
    if (!chains.empty()) chains_out.emplace(chains, ctx.force());
    ctx.add_input_history(io::open_kind(input, schema::kind::fdem_results, "pass the output of fdemrun"));
    const SimulationGrains grains = read_simulation_grains(input);
    ForcesOptions o = forces_frame_range(fdem::results_frame_count(input), from, to, window, input.string());
    o.chain_threshold = threshold, o.per_decade = per_decade, o.theta_bins = theta_bins, o.phi_bins = phi_bins;
    o.radius_d50 = radius_d50, o.min_neighbours = min_neighbours;
    std::optional<MicroTables> micro;
    if (!micro_path.empty()) {
      ctx.add_input_history(io::open_kind(micro_path, schema::kind::micro, "pass the output of tracks2micro on the results file"));
      micro = read_micro_tables(micro_path);
    }
    if (chains_out) fs::create_directories(chains_out->temp_path());

    ForceChainFiles chain_files;
    const ForcesFile content = force_statistics(input, grains, o, micro ? &*micro : nullptr, micro_path.string(),
                                                chains_out ? chains_out->temp_path() : fs::path(), &chain_files,
                                                ctx.progress_callback("frames"));
    log_statistics(content, grains.label.size(), o);
    write_forces_file(out.temp_path(), content, ctx.history());
    if (chains_out) write_pvd(chains_out->temp_path() / "chains.pvd", chain_files.files, chain_files.times);
    io::commit_outputs({&out, chains_out ? &*chains_out : nullptr});
  });
}
