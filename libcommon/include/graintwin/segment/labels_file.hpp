#pragma once
// `kind=labels` files (docs/formats.md): the label image, the grain table, the sample region and
// void ratio, and the segmentation parameters. Written by ct2labels, read by every stage after it.
#include <filesystem>
#include <string>
#include <vector>

#include "graintwin/core/volume.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/segment/labels.hpp"
#include "graintwin/segment/sample_region.hpp"

namespace graintwin::segment {

/// The sample region of a labels file and what was measured in it.
struct SampleRecord {
  Cylinder region;        ///< unbounded radius when the whole volume was the region
  VoidRatio void_ratio;
};

struct LabelsFile {
  Volume<std::uint32_t> labels;
  std::vector<GrainRecord> grains;  ///< in label order
  SampleRecord sample;
  std::string parameters_json;      ///< what the segmentation used and chose (free-form JSON object)
};

/// Writes a complete labels file (root attributes, /labels, /grains/*, /sample/*,
/// /segmentation/parameters, /provenance/history). `grains` must be grain_table(labels).
void write_labels_file(const std::filesystem::path& path, const LabelsFile& content,
                       const std::vector<std::string>& history);

/// Reads a labels file; UsageError naming the file if it is not one. The grain table is read from
/// the file (not recomputed) and checked against the label image (grain_table_mismatch): DataError
/// naming the file when a grain has no row or a row disagrees with its voxels.
LabelsFile read_labels_file(const std::filesystem::path& path);

/// The checks a reader makes on the grain table of an open labels file, without reading the label
/// image (for the report's check of a run): its columns of one length, no infinity anywhere, no NaN
/// in a centroid or volume (io/table_checks; DataError naming the file and the column).
void check_labels_tables(const io::H5File& file);

/// The void ratio a labels file measured in its sample region (/sample/void_ratio), without
/// reading the label image: for readers that need only the sample's measurement (the report).
/// NaN when the file holds none; UsageError naming the file if it is not a labels file.
double read_void_ratio(const std::filesystem::path& path);

}  // namespace graintwin::segment
