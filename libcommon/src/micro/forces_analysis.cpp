#include "graintwin/micro/forces_analysis.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/results_file.hpp"
#include "graintwin/micro/local_deformation.hpp"

namespace graintwin::micro {

ForcesOptions forces_frame_range(std::size_t frame_count, long long from, long long to, std::size_t window,
                                 const std::string& results) {
  if (frame_count == 0) throw DataError(results + " holds no frames; run fdemrun with a frame_interval that saves some");
  if (frame_count == 1)
    throw DataError(results + " holds a single frame, and the grains' volatility needs two frames or more; run fdemrun "
                    "with a frame_interval that saves more");
  ForcesOptions o;
  o.first = from < 0 ? 0 : std::size_t(from), o.last = to < 0 ? frame_count - 1 : std::size_t(to);
  if (o.last >= frame_count || o.first >= o.last)
    throw UsageError("--from/--to must name two frames first < last among 0.." + std::to_string(frame_count - 1) + " of " + results);
  const std::size_t span = o.last - o.first;
  o.window = window == 0 ? span : window;
  if (o.window > span)
    throw UsageError("--window " + std::to_string(window) + " is longer than the " + std::to_string(span) +
                     " frame steps analysed; give a smaller window or more frames");
  return o;
}

ForcesFile force_statistics(const std::filesystem::path& input, const SimulationGrains& grains, const ForcesOptions& o,
                            const MicroTables* micro, const std::string& micro_name, const std::filesystem::path& chains_dir,
                            ForceChainFiles* chains, const std::function<void(double)>& progress) {
  if (o.last <= o.first || o.window == 0 || o.window > o.last - o.first)
    throw UsageError("force_statistics: frames " + std::to_string(o.first) + ".." + std::to_string(o.last) + " with window " +
                     std::to_string(o.window) + " do not form a window; take them from forces_frame_range");
  ForcesFile content;
  content.label = grains.label;
  content.chain_threshold = o.chain_threshold;
  const std::size_t n = grains.label.size(), span = o.last - o.first, frames = span + 1, step = o.window;
  content.q.assign(n * frames, 0.0);
  std::vector<std::vector<Eigen::Vector3d>> centroids;
  for (std::size_t k = 0; k < frames; ++k) {
    const std::size_t idx = o.first + k;
    const fdem::ResultsFrame fr = fdem::read_results_frame(input, idx);
    const FrameContacts fc = frame_contacts(fr, grains, input, idx);
    if (fc.pair.empty())
      throw DataError(input.string() + ": frame " + std::to_string(idx) +
                      " has no grain-grain contacts, so its force statistics are undefined; skip it with --from/--to");
    FrameForces ff = frame_forces(fc.normal, fc.normal_force, o.per_decade, o.theta_bins, o.phi_bins, o.chain_threshold);
    ff.frame = idx, ff.time = fr.time, ff.platen_contacts = fc.platen_contacts;
    if (fr.stress.size() != 9 * n) throw DataError(input.string() + ": frame " + std::to_string(idx) + " does not hold one stress per grain; rerun fdemrun");
    const auto q = grain_q(fr.stress);
    for (std::size_t i = 0; i < n; ++i) content.q[i * frames + k] = q[i];
    centroids.push_back(frame_centroids(fr, grains, input, idx));
    if (!chains_dir.empty()) {
      const auto chain = strong_contacts(fc.normal_force, ff.distribution.mean, o.chain_threshold);
      const std::string name = fmt::format("chains_{:06d}.vtp", idx);
      if (chains) chains->files.push_back(name), chains->times.push_back(fr.time);
      write_force_chain_vtp(chains_dir / name, centroids.back(), grains.label, fc.pair, fc.normal_force, ff.distribution.mean, chain);
    }
    content.frames.push_back(std::move(ff));
    if (progress) progress(double(k + 1) / double(frames));
  }

  DeformationOptions d;
  d.d50 = grains.psd.d50;
  d.radius = o.radius_d50 * d.d50;
  d.min_neighbours = o.min_neighbours;
  content.d2min_source = micro ? micro_name : "centroids";
  for (std::size_t a = 0; a + step <= span; a += step) {
    VolatilityWindow w;
    w.from = o.first + a, w.to = o.first + a + step;
    for (std::size_t i = 0; i < n; ++i)
      w.volatility.push_back(volatility(std::vector<double>(content.q.begin() + std::ptrdiff_t(i * frames + a),
                                                            content.q.begin() + std::ptrdiff_t(i * frames + a + step + 1))));
    if (micro) {
      w.d2min = d2min_of_increment(*micro, micro_name, grains, w.from, w.to);
    } else {
      for (const LocalDeformation& g : local_deformation(centroids[a], centroids[a + step], d)) w.d2min.push_back(g.d2min);
    }
    w.correlation = pearson(w.volatility, w.d2min);
    content.windows.push_back(std::move(w));
  }

  const nlohmann::json p = {{"from", o.first},
                            {"to", o.last},
                            {"window", step},
                            {"chain_threshold", o.chain_threshold},
                            {"d2min", content.d2min_source},
                            {"radius_d50", o.radius_d50},
                            {"min_neighbours", o.min_neighbours},
                            {"d50", grains.psd.d50},
                            {"pdf_bins_per_decade", o.per_decade},
                            {"rose_theta_bins", o.theta_bins},
                            {"rose_phi_bins", o.phi_bins}};
  content.parameters_json = p.dump();
  return content;
}

}  // namespace graintwin::micro
