#include "graintwin/track/series.hpp"

#include <nlohmann/json.hpp>

#include "graintwin/core/error.hpp"

namespace graintwin::track {

std::string tracks_parameters_json(const ChainOptions& co, const RotationOptions& ro) {
  nlohmann::json p = {{"method", method_name(co.match.method)},
                      {"window_d50", co.match.window_d50},
                      {"volume_tol", volume_filter(co.match)},
                      {"max_gap", co.max_gap},
                      {"backward_check", co.match.backward_check},
                      {"rotation", rotation_method_name(ro.method)},
                      {"rotation_margin", ro.min_margin},
                      {"rotation_degree", ro.degree},
                      {"symmetry_tol", ro.symmetry_tol}};
  if (co.match.method == Method::improved) {
    p["passes"] = co.match.passes;
    p["local_radius_d50"] = co.match.local_radius_d50;
    p["window_sigmas"] = co.match.window_sigmas;
    p["min_window_d50"] = co.match.min_window_d50;
    p["lost_cost"] = co.match.lost_cost;
  }
  return p.dump();
}

TracksFile track_series(const std::vector<std::filesystem::path>& paths, const ChainOptions& chain,
                        const RotationOptions& rotation,
                        const std::function<std::function<void(double)>(const std::string&)>& progress) {
  const auto step = [&](const char* name) { return progress ? progress(name) : std::function<void(double)>(); };
  std::vector<shape::ShapesFile> shapes;
  std::vector<ScanGrains> scans;
  TracksFile content;
  std::function<void(double)> reading = step("reading");
  for (const std::filesystem::path& p : paths) {
    try {
      shapes.push_back(shape::read_shapes_file(p));
      scans.push_back(scan_grains(shapes.back()));
    } catch (Error& e) {
      e.add_context("while reading " + p.string());
      throw;
    }
    if (scans.back().size() == 0) throw DataError(p.string() + " holds no grain; check the segmentation of that scan");
    content.scans.push_back(p.string());
    content.d50.push_back(scans.back().d50);
    content.scan_labels.push_back(scans.back().label);
    if (reading) reading(static_cast<double>(shapes.size()) / static_cast<double>(paths.size()));
  }
  reading = nullptr;
  content.tracks = chain_tracks(scans, chain, step("matching"));
  std::vector<const shape::ShapesFile*> ptrs;
  for (const auto& s : shapes) ptrs.push_back(&s);
  content.kinematics = track_kinematics(content.tracks, ptrs, rotation, step("rotations"));
  content.parameters_json = tracks_parameters_json(chain, rotation);
  return content;
}

}  // namespace graintwin::track
