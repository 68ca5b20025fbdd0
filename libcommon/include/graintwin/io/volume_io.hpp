#pragma once
// Reading and writing `kind=volume` files (and image datasets of other kinds), with the kind and
// schema checks every reader does.
#include <filesystem>
#include <string>
#include <vector>

#include "graintwin/core/volume.hpp"
#include "graintwin/io/h5file.hpp"

namespace graintwin::io {

/// Writes the root attributes `kind`, `schema_version` and `creator`.
void write_root_attrs(H5File& file, const std::string& kind);
/// The root `kind` attribute, or "" when the file has none.
std::string file_kind(const H5File& file);
/// Opens `path` and checks that it is a GrainTwin file of `kind` whose schema this build reads.
/// On mismatch throws UsageError in one sentence: what was found, what was expected, and `hint`
/// (e.g. "pass the output of ct2labels").
H5File open_kind(const std::filesystem::path& path, const std::string& kind,
                 const std::string& hint = "");

/// Geometry and type of an image dataset, read from its attributes.
struct ImageHeader {
  Shape3 shape{0, 0, 0};
  DType dtype = DType::uint8;
  Vec3 voxel_size{1.0, 1.0, 1.0};
  Vec3 origin{0.0, 0.0, 0.0};
  std::string units;
};

/// Writes an image dataset (chunked, shuffled, gzip) with units, axis_order, voxel_size, origin.
template <class T>
void write_image(H5File& file, const std::string& path, const Volume<T>& v,
                 const std::string& units);
void write_image(H5File& file, const std::string& path, const AnyVolume& v,
                 const std::string& units);

ImageHeader read_image_header(const H5File& file, const std::string& path);
/// Reads an image dataset in its stored type.
AnyVolume read_image(const H5File& file, const std::string& path);
/// Reads an image dataset converted to T (values are converted by HDF5, no rescaling).
template <class T>
Volume<T> read_image_as(const H5File& file, const std::string& path);

/// Writes a complete `kind=volume` file: root attributes, /volume, provenance history.
void write_volume_file(const std::filesystem::path& path, const AnyVolume& v,
                       const std::vector<std::string>& history, const std::string& units = "1");
/// Reads /volume of a `kind=volume` file.
AnyVolume read_volume_file(const std::filesystem::path& path);

}  // namespace graintwin::io
