#pragma once
// Small text helpers shared by readers and tools.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace graintwin {

std::vector<std::string> split(const std::string& text, char sep);
std::string trim(const std::string& text);
std::string lower(std::string text);
/// Text read from a file, fit to be quoted in a message: bytes other than printable ASCII become
/// '?', and past `max` characters it is cut with "..." (a damaged file must not print pages).
std::string excerpt(const std::string& text, std::size_t max = 60);
/// Natural ("human") order: "slice2" < "slice10".
bool natural_less(const std::string& a, const std::string& b);
/// The length in metres of one `unit` (lower case): m, meter, cm, mm, um, micron, µm (also as
/// ImageJ escapes it, \u00b5m) or nm; nothing for any other name. The one unit table of the
/// length options and the image headers that name their unit.
std::optional<double> length_unit_m(const std::string& unit);
/// Parses a length with an optional unit suffix: "27.5um", "0.0607mm", "6e-5" (metres when bare).
/// Throws UsageError naming `what` when it is not a positive finite length.
double parse_length_m(const std::string& text, const std::string& what);
/// The candidate closest to `word` by edit distance, when close enough to be a likely misspelling
/// (at most a third of its letters, and at least 2, differ); empty otherwise.
std::string closest_name(const std::string& word, const std::vector<std::string>& candidates);
/// The same for a signed length, e.g. a position "-1.5mm": throws UsageError naming `what` unless
/// it is a finite length (zero and negative values pass).
double parse_signed_length_m(const std::string& text, const std::string& what);
/// Shell-style quoting of one argument for command lines recorded in provenance.
std::string shell_quote(const std::string& arg);
/// Current UTC time as ISO-8601, e.g. 2026-11-22T10:04:05Z.
std::string utc_now_iso8601();

}  // namespace graintwin
