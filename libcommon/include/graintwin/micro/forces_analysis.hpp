#pragma once
// The force statistics of a simulation (fdem2forces' stage, docs/methods.md, micro-mechanics): per
// saved frame of a kind=fdem_results file the force PDF, rose and strong network of the
// grain-grain contacts and every grain's q; per strain window the volatility of q against D2min.
// The result is the content of a kind=forces file (forces_file.hpp).
#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "graintwin/micro/forces_file.hpp"
#include "graintwin/micro/micro_file.hpp"
#include "graintwin/micro/simulation.hpp"

namespace graintwin::micro {

struct ForcesOptions {
  std::size_t first = 0, last = 0;  ///< frames analysed, first < last (frame indices of the results file)
  std::size_t window = 0;           ///< frames per strain window: windows first, first + W, ...; 0 = one over all
  double chain_threshold = 1.0;     ///< strong network: f_n >= this x <f_n>
  double per_decade = 5.0;          ///< log bins per decade of the force PDF
  int theta_bins = 9, phi_bins = 36;  ///< rose bins: polar angle over [0, 90] deg, azimuth over [0, 360] deg
  double radius_d50 = 1.5;          ///< D2min neighbourhood radius in d50 (D2min from the centroids)
  std::size_t min_neighbours = 3;   ///< fewest neighbours for D2min (from the centroids)
};

/// The first and last frame and the window length of `frame_count` saved frames of `results` for
/// --from / --to (negative: not given) and --window. UsageError naming the option and its range
/// (DataError when the file holds fewer than two frames).
ForcesOptions forces_frame_range(std::size_t frame_count, long long from, long long to, std::size_t window,
                                 const std::string& results);

/// Force chains written beside the statistics: a chains_<frame>.vtp file per frame and its time.
struct ForceChainFiles {
  std::vector<std::string> files;  ///< names inside the chains folder
  std::vector<double> times;       ///< s
};

/// The kind=forces content of frames options.first .. options.last of `results` (its grains
/// `grains`). D2min of each window comes from `micro` (a kind=micro file of the same results,
/// named `micro_name` in messages and in the file) when given, else from the frames' centroids
/// (Falk-Langer over options.radius_d50 x d50). With a non-empty `chains_dir` (an existing folder)
/// the strong network of each frame is written there as VTK lines and listed in `chains`.
/// DataError naming the frame when it has no grain-grain contacts or not one stress per grain.
ForcesFile force_statistics(const std::filesystem::path& results, const SimulationGrains& grains, const ForcesOptions& options,
                            const MicroTables* micro, const std::string& micro_name, const std::filesystem::path& chains_dir,
                            ForceChainFiles* chains, const std::function<void(double)>& progress = {});

}  // namespace graintwin::micro
