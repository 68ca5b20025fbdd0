#pragma once
// Checks a reader makes on the tables of a GrainTwin file before trusting them. A table is a group
// whose datasets are its columns, one row per grain, contact, track or frame along their first
// dimension (docs/formats.md). A damaged or hand-edited file can break a table in two ways no HDF5
// call notices: columns of different lengths (a grain's values taken from another grain's row) and
// values no tool writes (NaN or infinity where a finite number is the only meaning). Both are
// refused with a DataError naming the file, the column, the row and `fix` (what the user should do,
// e.g. "rewrite it with labels2shapes").
#include <cstddef>
#include <initializer_list>
#include <span>
#include <string>
#include <string_view>

#include "graintwin/io/h5file.hpp"

namespace graintwin::io {

/// The row count of the table under `group`: the first dimension its datasets share (subgroups and
/// a `parameters` JSON string beside the table aside). 0 when the group is absent or holds no dataset.
std::size_t table_rows(const H5File& f, const std::string& group, const std::string& fix);

/// Refuses an infinite value in any floating-point column of the table under `group`, and a NaN in
/// the columns named in `never_nan` (elsewhere NaN is the formats' "not measured"). A column is
/// named by its dataset's name in io/schema.hpp: its last path component is the column's name.
void require_finite_table(const H5File& f, const std::string& group, std::initializer_list<std::string_view> never_nan,
                          const std::string& fix);

/// Refuses a NaN or infinite value among `values`, read from the dataset `name` of `f` with `width`
/// values per row.
void require_finite(const H5File& f, const std::string& name, std::span<const double> values, std::size_t width,
                    const std::string& fix);

}  // namespace graintwin::io
