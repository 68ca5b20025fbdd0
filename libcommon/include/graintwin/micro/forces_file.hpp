#pragma once
// `kind=forces` files (docs/formats.md), written by fdem2forces: per frame the PDF of f_n / <f_n>
// with its strong and weak fits and the rose of mean normal force; per grain and frame the grain
// stress q; per strain window each grain's volatility of q and D2min with their correlation. Also
// the strong force network of a frame as VTK lines (force chains) and a ParaView .pvd index.
#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "graintwin/micro/distributions.hpp"
#include "graintwin/micro/forces.hpp"

namespace graintwin::io {
class H5File;
}

namespace graintwin::micro {

/// The force statistics of one frame (grain-grain contacts only).
struct FrameForces {
  std::size_t frame = 0;          ///< index of the frame in the results file
  double time = 0.0;              ///< s
  std::size_t contacts = 0;       ///< grain-grain contacts
  std::size_t platen_contacts = 0;
  std::size_t strong = 0;         ///< contacts with f_n >= chain threshold x <f_n>
  ForceDistribution distribution;
  ForceRose rose;
};

/// Indices of the contacts whose normal force is at least `threshold` x `mean` (the strong
/// network of Radjai et al. 1998 for threshold 1).
std::vector<std::size_t> strong_contacts(const std::vector<double>& normal_forces, double mean, double threshold);

/// The statistics of one frame from its grain-grain contact normals and normal forces (N):
/// force PDF in log bins (`per_decade`) with strong and weak fits, the rose of mean normal force
/// (`theta_bins` x `phi_bins`) and the number of contacts in the strong network at `threshold`.
/// frame, time and platen_contacts are left for the caller.
FrameForces frame_forces(const std::vector<Eigen::Vector3d>& normals, const std::vector<double>& normal_forces,
                         double per_decade, int theta_bins, int phi_bins, double threshold);

/// q (Pa) of each grain from a frame's stress table (G x 3 x 3, row-major).
std::vector<double> grain_q(const std::vector<double>& stress);

/// One strain window: frames `from` .. `to`; per grain the volatility of q over it and D2min / d50^2
/// between its ends, and Pearson's r of the two over the grains where both are defined.
struct VolatilityWindow {
  std::size_t from = 0, to = 0;
  std::vector<double> volatility;  ///< G, NaN where q is not positive in every frame (rigid grains)
  std::vector<double> d2min;       ///< G, D2min / d50^2, NaN where undefined
  Correlation correlation;
};

/// The q definition stored beside /grains/q.
inline constexpr const char* kQDefinition =
    "q = sqrt(1/2 s_ij s_ij), s the deviatoric part of the volume-averaged grain stress (the CT-FDEM paper's "
    "definition, sqrt(J2), not von Mises' sqrt(3 J2)); rigid grains: of the Love-Weber average of their contact forces";

struct ForcesFile {
  std::vector<std::uint32_t> label;   ///< G, simulation grain labels
  std::vector<FrameForces> frames;    ///< F
  std::vector<double> q;              ///< G x F, Pa
  std::vector<VolatilityWindow> windows;
  double chain_threshold = 1.0;       ///< in units of <f_n>
  std::string d2min_source;           ///< "centroids" or the kind=micro file it came from
  std::string parameters_json;        ///< what the run used (JSON object)
};

void write_forces_file(const std::filesystem::path& path, const ForcesFile& content, const std::vector<std::string>& history);

/// Force chains of one frame as VTK lines: a segment between the centroids of the two grains of
/// every contact in `chain` (indices into `pairs`), cell data `normal_force` (N) and
/// `normalised_force` (f_n / mean); point data `label`. Only grains in a chain become points.
void write_force_chain_vtp(const std::filesystem::path& path, const std::vector<Eigen::Vector3d>& centroids,
                           const std::vector<std::uint32_t>& labels, const std::vector<std::pair<std::size_t, std::size_t>>& pairs,
                           const std::vector<double>& normal_forces, double mean, const std::vector<std::size_t>& chain);

/// The tables of one frame of a kind=forces file.
struct ForcesFrameTables {
  std::size_t index = 0;  ///< frame of the results file
  double time = 0.0;      ///< s
  std::size_t contacts = 0;
  double strong_scale = 0.0, weak_theta = 0.0;
  Histogram pdf;   ///< of f_n / <f_n>
  ForceRose rose;  ///< counts and mean normal force (N)
};
/// The tables of one strain window of a kind=forces file.
struct ForcesWindowTables {
  std::size_t from = 0, to = 0;
  double pearson_r = 0.0, p_value = 0.0;
  std::size_t count = 0;
  std::vector<double> volatility, d2min;  ///< per grain
};
/// The per-frame and per-window tables of a kind=forces file.
struct ForcesTables {
  std::vector<ForcesFrameTables> frames;
  std::vector<ForcesWindowTables> windows;
};

/// The checks read_forces_tables makes on the tables of an open kind=forces file (io/table_checks):
/// /frames, /grains and /windows columns agree in length and hold no infinity.
void check_forces_tables(const io::H5File& file);

/// Reads the frame and window tables of a kind=forces file. UsageError when it is not one;
/// DataError naming the file when its tables disagree in size or hold values fdem2forces never writes.
ForcesTables read_forces_tables(const std::filesystem::path& path);

/// A ParaView collection (.pvd) listing `files` (relative to the .pvd's folder) at `times` (s).
void write_pvd(const std::filesystem::path& path, const std::vector<std::string>& files, const std::vector<double>& times);

}  // namespace graintwin::micro
