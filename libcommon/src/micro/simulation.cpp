#include "graintwin/micro/simulation.hpp"

#include <cmath>
#include <numbers>
#include <string>

#include "graintwin/core/error.hpp"
#include "graintwin/core/geometry.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"

namespace graintwin::micro {
namespace sr = schema::fdem_results;

SimulationGrains read_simulation_grains(const std::filesystem::path& path) {
  const io::H5File f = io::open_kind(path, schema::kind::fdem_results, "pass the output of fdemrun");
  SimulationGrains g;
  if (!f.exists(sr::grain_label) || !f.exists(sr::grain_volume))
    throw DataError(path.string() + " has no grain table (/grains/label, /grains/volume); rerun fdemrun");
  g.label = f.read<std::uint32_t>(sr::grain_label);
  g.volume = f.read<double>(sr::grain_volume);
  if (g.label.empty()) throw DataError(path.string() + " holds no grains; rerun fdemrun on a scene with grains");
  if (g.volume.size() != g.label.size())
    throw DataError(path.string() + ": /grains/label and /grains/volume differ in length; rerun fdemrun");
  std::vector<double> diameter;
  for (std::size_t i = 0; i < g.label.size(); ++i) {
    if (!(g.volume[i] > 0.0))
      throw DataError(path.string() + ": grain " + std::to_string(g.label[i]) + " has no positive volume; rerun fdemrun");
    if (!g.row.emplace(g.label[i], i).second)
      throw DataError(path.string() + ": label " + std::to_string(g.label[i]) + " names two grains; rerun fdemrun");
    diameter.push_back(equivalent_diameter(g.volume[i]));
  }
  g.psd = shape::size_distribution(diameter, g.volume);
  return g;
}

namespace {
[[noreturn]] void frame_error(const std::filesystem::path& path, std::size_t k, const std::string& what) {
  throw DataError(path.string() + ": frame " + std::to_string(k) + " " + what + "; rerun fdemrun");
}
}  // namespace

FrameContacts frame_contacts(const fdem::ResultsFrame& fr, const SimulationGrains& grains, const std::filesystem::path& path,
                             std::size_t k) {
  const std::size_t m = fr.platen.size();
  if (fr.pair.size() != 2 * m || fr.normal.size() != 3 * m || fr.force.size() != 3 * m)
    frame_error(path, k, "has contact tables of different lengths");
  FrameContacts c;
  for (std::size_t i = 0; i < m; ++i) {
    if (fr.platen[i] >= 0) {
      ++c.platen_contacts;
      continue;
    }
    const auto a = grains.row.find(fr.pair[2 * i]), b = grains.row.find(fr.pair[2 * i + 1]);
    if (a == grains.row.end() || b == grains.row.end())
      frame_error(path, k, "has a contact naming a label that is not in /grains/label");
    const Eigen::Vector3d n(fr.normal[3 * i], fr.normal[3 * i + 1], fr.normal[3 * i + 2]);
    const Eigen::Vector3d f(fr.force[3 * i], fr.force[3 * i + 1], fr.force[3 * i + 2]);
    c.pair.emplace_back(a->second, b->second);
    c.normal.push_back(n);
    c.normal_force.push_back(f.dot(n));
  }
  return c;
}

std::vector<Eigen::Vector3d> frame_centroids(const fdem::ResultsFrame& fr, const SimulationGrains& grains,
                                             const std::filesystem::path& path, std::size_t k) {
  const std::size_t n = grains.label.size();
  if (fr.centroid.size() != 3 * n) frame_error(path, k, "does not hold one centroid per grain");
  std::vector<Eigen::Vector3d> p(n);
  for (std::size_t i = 0; i < n; ++i) p[i] = Eigen::Vector3d(fr.centroid[3 * i], fr.centroid[3 * i + 1], fr.centroid[3 * i + 2]);
  return p;
}

SeriesStates simulation_states(const std::filesystem::path& path, const SimulationGrains& grains, std::vector<double>* times) {
  const std::size_t frames = fdem::results_frame_count(path);
  if (frames == 0) throw DataError(path.string() + " holds no frames; run fdemrun with a frame_interval that saves some");
  SeriesStates s;
  s.grains = grains.label.size(), s.states = frames;
  s.position.resize(s.grains * frames);
  s.volume.resize(s.grains * frames);
  s.d50.assign(frames, grains.psd.d50);
  s.psd.assign(frames, grains.psd);
  s.coordination.resize(frames);
  if (times) times->clear();
  for (std::size_t t = 0; t < frames; ++t) {
    const fdem::ResultsFrame fr = fdem::read_results_frame(path, t);
    const auto p = frame_centroids(fr, grains, path, t);
    for (std::size_t i = 0; i < s.grains; ++i) s.position[i * frames + t] = p[i], s.volume[i * frames + t] = grains.volume[i];
    s.coordination[t] = coordination_from_pairs(s.grains, frame_contacts(fr, grains, path, t).pair);
    if (times) times->push_back(fr.time);
  }
  return s;
}

std::vector<contacts::Rose> simulation_branch_roses(const std::filesystem::path& path, const std::vector<std::size_t>& frames,
                                                    int theta_bins, int phi_bins) {
  const SimulationGrains grains = read_simulation_grains(path);
  std::vector<contacts::Rose> roses;
  for (std::size_t k : frames) {
    const fdem::ResultsFrame frame = fdem::read_results_frame(path, k);
    const FrameContacts fc = frame_contacts(frame, grains, path, k);
    const std::vector<Eigen::Vector3d> centroid = frame_centroids(frame, grains, path, k);
    std::vector<Vec3> branch;
    for (const auto& [a, b] : fc.pair) {
      const Eigen::Vector3d d = centroid[b] - centroid[a];
      branch.push_back({d.x(), d.y(), d.z()});
    }
    roses.push_back(contacts::rose(branch, theta_bins, phi_bins));
  }
  return roses;
}

}  // namespace graintwin::micro
