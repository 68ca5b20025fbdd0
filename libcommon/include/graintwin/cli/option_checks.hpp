#pragma once
// The option contract: every numeric option (and every key of a --config or scene file, which
// are the same options) is a finite number inside a stated range, checked while the command line
// is parsed, so before any heavy work. The range, with its unit, is shown in --help (CLI11 prints
// a validator's description) and in the message that refuses a value, numbers printed %g-style.
//   app.add_option("--blur", blur, "Point-spread sigma")->check(cli::number_in(cli::closed(0, 20, "voxels")));
//   -> "--blur: must be a finite number in [0, 20] voxels, not nan"
#include <CLI/CLI.hpp>

#include <string>

namespace graintwin::cli {

/// An interval of allowed values with the unit they are counted in, for help and messages.
struct NumberRange {
  double lo = 0.0;
  double hi = 0.0;
  bool lo_open = false;  ///< lo itself is excluded
  bool hi_open = false;  ///< hi itself is excluded
  std::string unit;      ///< e.g. "voxels", "d50", "deg"; empty for a pure number

  /// True for a finite value inside the interval (never for NaN or an infinity).
  bool contains(double value) const;
  /// "[0, 20] voxels", "(0, 1]", "[1e-06, 1e+06] d50".
  std::string text() const;
};

/// [lo, hi]
NumberRange closed(double lo, double hi, std::string unit = {});
/// (lo, hi]: for values that must be positive, e.g. above(0, 100, "d50").
NumberRange above(double lo, double hi, std::string unit = {});

/// Numbers as people read them: %g with up to 6 significant digits ("0.74", "1e+06", "nan").
std::string format_number(double value);
/// A length in metres in the unit that reads best: "27.5 um", "3 mm", "1 m".
std::string format_length(double metres);

/// CLI11 check of a real-valued option: a finite number in `range`.
CLI::Validator number_in(const NumberRange& range);
/// CLI11 check of a real-valued option with no natural bounds (a grey level): any finite number.
CLI::Validator finite_number(const std::string& unit = {});
/// CLI11 check of an integer option: a whole number in [lo, hi] (also refuses "-1" for unsigned
/// options, which CLI11 would otherwise wrap round to 2^64 - 1).
CLI::Validator whole_number_in(long long lo, long long hi, const std::string& unit = {});
/// CLI11 check of a length option given as text with a unit ("27.5um", "0.3mm", "6e-5"): a
/// length in [lo_m, hi_m] metres; with `allow_zero` the text "0" (meaning "none") passes too.
/// lo_m may be negative for positions.
CLI::Validator length_in(double lo_m, double hi_m, bool allow_zero = false);

/// The same checks for values that do not come through CLI11 (parts of a list option, values
/// computed from options): UsageError "<what> must be a finite number in <range>, not <value>".
double require_in(double value, const std::string& what, const NumberRange& range);
/// Parses a length with unit (signed) and checks it lies in [lo_m, hi_m]; UsageError naming `what`.
double parse_length_in(const std::string& text, const std::string& what, double lo_m, double hi_m);

}  // namespace graintwin::cli
