// Fuzz target: fdemrun's checkpoints (fdem/results_file.cpp read_checkpoint, Solver::load),
// structure-aware (h5_mutator.hpp). The valid checkpoint is made here: two boxes (tet4 and rigid)
// dropped onto a platen for a few steps, so that the contact history holds records.
#include "fuzz_support.hpp"
#include "graintwin/fdem/primitives.hpp"
#include "graintwin/fdem/results_file.hpp"
#include "graintwin/fdem/solver.hpp"
#include "h5_mutator.hpp"

namespace {
using namespace graintwin::fdem;

const char* kDigest = "fuzz scene";

Model two_boxes() {
  Model m;
  m.materials.push_back(Material{});
  const TetMesh mesh = box_mesh(Eigen::Vector3d::Constant(1e-3), 0.5e-3);
  add_grain(m, mesh, {0, 0, 0.499e-3}, GrainKind::tet4, 0, 1);
  add_grain(m, mesh, {0.2e-3, 0, 1.498e-3}, GrainKind::rigid, 0, 2);
  m.platens.push_back({"bottom", {0, 0, 0}, {0, 0, 1}, 0.5});
  return m;
}

SolverOptions options() {
  SolverOptions o;
  o.gravity = {0, 0, -9.81};
  o.contact.enabled = true;
  return o;
}

const std::filesystem::path& base_checkpoint() {
  static const std::filesystem::path path = [] {
    const Model m = two_boxes();
    Solver solver(m, options());
    solver.set_grain_velocity(1, {0, 0, -0.5}, {0, 100, 0});
    const double dt = 0.5 * solver.time_step_limits().stable();
    for (int s = 0; s < 20; ++s) solver.step(dt);
    const auto p = graintwin::fuzz::scratch_dir() / "checkpoint.h5";
    write_checkpoint(p, solver, kDigest);
    return p;
  }();
  return path;
}
}  // namespace

GRAINTWIN_FUZZ_TARGET(checkpoint) {
  graintwin::fuzz::fuzz_h5_reader("read_checkpoint", base_checkpoint(), data, size, [](const std::filesystem::path& p) {
    static const Model model = two_boxes();
    Solver solver(model, options());
    read_checkpoint(p, solver, kDigest);
  });
}
