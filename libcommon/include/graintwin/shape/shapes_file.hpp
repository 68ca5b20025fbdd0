#pragma once
// `kind=shapes` files (docs/formats.md): per-grain properties, SH coefficients, invariants, fit
// quality and flags, and the scan's size distribution. Written by labels2shapes, read by
// shapes2tracks and shapes2mesh.
#include <filesystem>
#include <string>
#include <vector>

#include "graintwin/io/h5file.hpp"
#include "graintwin/shape/grain_measure.hpp"

namespace graintwin::shape {

struct ShapesFile {
  std::vector<GrainShape> grains;  ///< coefficient vectors all of degree `degree`
  int degree = 0;                  ///< SH degree of the stored coefficients (the fitter's)
  SizeDistribution psd;
  std::string parameters_json;     ///< what the run used (free-form JSON object)
};

void write_shapes_file(const std::filesystem::path& path, const ShapesFile& content,
                       const std::vector<std::string>& history);
/// UsageError naming the file if it is not a shapes file; DataError if its tables disagree.
ShapesFile read_shapes_file(const std::filesystem::path& path);
/// The number of grains an open kind=shapes file holds (the rows of its grain table), read from the
/// table's layout alone: what a tool sizes its workers by before it reads the grains.
std::size_t shapes_grain_count(const io::H5File& file);

}  // namespace graintwin::shape
