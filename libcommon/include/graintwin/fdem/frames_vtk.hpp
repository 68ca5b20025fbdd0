#pragma once
// fdemrun's frames for ParaView: one VTK unstructured grid (.vtu) per frame of the deformed meshes
// and a .pvd collection that orders them by time, so ParaView plays the run as an animation.
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "graintwin/fdem/solver.hpp"

namespace graintwin::fdem {

class VtkFrameWriter {
 public:
  /// Writes into `folder` (created; it must be new or empty).
  explicit VtkFrameWriter(std::filesystem::path folder);
  /// Writes frame_<k>.vtu of the solver's current state: the meshes at the current node positions,
  /// point data `displacement` (x - X, m) and `velocity` (last half step, m/s), cell data `grain`,
  /// `label` and `stress` (element volume-averaged Cauchy stress, compression positive as in
  /// kind=fdem_results, Pa, 9 components row-major).
  void add(const Solver& solver);
  /// Writes frames.pvd listing every frame with its time.
  void finish() const;
  std::size_t frames() const { return frames_.size(); }

 private:
  std::filesystem::path folder_;
  std::vector<std::pair<double, std::string>> frames_;  ///< time (s), file name
};

}  // namespace graintwin::fdem
