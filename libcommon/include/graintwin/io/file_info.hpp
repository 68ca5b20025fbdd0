#pragma once
// volinfo's stage: what a GrainTwin .h5 file holds, as JSON (what `volinfo --json` prints) and as the
// text volinfo prints: its kind, schema version and creator, every dataset with its shape, type and
// units, the geometry and value range of its image datasets, and its provenance history.
#include <nlohmann/json.hpp>

#include <filesystem>
#include <functional>
#include <string>

#include "graintwin/core/volume_ops.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/volume_io.hpp"

namespace graintwin::io {

/// The description of the file at `path`; the images' value ranges (every voxel read) only when
/// `value_range`. `progress` (may be empty) makes the progress callback of a named step. UsageError
/// naming the file when it lacks GrainTwin's `kind` attribute.
nlohmann::json describe_file(const std::filesystem::path& path, bool value_range,
                             const std::function<std::function<void(double)>(const std::string&)>& progress = {});

/// The description as volinfo's text: the kind, each image's geometry and values, the datasets and
/// the history, one item a line.
std::string describe_text(const nlohmann::json& description);

/// An image dataset's value range, read in z slabs of at most 64 MB so that a large volume never
/// sits in memory whole; `progress` (may be empty) gets the share read.
ValueRange image_value_range(const H5File& f, const std::string& path, const ImageHeader& header,
                             const std::function<void(double)>& progress = {});

}  // namespace graintwin::io
