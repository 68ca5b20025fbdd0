#include "graintwin/report/paraview_state.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/results_file.hpp"
#include "graintwin/io/vtk.hpp"
#include "graintwin/micro/forces_file.hpp"
#include "graintwin/report/page.hpp"
#include "graintwin/report/sections.hpp"
#include "graintwin/report/surfaces_3d.hpp"

namespace graintwin::report {

namespace {

/// One property of `values` (numbers or strings, already formatted) of proxy `id`.
std::string property(int id, const std::string& name, const std::vector<std::string>& values) {
  std::string out = fmt::format("      <Property name=\"{}\" id=\"{}.{}\" number_of_elements=\"{}\">\n", name, id, name, values.size());
  for (std::size_t i = 0; i < values.size(); ++i) out += fmt::format("        <Element index=\"{}\" value=\"{}\"/>\n", i, html_escape(values[i]));
  return out + "      </Property>\n";
}

/// A property holding other proxies (by id; with the output port for a pipeline input).
std::string proxy_property(int id, const std::string& name, const std::vector<int>& proxies, bool output_port = false) {
  std::string out = fmt::format("      <Property name=\"{}\" id=\"{}.{}\" number_of_elements=\"{}\">\n", name, id, name, proxies.size());
  for (int p : proxies) out += fmt::format("        <Proxy value=\"{}\"{}/>\n", p, output_port ? " output_port=\"0\"" : "");
  return out + "      </Property>\n";
}

std::string number(double v) { return fmt::format("{:.9g}", v); }

std::vector<std::string> numbers(std::initializer_list<double> values) {
  std::vector<std::string> out;
  for (double v : values) out.push_back(number(v));
  return out;
}

/// Matplotlib's viridis at five points, as ParaView's RGBPoints (x, r, g, b) over [lo, hi].
std::vector<std::string> viridis(double lo, double hi) {
  constexpr double stops[5][3] = {{0.267, 0.005, 0.329}, {0.229, 0.322, 0.546}, {0.128, 0.567, 0.551}, {0.369, 0.789, 0.383}, {0.993, 0.906, 0.144}};
  std::vector<std::string> out;
  for (int i = 0; i < 5; ++i)
    for (double v : {lo + (hi - lo) * i / 4.0, stops[i][0], stops[i][1], stops[i][2]}) out.push_back(number(v));
  return out;
}

std::string proxy(const std::string& group, const std::string& type, int id, int servers, const std::string& properties) {
  return fmt::format("    <Proxy group=\"{}\" type=\"{}\" id=\"{}\" servers=\"{}\">\n{}    </Proxy>\n", group, type, id, servers, properties);
}

std::string collection(const std::string& name, const std::vector<std::pair<int, std::string>>& items) {
  std::string out = fmt::format("    <ProxyCollection name=\"{}\">\n", name);
  for (const auto& [id, item] : items) out += fmt::format("      <Item id=\"{}\" name=\"{}\"/>\n", id, html_escape(item));
  return out + "    </ProxyCollection>\n";
}

}  // namespace

std::string paraview_state_xml(const std::vector<StateSource>& sources, const std::array<double, 6>& bounds) {
  // Ids: readers 100 + i, representations 200 + i, lookup tables 300 + i, views 400 and 401, time
  // keeper 500, animation scene 501, layout 502.
  constexpr int kViews[2] = {400, 401};
  std::string body;
  std::vector<std::pair<int, std::string>> readers, representations, tables;
  std::vector<int> shown[2], time_sources;
  for (std::size_t i = 0; i < sources.size(); ++i) {
    const StateSource& s = sources[i];
    const int reader = 100 + int(i), rep = 200 + int(i), table = 300 + int(i);
    body += proxy("sources", s.reader, reader, 1, property(reader, "FileName", {s.file}));
    readers.emplace_back(reader, s.name);
    if (s.reader == "PVDReader") time_sources.push_back(reader);
    std::string p = proxy_property(rep, "Input", {reader}, true) + property(rep, "Visibility", {s.visible ? "1" : "0"}) +
                    property(rep, "Representation", {s.representation}) +
                    property(rep, "DiffuseColor", numbers({s.colour[0], s.colour[1], s.colour[2]})) +
                    property(rep, "AmbientColor", numbers({s.colour[0], s.colour[1], s.colour[2]})) +
                    property(rep, "Opacity", {number(s.opacity)}) + property(rep, "PointSize", {number(s.point_size)}) +
                    property(rep, "LineWidth", {number(s.line_width)});
    if (s.gaussian_radius > 0.0)  // ShaderPreset 1: each point a shaded sphere of the radius
      p += property(rep, "GaussianRadius", {number(s.gaussian_radius)}) + property(rep, "ShaderPreset", {"1"});
    if (!s.colour_by.empty()) {
      body += proxy("lookup_tables", "PVLookupTable", table, 21,
                    property(table, "RGBPoints", viridis(s.colour_range[0], s.colour_range[1])) + property(table, "ColorSpace", {"Lab"}) +
                        property(table, "AutomaticRescaleRangeMode", {"-1"}));  // -1: keep this range, the same for every frame
      tables.emplace_back(table, s.colour_by + ".PVLookupTable");
      p += property(rep, "ColorArrayName", {"", "", "", "1", s.colour_by}) + proxy_property(rep, "LookupTable", {table});
    }
    body += proxy("representations", "GeometryRepresentation", rep, 21, p);
    representations.emplace_back(rep, s.name + " (shown)");
    shown[std::clamp(s.view, 0, 1)].push_back(rep);
  }
  // Both cameras along +y from 20 degrees above the box's centre, far enough for the whole box.
  const double cx = 0.5 * (bounds[0] + bounds[1]), cy = 0.5 * (bounds[2] + bounds[3]), cz = 0.5 * (bounds[4] + bounds[5]);
  const double span = std::max({bounds[1] - bounds[0], bounds[3] - bounds[2], bounds[5] - bounds[4]});
  const double up = 20.0 * std::numbers::pi / 180.0, distance = 3.0 * span;
  for (int v = 0; v < 2; ++v) {
    const int id = kViews[v];
    body += proxy("views", "RenderView", id, 21,
                  proxy_property(id, "Representations", shown[v]) + property(id, "CameraFocalPoint", numbers({cx, cy, cz})) +
                      property(id, "CameraPosition", numbers({cx, cy - distance * std::cos(up), cz + distance * std::sin(up)})) +
                      property(id, "CameraViewUp", numbers({0.0, 0.0, 1.0})) + property(id, "CenterOfRotation", numbers({cx, cy, cz})) +
                      property(id, "Background", numbers({1.0, 1.0, 1.0})) + property(id, "UseColorPaletteForBackground", {"0"}) +
                      property(id, "OrientationAxesVisibility", {"1"}));
  }
  body += proxy("misc", "TimeKeeper", 500, 16, proxy_property(500, "TimeSources", time_sources) + proxy_property(500, "Views", {kViews[0], kViews[1]}));
  // PlayMode 2: snap to the time steps, so the animation shows the saved frames and nothing between.
  body += proxy("animation", "AnimationScene", 501, 16,
                proxy_property(501, "TimeKeeper", {500}) + property(501, "PlayMode", {"2"}) + proxy_property(501, "ViewModules", {kViews[0], kViews[1]}));
  body += fmt::format(
      "    <Proxy group=\"misc\" type=\"ViewLayout\" id=\"502\" servers=\"20\">\n      <Layout number_of_elements=\"3\">\n"
      "        <Item direction=\"2\" fraction=\"0.5\" view=\"0\"/>\n        <Item direction=\"0\" fraction=\"0.5\" view=\"{}\"/>\n"
      "        <Item direction=\"0\" fraction=\"0.5\" view=\"{}\"/>\n      </Layout>\n    </Proxy>\n",
      kViews[0], kViews[1]);
  body += collection("sources", readers) + collection("representations", representations) + collection("lookup_tables", tables) +
          collection("views", {{kViews[0], "the scans"}, {kViews[1], "the twin"}}) + collection("timekeeper", {{500, "TimeKeeper"}}) +
          collection("animation", {{501, "AnimationScene1"}}) + collection("layouts", {{502, "the run"}});
  return "<ParaView>\n  <ServerManagerState version=\"5.11.0\">\n" + body + "  </ServerManagerState>\n</ParaView>\n";
}

bool write_membrane_frames(const fs::path& simulation, const fs::path& folder) {
  std::vector<std::string> files;
  std::vector<double> times;
  const std::size_t frames = fdem::results_frame_count(simulation);
  for (std::size_t k = 0; k < frames; ++k) {
    const fdem::ResultsFrame f = fdem::read_results_frame(simulation, k);
    if (f.membrane_position.empty()) continue;
    io::VtkPolyData d;
    d.points = f.membrane_position;
    d.add_vertices(0, d.point_count());
    if (files.empty()) fs::create_directories(folder);
    files.push_back(fmt::format("membrane_{}.vtp", k));
    times.push_back(f.time);
    io::write_vtp(folder / files.back(), d);
  }
  if (files.empty()) return false;
  micro::write_pvd(folder / "membrane.pvd", files, times);
  return true;
}

std::vector<StateSource> run_state_sources(const fs::path& run_dir, const RunFiles& files, const fs::path& state_folder,
                                           const std::string& membrane_pvd, double ball_radius) {
  const auto relative = [&](const fs::path& p) { return fs::absolute(p).lexically_normal().lexically_relative(fs::absolute(state_folder).lexically_normal()).generic_string(); };
  const auto present = [&](const fs::path& p) { return fs::is_regular_file(run_dir / p); };
  const auto source = [](std::string name, std::string file, std::string reader) {
    StateSource s;
    s.name = std::move(name), s.file = std::move(file), s.reader = std::move(reader);
    return s;
  };
  std::vector<StateSource> sources;
  for (std::size_t t = 0; t < files.scan_names.size(); ++t) {
    const fs::path grains = fs::path(files.scan_names[t]) / paraview_layout::grains;
    if (!present(grains)) continue;
    StateSource s = source(files.scan_names[t] + " grains", relative(run_dir / grains), "XMLPolyDataReader");
    s.view = 0, s.colour = {0.85, 0.72, 0.5};  // sand
    s.visible = sources.empty();                // the scans overlap: the first one shown
    sources.push_back(s);
  }
  if (present(paraview_layout::tracks)) {
    StateSource s = source("grain tracks", relative(run_dir / paraview_layout::tracks), "XMLPolyDataReader");
    s.view = 0, s.colour = {0.7, 0.1, 0.1}, s.point_size = 4.0, s.line_width = 2.0;
    sources.push_back(s);
  }
  if (present(paraview_layout::frames)) {
    StateSource s = source("twin frames", relative(run_dir / paraview_layout::frames), "PVDReader");
    s.view = 1, s.colour = {0.8, 0.68, 0.48};
    sources.push_back(s);
  }
  if (!membrane_pvd.empty()) {
    StateSource s = source("membrane balls", membrane_pvd, "PVDReader");
    s.view = 1, s.colour = {0.6, 0.75, 0.95}, s.opacity = 0.35;
    s.representation = ball_radius > 0.0 ? "Point Gaussian" : "Points", s.gaussian_radius = ball_radius, s.point_size = 3.0;
    sources.push_back(s);
  }
  if (present(paraview_layout::chains)) {
    // fdem2forces' strong chains carry f_n / <f_n> from 1 up; a few times the mean is the strongest.
    StateSource s = source("force chains", relative(run_dir / paraview_layout::chains), "PVDReader");
    s.view = 1, s.line_width = 3.0, s.colour_by = "normalised_force", s.colour_range = {1.0, 4.0};
    sources.push_back(s);
  }
  return sources;
}

std::vector<StateSource> write_paraview_state(const fs::path& run_dir, const RunFiles& files, const fs::path& state,
                                              const fs::path& final_state, const fs::path& membrane, const fs::path& final_membrane) {
  const fs::path folder = final_state.parent_path().empty() ? fs::path(".") : final_state.parent_path();
  std::string membrane_pvd;
  double ball_radius = 0.0;
  if (!files.simulation.empty() && write_membrane_frames(files.simulation, membrane)) {
    membrane_pvd = (fs::absolute(final_membrane).lexically_normal() / "membrane.pvd").lexically_relative(fs::absolute(folder).lexically_normal()).generic_string();
    ball_radius = membrane_ball_radius(files.simulation);
  }
  const std::vector<StateSource> sources = run_state_sources(run_dir, files, folder, membrane_pvd, ball_radius);
  std::ofstream out(state);
  out << paraview_state_xml(sources, scan_planes(files.labels.front()).extent);
  if (!out) throw DataError("cannot write " + state.string() + "; check the disk and the folder's permissions");
  return sources;
}

}  // namespace graintwin::report
