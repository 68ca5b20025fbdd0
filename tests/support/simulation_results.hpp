#pragma once
// kind=fdem_results files with exactly known content for the tools that read simulations
// (tracks2micro, fdem2forces): the real solver and ResultsWriter move rigid boxes on a cubic
// lattice with prescribed velocities (no contact, no gravity, so every grain moves exactly at its
// velocity), and a frame's contacts and stresses can be replaced by chosen ones afterwards.
#include <Eigen/Core>
#include <fmt/format.h>
#include <hdf5.h>

#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "graintwin/fdem/frames_vtk.hpp"
#include "graintwin/fdem/primitives.hpp"
#include "graintwin/fdem/results_file.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/schema.hpp"

namespace graintwin::test {

struct LatticeRun {
  int side = 4;              ///< side^3 grains
  double spacing = 1.5e-3;   ///< m between lattice sites
  double box = 1e-3;         ///< m, edge of each cubic grain
  Eigen::Matrix3d velocity_gradient = Eigen::Matrix3d::Zero();  ///< 1/s: grain at x moves at L x
  std::vector<std::pair<std::size_t, Eigen::Vector3d>> extra_velocity;  ///< (grain, m/s) on top
  std::size_t frames = 4;
  std::size_t steps_per_frame = 10;
  double dt = 1e-6;          ///< s
  std::filesystem::path vtk_frames;  ///< when set, also every frame as fdemrun --vtk writes it (frames.pvd)
};

inline std::uint32_t lattice_label(std::size_t grain) { return std::uint32_t(10 + grain); }

/// Site of grain i (x fastest), m.
inline Eigen::Vector3d lattice_site(const LatticeRun& run, std::size_t i) {
  const std::size_t s = std::size_t(run.side);
  return run.spacing * Eigen::Vector3d(double(i % s), double(i / s % s), double(i / (s * s)));
}

/// The lattice's model: rigid cubes of edge `box` centred on the sites, labelled lattice_label.
inline fdem::Model lattice_model(const LatticeRun& run) {
  fdem::Model model;
  const fdem::TetMesh mesh = fdem::box_mesh(Eigen::Vector3d::Constant(run.box), run.box);
  for (std::size_t i = 0; i < std::size_t(run.side * run.side * run.side); ++i)
    fdem::add_grain(model, mesh, lattice_site(run, i), fdem::GrainKind::rigid, 0, lattice_label(i));
  return model;
}

/// Writes `path`; frame k is taken after k x steps_per_frame steps. Grain volumes are box^3.
inline void write_lattice_results(const std::filesystem::path& path, const LatticeRun& run) {
  fdem::Model model = lattice_model(run);
  const std::size_t n = model.grains.size();
  fdem::SolverOptions options;
  options.contact.enabled = false;
  fdem::Solver solver(model, options);
  for (std::size_t i = 0; i < n; ++i) {
    Eigen::Vector3d v = run.velocity_gradient * lattice_site(run, i);
    for (const auto& [grain, extra] : run.extra_velocity)
      if (grain == i) v += extra;
    solver.set_grain_velocity(i, v, Eigen::Vector3d::Zero());
  }
  fdem::ResultsWriter writer(path, solver, "{}");
  std::optional<fdem::VtkFrameWriter> vtk;
  if (!run.vtk_frames.empty()) vtk.emplace(run.vtk_frames);
  writer.add_stage("move", 0.0);
  for (std::size_t k = 0; k < run.frames; ++k) {
    if (k > 0)
      for (std::size_t s = 0; s < run.steps_per_frame; ++s) writer.add_row(solver, solver.step(run.dt), 0, run.dt);
    writer.add_frame(solver);
    if (vtk) vtk->add(solver);
  }
  writer.finish({"lattice results (test)"});
  if (vtk) vtk->finish();
}

/// Replaces dataset `name` of `path` by `data` with `dims` (io::H5File opens files read-only; the
/// results file is rewritten in place here, the way a test fixture needs and no tool does).
template <class T>
void replace_dataset(const std::filesystem::path& path, const std::string& name, const std::vector<T>& data,
                     const std::vector<hsize_t>& dims) {
  hid_t type = H5T_NATIVE_DOUBLE;
  if constexpr (std::is_same_v<T, std::uint32_t>) type = H5T_NATIVE_UINT32;
  if constexpr (std::is_same_v<T, std::int32_t>) type = H5T_NATIVE_INT32;
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  if (file < 0) throw std::runtime_error("cannot open " + path.string() + " for writing");
  H5Ldelete(file, name.c_str(), H5P_DEFAULT);
  const hid_t space = H5Screate_simple(int(dims.size()), dims.data(), nullptr);
  const hid_t set = H5Dcreate2(file, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  const herr_t written = set < 0 ? -1 : H5Dwrite(set, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data.data());
  if (set >= 0) H5Dclose(set);
  H5Sclose(space);
  H5Fclose(file);
  if (written < 0) throw std::runtime_error("cannot write " + name + " in " + path.string());
}

/// A chosen contact of a frame: grain-grain when platen < 0, else grain `a` against that platen.
struct KnownContact {
  std::size_t a = 0, b = 0;
  int platen = -1;
  Eigen::Vector3d normal = Eigen::Vector3d::UnitX(), force = Eigen::Vector3d::Zero();
};

/// Replaces frame k's contact tables by `contacts` (grain indices as in lattice_label).
inline void set_frame_contacts(const std::filesystem::path& path, std::size_t k, const std::vector<KnownContact>& contacts) {
  namespace sr = schema::fdem_results;
  const std::string g = fmt::format("{}/{:06d}/", sr::frames, k);
  std::vector<std::uint32_t> pair;
  std::vector<std::int32_t> platen;
  std::vector<double> point, normal, force, overlap;
  for (const KnownContact& c : contacts) {
    pair.insert(pair.end(), {lattice_label(c.a), c.platen >= 0 ? 0u : lattice_label(c.b)});
    platen.push_back(c.platen);
    point.insert(point.end(), {0.0, 0.0, 0.0});
    normal.insert(normal.end(), {c.normal.x(), c.normal.y(), c.normal.z()});
    force.insert(force.end(), {c.force.x(), c.force.y(), c.force.z()});
    overlap.push_back(1e-7);
  }
  const hsize_t m = platen.size();
  replace_dataset(path, g + sr::contact_pair, pair, {m, 2});
  replace_dataset(path, g + sr::contact_platen, platen, {m});
  replace_dataset(path, g + sr::contact_point, point, {m, 3});
  replace_dataset(path, g + sr::contact_normal, normal, {m, 3});
  replace_dataset(path, g + sr::contact_force, force, {m, 3});
  replace_dataset(path, g + sr::contact_overlap, overlap, {m});
}

/// Replaces frame k's grain stresses (one tensor per grain, Pa, compression positive).
inline void set_frame_stress(const std::filesystem::path& path, std::size_t k, const std::vector<Eigen::Matrix3d>& stress) {
  std::vector<double> v;
  for (const Eigen::Matrix3d& s : stress)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) v.push_back(s(i, j));
  replace_dataset(path, fmt::format("{}/{:06d}/{}", schema::fdem_results::frames, k, schema::fdem_results::frame_stress), v,
                  {hsize_t(stress.size()), 3, 3});
}

}  // namespace graintwin::test
