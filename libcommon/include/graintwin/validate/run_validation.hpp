#pragma once
// validate's stage (docs/validate.md): a pipeline run (runs/<series>/) scored against the ground
// truth of the ctsynth series it was made from (sample_volumes/<series>/truth_NNN.h5), every
// line of the error budget (validate/scores) for every scan and increment the run has.
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "graintwin/validate/validation_file.hpp"

namespace graintwin::validate {

namespace fs = std::filesystem;

/// The files of one validation; an empty path is a file the run does not have.
struct ValidationFiles {
  fs::path run_dir, series_dir;
  std::vector<std::string> scan_names;          ///< scan_NNN, in order
  std::vector<fs::path> truth, labels;          ///< per scan, always present
  std::vector<fs::path> contacts, shapes;       ///< per scan (empty = absent)
  fs::path tracks, micro, simulation;
  /// Every file, in reading order.
  std::vector<fs::path> all() const;
};

/// The scans are the run's scan_* folders holding a labels file; each needs the series' truth file
/// of the same number. UsageError in one sentence naming the path and the fix: a folder missing,
/// no scans, a scan without its truth (not a ctsynth series).
ValidationFiles locate_validation_files(const fs::path& run_dir, const fs::path& series_dir);

struct ValidationOptions {
  bool all_contacts = false;  ///< count every contact of the contacts files, not only the accepted ones
};

/// Reads the files and scores every line. `progress` (may be empty) gets the fraction done.
/// UsageError from the readers for a file of the wrong kind; DataError when the files disagree
/// (a label image of another shape than its truth, tracks or micro-mechanics over another number
/// of scans).
Validation validate_run(const ValidationFiles& files, const ValidationOptions& options,
                        const std::function<void(double)>& progress = {});

}  // namespace graintwin::validate
