#pragma once
// Small text helpers shared by readers and tools.
#include <filesystem>
#include <string>
#include <vector>

namespace graintwin {

std::vector<std::string> split(const std::string& text, char sep);
std::string trim(const std::string& text);
std::string lower(std::string text);
/// Natural ("human") order: "slice2" < "slice10".
bool natural_less(const std::string& a, const std::string& b);
/// Parses a length with an optional unit suffix: "27.5um", "0.0607mm", "6e-5" (metres when bare).
/// Throws UsageError naming `what` when it is not a positive finite length.
double parse_length_m(const std::string& text, const std::string& what);
/// The same for a signed length, e.g. a position "-1.5mm": throws UsageError naming `what` unless
/// it is a finite length (zero and negative values pass).
double parse_signed_length_m(const std::string& text, const std::string& what);
/// Shell-style quoting of one argument for command lines recorded in provenance.
std::string shell_quote(const std::string& arg);
/// Current UTC time as ISO-8601, e.g. 2026-11-22T10:04:05Z.
std::string utc_now_iso8601();

}  // namespace graintwin
