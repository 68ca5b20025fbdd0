#pragma once
// validation.json (docs/formats.md, docs/validate.md): a pipeline run's error budget against
// ctsynth's ground truth, per scan and per increment with every line's summary, and the command
// history. Written by the validate tool, read by the report (read_validation). JSON, not HDF5: it
// is a small record people read and diff; keys are in io/schema.hpp (schema::validation).
#include <filesystem>
#include <string>
#include <vector>

#include "graintwin/validate/scores.hpp"

namespace graintwin::validate {

/// One scan's lines.
struct ScanValidation {
  std::string name;  ///< scan_NNN
  SegmentationScore segmentation;
  bool has_contacts = false, has_shapes = false;  ///< the run has the scan's contacts / shapes file
  ContactScore contacts;
  ShapeScore shapes;
};

/// The whole record.
struct Validation {
  std::string run, series;  ///< the run folder and the series folder, as given
  std::vector<ScanValidation> scans;
  std::vector<TrackingScore> tracking;        ///< per pair of consecutive scans (empty without tracks)
  std::vector<DeformationScore> deformation;  ///< per increment of the run's micro.h5 (empty without one)
  bool has_simulation = false;                ///< the run has simulation.h5
  TwinScore twin;
  std::vector<std::string> history;           ///< the inputs' provenance lines, then the validate run's own
};

/// One number per line of the budget, over all scans or increments (NaN when the run lacks the stage).
struct BudgetSummary {
  double grains_right = kNaN;              ///< sum of right / sum of true grains over the scans
  double void_ratio_error_max_abs = kNaN;  ///< largest |e - e_true| over the scans
  double contacts_found_share = kNaN;      ///< sum of found / sum of true touching
  std::size_t contacts_false = 0;          ///< sum of false over the scans
  double normal_error_median_deg = kNaN;   ///< over every scan's found contacts
  double anisotropy_error_max_abs = kNaN;  ///< largest |a - a_true| over the scans
  double invariant_error_median = kNaN;    ///< mean of the scans' medians
  double volume_error_median = kNaN;       ///< over every scan's faithful grains
  std::size_t tracking_right = 0, tracking_wrong = 0, tracking_lost = 0;
  double displacement_error_median_m = kNaN, displacement_error_rel_median = kNaN;  ///< over every right track
  double rotation_error_median_deg = kNaN;
  double d2min_spearman = kNaN, eps_q_spearman = kNaN, cluster_jaccard = kNaN;  ///< means over the increments
};
BudgetSummary summarise(const Validation& v);

/// Writes `v` as JSON (NaN as null) to `path`.
void write_validation(const std::filesystem::path& path, const Validation& v);

/// Reads a validation.json. UsageError naming the file when it is not JSON of kind "validation";
/// DataError naming the file and the key when a key the writer always writes is missing or of
/// the wrong type.
Validation read_validation(const std::filesystem::path& path);

}  // namespace graintwin::validate
