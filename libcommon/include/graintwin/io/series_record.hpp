#pragma once
// A ctsynth series' series.json (docs/formats.md): the scans' applied axial strains, read for the
// report's strain axis. ctsynth writes it (synth/series) with the key names of
// schema::series_record.
#include <filesystem>
#include <vector>

namespace graintwin::io {

/// The applied axial strain of every scan, in scan order. UsageError in one sentence naming the
/// file and the fix when it is not such a record: unreadable, not a JSON object with a `scans`
/// array, or an entry without a number `axial_strain`.
std::vector<double> read_series_axial_strains(const std::filesystem::path& path);

}  // namespace graintwin::io
