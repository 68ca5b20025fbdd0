#include "graintwin/io/table_checks.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "graintwin/core/error.hpp"

namespace graintwin::io {

namespace {

std::string value_name(double v) { return std::isnan(v) ? "NaN" : v > 0 ? "infinity" : "-infinity"; }

/// The first value of `values` that fails `bad`, reported with its row.
template <class Bad>
void refuse_first(const H5File& f, const std::string& name, std::span<const double> values, std::size_t width,
                  const std::string& fix, Bad bad) {
  const auto at = std::find_if(values.begin(), values.end(), bad);
  if (at == values.end()) return;
  const std::size_t row = static_cast<std::size_t>(at - values.begin()) / std::max<std::size_t>(width, 1);
  throw DataError(fmt::format("{}: {} holds {} in row {}, a value no GrainTwin tool writes there; {}", f.path().string(), name,
                              value_name(*at), row, fix));
}

}  // namespace

std::size_t table_rows(const H5File& f, const std::string& group, const std::string& fix) {
  if (!f.exists(group) || !f.is_group(group)) return 0;
  std::string first;
  std::size_t rows = 0;
  for (const std::string& member : f.list(group)) {
    const std::string name = group + "/" + member;
    // A stage's options (JSON) may sit beside the table it made (/tracks/parameters): not a column.
    if (member == "parameters" || f.is_group(name)) continue;
    const DatasetInfo info = f.info(name);
    const std::size_t n = info.dims.empty() ? 1 : static_cast<std::size_t>(info.dims[0]);
    if (first.empty()) {
      first = name, rows = n;
    } else if (n != rows) {
      throw DataError(fmt::format("{}: the table {} has columns of different lengths ({} has {} rows, {} has {}); {}",
                                  f.path().string(), group, first, rows, name, n, fix));
    }
  }
  return rows;
}

void require_finite_table(const H5File& f, const std::string& group, std::initializer_list<std::string_view> never_nan,
                          const std::string& fix) {
  if (!f.exists(group) || !f.is_group(group)) return;
  for (const std::string& member : f.list(group)) {
    const std::string name = group + "/" + member;
    if (f.is_group(name)) continue;
    const std::string dtype = f.info(name).dtype;
    if (!dtype.starts_with("float")) continue;
    std::vector<hsize_t> dims;
    const std::vector<double> v = f.read<double>(name, &dims);
    std::size_t width = 1;
    for (std::size_t k = 1; k < dims.size(); ++k) width *= static_cast<std::size_t>(dims[k]);
    const bool nan_forbidden = std::any_of(never_nan.begin(), never_nan.end(), [&](std::string_view column) {
      return column.substr(column.rfind('/') + 1) == member;  // npos + 1 == 0: a bare name is itself
    });
    refuse_first(f, name, v, width, fix, [&](double x) { return std::isinf(x) || (nan_forbidden && std::isnan(x)); });
  }
}

void require_finite(const H5File& f, const std::string& name, std::span<const double> values, std::size_t width,
                    const std::string& fix) {
  refuse_first(f, name, values, width, fix, [](double x) { return !std::isfinite(x); });
}

}  // namespace graintwin::io
