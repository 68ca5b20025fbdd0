#pragma once
// ct2labels' stage (docs/ct2labels.md): a scan file (kind=volume) in, the content of its labels file
// out. The scan is read, checked against the options, segmented (segment_grains), the choices and
// measures logged and recorded as the file's parameters; and the preview picture of the result.
#include <filesystem>
#include <functional>
#include <string>

#include "graintwin/io/h5file.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "graintwin/segment/segment_grains.hpp"

namespace graintwin::segment {

/// What segment_scan gives: the labels file's content and the grey threshold it used.
struct ScanSegmentation {
  LabelsFile labels;
  double threshold = 0.0;
};

/// Segments the scan of `scan` (an open kind=volume file; uint8, uint16 or float32) with `options`,
/// logging the scan's size, each step's time (debug), the choices and the result. Its on_step is
/// taken over: `progress` (may be empty) makes the progress callback of the named step "segment"
/// once the scan is read, which gets the fraction of the steps done and ends with the
/// segmentation. UsageError before anything is read when the Gaussian kernel is wider than the
/// scan, and for a uint32 scan; errors name the file.
ScanSegmentation segment_scan(const io::H5File& scan, SegmentOptions options,
                              const std::function<std::function<void(double)>(const std::string&)>& progress = {});

/// What a segmentation used and chose, as the JSON object of /segmentation/parameters.
std::string segmentation_parameters_json(const SegmentOptions& options, const SegmentResult& result);

/// ct2labels --preview: the mid axial slice (z) and the mid vertical section (y, z upwards) of the
/// grey scan in `scan` with `labels` drawn over them (overlay_labels), side by side, as a PNG; the
/// grey window spans both slices and `threshold`.
void write_segmentation_preview(const std::filesystem::path& png, const io::H5File& scan, const Volume<std::uint32_t>& labels,
                                double threshold);

}  // namespace graintwin::segment
