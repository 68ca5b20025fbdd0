#pragma once
// Arrays of 3-vectors in checkpoints: an (n, 3) float64 dataset, uncompressed (a restart must read
// back the exact bits).
#include <Eigen/Core>
#include <span>
#include <string>
#include <vector>

#include "graintwin/io/h5file.hpp"

namespace graintwin::fdem {

void write_vectors(io::H5File& file, const std::string& path, std::span<const Eigen::Vector3d> vectors);
/// Reads what write_vectors wrote; DataError naming the file and dataset unless it holds `count`
/// rows of 3 (a checkpoint of another model or scene).
std::vector<Eigen::Vector3d> read_vectors(const io::H5File& file, const std::string& path, std::size_t count);

}  // namespace graintwin::fdem
