#include "graintwin/core/strings.hpp"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <ctime>

#include "graintwin/core/error.hpp"

namespace graintwin {

std::vector<std::string> split(const std::string& text, char sep) {
  std::vector<std::string> parts;
  std::string cur;
  for (char c : text) {
    if (c == sep) {
      parts.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  parts.push_back(cur);
  return parts;
}

std::string trim(const std::string& text) {
  const auto b = text.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return "";
  const auto e = text.find_last_not_of(" \t\r\n");
  return text.substr(b, e - b + 1);
}

std::string lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

std::string excerpt(const std::string& text, std::size_t max) {
  std::string out;
  for (unsigned char c : text) {
    if (out.size() >= max) return out + "...";
    out += (c >= 0x20 && c < 0x7f) ? static_cast<char>(c) : '?';
  }
  return out;
}

bool natural_less(const std::string& a, const std::string& b) {
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (std::isdigit(static_cast<unsigned char>(a[i])) && std::isdigit(static_cast<unsigned char>(b[j]))) {
      std::size_t i2 = i, j2 = j;
      while (i2 < a.size() && a[i2] == '0') ++i2;
      while (j2 < b.size() && b[j2] == '0') ++j2;
      std::size_t ie = i2, je = j2;
      while (ie < a.size() && std::isdigit(static_cast<unsigned char>(a[ie]))) ++ie;
      while (je < b.size() && std::isdigit(static_cast<unsigned char>(b[je]))) ++je;
      if (ie - i2 != je - j2) return ie - i2 < je - j2;
      const int c = a.compare(i2, ie - i2, b, j2, je - j2);
      if (c != 0) return c < 0;
      if ((i2 - i) != (j2 - j)) return (i2 - i) < (j2 - j);  // fewer leading zeros first
      i = ie;
      j = je;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i;
      ++j;
    }
  }
  return a.size() - i < b.size() - j;
}

std::optional<double> length_unit_m(const std::string& unit) {
  struct LengthUnit {
    const char* name;
    double metres;
  };
  static constexpr LengthUnit kLengthUnits[] = {{"m", 1.0},     {"meter", 1.0},     {"cm", 1e-2},
                                                {"mm", 1e-3},   {"um", 1e-6},       {"micron", 1e-6},
                                                {"µm", 1e-6},   {"\\u00b5m", 1e-6}, {"nm", 1e-9}};
  for (const LengthUnit& u : kLengthUnits)
    if (unit == u.name) return u.metres;
  return std::nullopt;
}

double parse_signed_length_m(const std::string& text, const std::string& what) {
  const std::string t = lower(trim(text));
  std::size_t used = 0;
  double value = 0.0;
  try {
    value = std::stod(t, &used);
  } catch (const std::out_of_range&) {
    throw UsageError(what + " '" + text + "' is too large a number; give a length such as 27.5um or 2.75e-5");
  } catch (...) {
    throw UsageError(what + " '" + text + "' is not a number; give a length such as 27.5um or 2.75e-5");
  }
  const std::string unit = trim(t.substr(used));
  const std::optional<double> scale = unit.empty() ? 1.0 : length_unit_m(unit);
  if (!scale) throw UsageError(what + " '" + text + "' has unknown unit '" + unit + "'; use m, mm, um or nm");
  const double m = value * *scale;
  if (!std::isfinite(m)) throw UsageError(what + " '" + text + "' must be a finite length");
  return m;
}

double parse_length_m(const std::string& text, const std::string& what) {
  const double m = parse_signed_length_m(text, what);
  if (m <= 0.0) throw UsageError(what + " '" + text + "' must be a positive length");
  return m;
}

std::string shell_quote(const std::string& arg) {
  if (!arg.empty() && arg.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                            "0123456789_-+=./:,@%") == std::string::npos)
    return arg;
  std::string q = "'";
  for (char c : arg) q += (c == '\'') ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::string utc_now_iso8601() {
  const std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

namespace {
std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}
}  // namespace

std::string closest_name(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  std::size_t best_distance = std::max<std::size_t>(2, word.size() / 3) + 1;
  for (const std::string& c : candidates)
    if (const std::size_t d = edit_distance(word, c); d < best_distance) best_distance = d, best = c;
  return best;
}

}  // namespace graintwin
