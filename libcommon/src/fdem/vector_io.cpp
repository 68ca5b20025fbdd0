#include "graintwin/fdem/vector_io.hpp"

#include "graintwin/core/error.hpp"

namespace graintwin::fdem {

void write_vectors(io::H5File& file, const std::string& path, std::span<const Eigen::Vector3d> vectors) {
  std::vector<double> flat;
  flat.reserve(3 * vectors.size());
  for (const Eigen::Vector3d& v : vectors) flat.insert(flat.end(), {v[0], v[1], v[2]});
  io::DatasetOptions exact;
  exact.compress = false;
  file.write(path, flat.data(), {static_cast<hsize_t>(vectors.size()), 3}, exact);
}

std::vector<Eigen::Vector3d> read_vectors(const io::H5File& file, const std::string& path, std::size_t count) {
  std::vector<hsize_t> dims;
  const std::vector<double> flat = file.read<double>(path, &dims);
  if (dims != std::vector<hsize_t>{count, 3} && !(count == 0 && flat.empty()))
    throw DataError(file.path().string() + ": " + path + " does not hold " + std::to_string(count) +
                    " rows of 3 values; restart with the scene that wrote the checkpoint");
  std::vector<Eigen::Vector3d> out(count);
  for (std::size_t i = 0; i < count; ++i) out[i] = Eigen::Vector3d(flat[3 * i], flat[3 * i + 1], flat[3 * i + 2]);
  return out;
}

}  // namespace graintwin::fdem
