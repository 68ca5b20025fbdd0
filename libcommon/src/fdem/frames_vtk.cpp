#include "graintwin/fdem/frames_vtk.hpp"

#include <fmt/format.h>

#include <fstream>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/model_file.hpp"
#include "graintwin/io/vtk.hpp"

namespace graintwin::fdem {

VtkFrameWriter::VtkFrameWriter(std::filesystem::path folder) : folder_(std::move(folder)) {
  std::filesystem::create_directories(folder_);
  if (!std::filesystem::is_empty(folder_))
    throw UsageError("the VTK frame folder " + folder_.string() + " is not empty; name a new folder");
}

void VtkFrameWriter::add(const Solver& solver) {
  const Model& model = solver.model();
  const SolverState& state = solver.state();
  io::VtkUnstructuredGrid grid = model_grid(model, state.x);
  io::VtkArray displacement{"displacement", 3, {}}, velocity{"velocity", 3, {}}, stress{"stress", 9, {}};
  displacement.values.reserve(3 * model.nodes.size());
  velocity.values.reserve(3 * model.nodes.size());
  for (std::size_t i = 0; i < model.nodes.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      displacement.values.push_back(state.x[i][k] - model.nodes[i][k]);
      velocity.values.push_back(state.v[i][k]);
    }
  stress.values.reserve(9 * model.element_count());
  for (std::size_t e = 0; e < model.element_count(); ++e) {
    const Eigen::Matrix3d s = -solver.element_stress(e);  // compression positive (docs/conventions.md)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) stress.values.push_back(s(i, j));
  }
  grid.point_data.push_back(std::move(displacement));
  grid.point_data.push_back(std::move(velocity));
  grid.cell_data.push_back(std::move(stress));
  const std::string name = fmt::format("frame_{:06d}.vtu", frames_.size());
  io::write_vtu(folder_ / name, grid);
  frames_.emplace_back(state.time, name);
}

void VtkFrameWriter::finish() const {
  const auto path = folder_ / "frames.pvd";
  std::ofstream out(path);
  out << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
         "  <Collection>\n";
  for (const auto& [time, name] : frames_)
    out << fmt::format("    <DataSet timestep=\"{:.17g}\" group=\"\" part=\"0\" file=\"{}\"/>\n", time, name);
  out << "  </Collection>\n</VTKFile>\n";
  if (!out) throw DataError("cannot write " + path.string() + "; check the disk space and permissions");
}

}  // namespace graintwin::fdem
