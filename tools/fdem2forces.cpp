// fdem2forces: contact-force and grain-stress statistics of a simulation (docs/methods.md, micro-mechanics).
//   fdem2forces runs/sand_small/results.h5 runs/sand_small/forces.h5 --chains runs/sand_small/chains
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <cmath>
#include <optional>

#include "graintwin/cli/option_checks.hpp"
#include "graintwin/cli/tool.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/micro/forces_file.hpp"
#include "graintwin/micro/local_deformation.hpp"
#include "graintwin/micro/micro_file.hpp"
#include "graintwin/micro/simulation.hpp"

namespace fs = std::filesystem;
using namespace graintwin;
using namespace graintwin::micro;

namespace {

/// D2min / d50^2 per simulation grain for increment from -> to of a kind=micro file made from the
/// same results file (tracks2micro RESULTS MICRO); UsageError naming the fix when it does not fit.
std::vector<double> d2min_from_micro(const io::H5File& m, const SimulationGrains& grains, std::size_t from, std::size_t to) {
  const std::string name = m.path().string();
  const std::string source = read_micro_source(m);
  if (source != "fdem_results")
    throw UsageError("--micro " + name + " was made from " + source + ", not from simulation frames; run tracks2micro on the results file");
  const auto inc_from = m.read<std::uint64_t>(schema::micro::increment_from), inc_to = m.read<std::uint64_t>(schema::micro::increment_to);
  std::size_t k = inc_from.size();
  for (std::size_t q = 0; q < inc_from.size(); ++q)
    if (inc_from[q] == from && inc_to[q] == to) k = q;
  if (k == inc_from.size())
    throw UsageError("--micro " + name + " has no increment " + std::to_string(from) + " -> " + std::to_string(to) +
                     "; run tracks2micro RESULTS MICRO --from " + std::to_string(from) + " --to " + std::to_string(to) +
                     " or leave out --micro");
  std::vector<hsize_t> label_dims, d2_dims;
  const auto label = m.read<std::uint32_t>(schema::micro::grain_label, &label_dims);
  const auto d2min = m.read<double>(schema::micro::grain_d2min, &d2_dims);
  const std::size_t t = label_dims.at(1), kk = d2_dims.at(1);
  std::vector<double> out(grains.label.size(), std::nan(""));
  std::size_t found = 0;
  for (std::size_t i = 0; i < label_dims[0]; ++i) {
    const auto it = grains.row.find(label[i * t + from]);
    if (it != grains.row.end()) out[it->second] = d2min[i * kk + k], ++found;
  }
  if (found != grains.label.size())
    throw UsageError("--micro " + name + " lacks " + std::to_string(grains.label.size() - found) +
                     " of the simulation's grains; make it from the same results file with tracks2micro");
  return out;
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
    const io::H5File results = io::open_kind(input, schema::kind::fdem_results, "pass the output of fdemrun");
    ctx.add_input_history(results);
    const SimulationGrains grains = read_simulation_grains(input);
    const std::size_t frame_count = fdem::results_frame_count(input);
    if (frame_count == 0) throw DataError(input.string() + " holds no frames; run fdemrun with a frame_interval that saves some");
    if (frame_count == 1)
      throw DataError(input.string() + " holds a single frame, and the grains' volatility needs two frames or more; run fdemrun "
                      "with a frame_interval that saves more");
    const std::size_t first = from < 0 ? 0 : std::size_t(from), last = to < 0 ? frame_count - 1 : std::size_t(to);
    if (last >= frame_count || first >= last)
      throw UsageError("--from/--to must name two frames first < last among 0.." + std::to_string(frame_count - 1) + " of " + input.string());
    const std::size_t span = last - first, step = window == 0 ? span : window;
    if (step > span)
      throw UsageError("--window " + std::to_string(window) + " is longer than the " + std::to_string(span) +
                       " frame steps analysed; give a smaller window or more frames");
    std::optional<io::H5File> micro_file;
    if (!micro_path.empty()) {
      micro_file.emplace(io::open_kind(micro_path, schema::kind::micro, "pass the output of tracks2micro on the results file"));
      ctx.add_input_history(*micro_file);
    }
    if (chains_out) fs::create_directories(chains_out->temp_path());

    ForcesFile content;
    content.label = grains.label;
    content.chain_threshold = threshold;
    const std::size_t n = grains.label.size(), frames = span + 1;
    content.q.assign(n * frames, 0.0);
    std::vector<std::vector<Eigen::Vector3d>> centroids;
    std::vector<std::string> chain_files;
    std::vector<double> chain_times;
    const auto progress = ctx.progress_callback("frames");
    for (std::size_t k = 0; k < frames; ++k) {
      const std::size_t idx = first + k;
      const fdem::ResultsFrame fr = fdem::read_results_frame(input, idx);
      const FrameContacts fc = frame_contacts(fr, grains, input, idx);
      if (fc.pair.empty())
        throw DataError(input.string() + ": frame " + std::to_string(idx) +
                        " has no grain-grain contacts, so its force statistics are undefined; skip it with --from/--to");
      FrameForces ff = frame_forces(fc.normal, fc.normal_force, per_decade, theta_bins, phi_bins, threshold);
      ff.frame = idx, ff.time = fr.time, ff.platen_contacts = fc.platen_contacts;
      if (fr.stress.size() != 9 * n) throw DataError(input.string() + ": frame " + std::to_string(idx) + " does not hold one stress per grain; rerun fdemrun");
      const auto q = grain_q(fr.stress);
      for (std::size_t i = 0; i < n; ++i) content.q[i * frames + k] = q[i];
      centroids.push_back(frame_centroids(fr, grains, input, idx));
      spdlog::debug("frame {}: {} grain contacts, <f_n> {:.4g} N, {} strong", idx, ff.contacts, ff.distribution.mean, ff.strong);
      if (chains_out) {
        const auto chain = strong_contacts(fc.normal_force, ff.distribution.mean, threshold);
        chain_files.push_back(fmt::format("chains_{:06d}.vtp", idx));
        chain_times.push_back(fr.time);
        write_force_chain_vtp(chains_out->temp_path() / chain_files.back(), centroids.back(), grains.label, fc.pair,
                              fc.normal_force, ff.distribution.mean, chain);
      }
      content.frames.push_back(std::move(ff));
      if (progress) progress(double(k + 1) / double(frames));
    }

    DeformationOptions d;
    d.d50 = grains.psd.d50;
    d.radius = radius_d50 * d.d50;
    d.min_neighbours = min_neighbours;
    content.d2min_source = micro_file ? micro_path.string() : "centroids";
    for (std::size_t a = 0; a + step <= span; a += step) {
      VolatilityWindow w;
      w.from = first + a, w.to = first + a + step;
      for (std::size_t i = 0; i < n; ++i)
        w.volatility.push_back(volatility(std::vector<double>(content.q.begin() + std::ptrdiff_t(i * frames + a),
                                                              content.q.begin() + std::ptrdiff_t(i * frames + a + step + 1))));
      if (micro_file) {
        w.d2min = d2min_from_micro(*micro_file, grains, w.from, w.to);
      } else {
        for (const LocalDeformation& g : local_deformation(centroids[a], centroids[a + step], d)) w.d2min.push_back(g.d2min);
      }
      w.correlation = pearson(w.volatility, w.d2min);
      spdlog::info("window {} -> {}: Pearson r of volatility against D2min {:.3f} (p = {:.3g}) over {} grains", w.from, w.to,
                   w.correlation.r, w.correlation.p_value, w.correlation.count);
      if (w.correlation.count < 3)
        spdlog::warn("window {} -> {}: fewer than 3 grains have both a volatility and a D2min",
                     w.from, w.to);
      content.windows.push_back(std::move(w));
    }
    const FrameForces& end = content.frames.back();
    spdlog::info("{} grains, frames {}..{}; last frame: {} grain contacts, <f_n> {:.4g} N, {} strong (f_n >= {:g} <f_n>); "
                 "strong scale {:.3g}, weak theta {:.3g}",
                 n, first, last, end.contacts, end.distribution.mean, end.strong, threshold, end.distribution.strong.scale,
                 end.distribution.weak.theta);

    nlohmann::json p = {{"from", first},
                        {"to", last},
                        {"window", step},
                        {"chain_threshold", threshold},
                        {"d2min", content.d2min_source},
                        {"radius_d50", radius_d50},
                        {"min_neighbours", min_neighbours},
                        {"d50", grains.psd.d50},
                        {"pdf_bins_per_decade", per_decade},
                        {"rose_theta_bins", theta_bins},
                        {"rose_phi_bins", phi_bins}};
    content.parameters_json = p.dump();
    write_forces_file(out.temp_path(), content, ctx.history());
    if (chains_out) write_pvd(chains_out->temp_path() / "chains.pvd", chain_files, chain_times);
    io::commit_outputs({&out, chains_out ? &*chains_out : nullptr});
  });
}
