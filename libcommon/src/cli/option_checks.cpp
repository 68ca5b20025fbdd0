#include "graintwin/cli/option_checks.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <optional>

#include "graintwin/core/error.hpp"
#include "graintwin/core/strings.hpp"

namespace graintwin::cli {

namespace {

/// What the user typed, shortened so that a pasted 400-digit number does not flood the message.
std::string shown(const std::string& input) {
  const std::string t = trim(input);
  return t.size() <= 40 ? t : t.substr(0, 37) + "...";
}

/// The number CLI11 would read from `input` (strtold, the whole text), or nothing.
std::optional<long double> read_number(const std::string& input) {
  const std::string t = trim(input);
  if (t.empty()) return std::nullopt;
  char* end = nullptr;
  const long double v = std::strtold(t.c_str(), &end);
  if (end != t.c_str() + t.size()) return std::nullopt;
  return v;
}

/// An integer as CLI11 reads one (strtoll, base 0: "0x10" and "010" count too), else a real
/// number that may be whole ("1e3").
std::optional<long double> read_whole_number(const std::string& input) {
  const std::string t = trim(input);
  if (t.empty()) return std::nullopt;
  char* end = nullptr;
  errno = 0;
  const long long i = std::strtoll(t.c_str(), &end, 0);
  if (end == t.c_str() + t.size() && errno == 0) return static_cast<long double>(i);
  return read_number(t);
}

std::string with_unit(const std::string& text, const std::string& unit) { return unit.empty() ? text : text + " " + unit; }

}  // namespace

bool NumberRange::contains(double value) const {
  if (!std::isfinite(value)) return false;
  const bool lo_ok = lo_open ? value > lo : value >= lo;
  const bool hi_ok = hi_open ? value < hi : value <= hi;
  return lo_ok && hi_ok;
}

std::string NumberRange::text() const {
  return with_unit(std::string(lo_open ? "(" : "[") + format_number(lo) + ", " + format_number(hi) + (hi_open ? ")" : "]"),
                   unit);
}

NumberRange closed(double lo, double hi, std::string unit) { return {lo, hi, false, false, std::move(unit)}; }

NumberRange above(double lo, double hi, std::string unit) { return {lo, hi, true, false, std::move(unit)}; }

std::string format_number(double value) { return fmt::format("{:.6g}", value); }

std::string format_length(double metres) {
  const double a = std::abs(metres);
  if (a == 0.0 || !std::isfinite(a)) return format_number(metres) + " m";
  if (a >= 1.0) return format_number(metres) + " m";
  if (a >= 1e-3) return format_number(metres * 1e3) + " mm";
  if (a >= 1e-6) return format_number(metres * 1e6) + " um";
  return format_number(metres * 1e9) + " nm";
}

CLI::Validator number_in(const NumberRange& range) {
  return CLI::Validator(
      [range](std::string& input) -> std::string {
        const auto v = read_number(input);
        if (v && range.contains(static_cast<double>(*v))) return {};
        return "must be a finite number in " + range.text() + ", not " + shown(input);
      },
      range.text());
}

CLI::Validator finite_number(const std::string& unit) {
  const std::string what = with_unit("finite number", unit);
  return CLI::Validator(
      [what](std::string& input) -> std::string {
        const auto v = read_number(input);
        if (v && std::isfinite(static_cast<double>(*v))) return {};
        return "must be a " + what + ", not " + shown(input);
      },
      what);
}

CLI::Validator whole_number_in(long long lo, long long hi, const std::string& unit) {
  // Counts are printed in full up to millions, beyond that %g-style ("1e+15 steps").
  const auto count = [](long long v) { return std::llabs(v) < 10000000 ? std::to_string(v) : format_number(static_cast<double>(v)); };
  const std::string text = with_unit("[" + count(lo) + ", " + count(hi) + "]", unit);
  return CLI::Validator(
      [lo, hi, text](std::string& input) -> std::string {
        const auto v = read_whole_number(input);
        if (v && std::isfinite(*v) && *v == std::floor(*v) && *v >= static_cast<long double>(lo) &&
            *v <= static_cast<long double>(hi))
          return {};
        return "must be a whole number in " + text + ", not " + shown(input);
      },
      text);
}

CLI::Validator length_in(double lo_m, double hi_m, bool allow_zero) {
  const std::string text = "[" + format_length(lo_m) + ", " + format_length(hi_m) + "]";
  return CLI::Validator(
      [lo_m, hi_m, allow_zero, text](std::string& input) -> std::string {
        if (allow_zero && trim(input) == "0") return {};
        double m = 0.0;
        try {
          m = parse_signed_length_m(input, "the length");
        } catch (const UsageError& e) {
          return e.message();
        }
        if ((m >= lo_m && m <= hi_m) || (allow_zero && m == 0.0)) return {};  // "0mm" is none too
        return "must be a length in " + text + (allow_zero ? " (or 0 for none)" : "") + ", not " + shown(input);
      },
      "length in " + text + (allow_zero ? " or 0" : ""));
}

double require_in(double value, const std::string& what, const NumberRange& range) {
  if (!range.contains(value))
    throw UsageError(what + " must be a finite number in " + range.text() + ", not " + format_number(value));
  return value;
}

double parse_length_in(const std::string& text, const std::string& what, double lo_m, double hi_m) {
  const double m = parse_signed_length_m(text, what);
  if (!(m >= lo_m && m <= hi_m))
    throw UsageError(what + " must be a length in [" + format_length(lo_m) + ", " + format_length(hi_m) + "], not " +
                     shown(text));
  return m;
}

}  // namespace graintwin::cli
