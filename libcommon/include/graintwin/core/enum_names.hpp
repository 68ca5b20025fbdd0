#pragma once
// One table per enum gives both its names and its parsing, so that the two directions cannot drift
// apart (an option's value, a name stored in a file, a message all read the same table).
#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "graintwin/core/error.hpp"

namespace graintwin {

template <class E>
struct EnumName {
  E value;
  const char* name;
};

/// The name of `value` in `table`; "?" if the table lacks it (a table missing a value is a
/// programming error, which the enum's tests catch).
template <class E, std::size_t N>
const char* enum_name(const std::array<EnumName<E>, N>& table, E value) {
  for (const EnumName<E>& e : table)
    if (e.value == value) return e.name;
  return "?";
}

/// The table's names in its order: a command-line option's choices (CLI::IsMember), so that the
/// option lists exactly the names its parsing takes.
template <class E, std::size_t N>
std::vector<std::string> enum_names(const std::array<EnumName<E>, N>& table) {
  std::vector<std::string> names;
  for (const EnumName<E>& e : table) names.emplace_back(e.name);
  return names;
}

/// The value named `text` (exactly), or nothing: for names read from files, whose errors say more.
template <class E, std::size_t N>
std::optional<E> find_enum(const std::array<EnumName<E>, N>& table, const std::string& text) {
  for (const EnumName<E>& e : table)
    if (text == e.name) return e.value;
  return std::nullopt;
}

/// The value named `text`; UsageError "<what> '<text>' is not a, b or c" otherwise.
template <class E, std::size_t N>
E parse_enum(const std::array<EnumName<E>, N>& table, const std::string& text, const std::string& what) {
  if (const std::optional<E> value = find_enum(table, text)) return *value;
  std::string names;
  for (std::size_t k = 0; k < N; ++k) names += (k == 0 ? "" : k + 1 == N ? " or " : ", ") + std::string(table[k].name);
  throw UsageError(what + " '" + text + "' is not " + names);
}

}  // namespace graintwin
