#pragma once
// Internal to the scene reader (scene.cpp): one TOML table read with checks, named in every error
// as "scene.toml: [[grains]] 2", and the tables of an array of tables. Every table refuses the keys
// it does not know, suggesting the closest known one.
#include <Eigen/Core>
#include <toml++/toml.h>

#include <cmath>
#include <initializer_list>
#include <set>
#include <string>
#include <vector>

#include "graintwin/core/error.hpp"
#include "graintwin/core/strings.hpp"

namespace graintwin::fdem::detail {

/// One TOML table with the name it is reported under ("scene.toml: [[grains]] 2").
class Table {
 public:
  Table(const toml::table& t, std::string where, std::initializer_list<const char*> keys) : t_(t), where_(std::move(where)) {
    const std::set<std::string> known(keys.begin(), keys.end());
    for (auto&& [k, v] : t)
      if (!known.count(std::string(k.str()))) {
        std::string list;
        for (const char* key : keys) list += (list.empty() ? "" : ", ") + std::string(key);
        const std::string hint = closest_name(std::string(k.str()), {keys.begin(), keys.end()});
        fail("key '" + excerpt(std::string(k.str())) + "' is unknown" + (hint.empty() ? "" : "; did you mean '" + hint + "'?") +
             " (known: " + list + ")");
      }
  }
  [[noreturn]] void fail(const std::string& what) const { throw UsageError(where_ + ": " + what); }
  bool has(const char* key) const { return t_.contains(key); }
  const std::string& where() const { return where_; }

  double number(const char* key, double fallback) const {
    const toml::node* n = t_.get(key);
    if (!n) return fallback;
    const auto v = n->value<double>();
    if (!v || !std::isfinite(*v)) fail(std::string(key) + " must be a number");
    return *v;
  }
  double positive(const char* key, double fallback) const {
    const double v = number(key, fallback);
    if (!(v > 0)) fail(std::string(key) + " must be positive");
    return v;
  }
  double non_negative(const char* key, double fallback) const {
    const double v = number(key, fallback);
    if (v < 0) fail(std::string(key) + " must not be negative");
    return v;
  }
  bool flag(const char* key, bool fallback) const {
    const toml::node* n = t_.get(key);
    if (!n) return fallback;
    if (!n->is_boolean()) fail(std::string(key) + " must be true or false");
    return n->value<bool>().value();
  }
  std::string text(const char* key, const std::string& fallback) const {
    const toml::node* n = t_.get(key);
    if (!n) return fallback;
    if (!n->is_string()) fail(std::string(key) + " must be a string");
    return n->value<std::string>().value();
  }
  Eigen::Vector3d vector(const char* key, const Eigen::Vector3d& fallback) const {
    const toml::node* n = t_.get(key);
    if (!n) return fallback;
    const toml::array* a = n->as_array();
    if (!a || a->size() != 3) fail(std::string(key) + " must be an array of 3 numbers, e.g. [0, 0, 1]");
    Eigen::Vector3d v;
    for (int k = 0; k < 3; ++k) {
      const auto x = (*a)[static_cast<std::size_t>(k)].value<double>();
      if (!x || !std::isfinite(*x)) fail(std::string(key) + " must be an array of 3 numbers, e.g. [0, 0, 1]");
      v[k] = *x;
    }
    return v;
  }
  /// An array of 3-vectors, e.g. [[0, 0, 1e-3], [0, 0, -1e-3]]; empty when the key is absent.
  std::vector<Eigen::Vector3d> vectors(const char* key) const {
    std::vector<Eigen::Vector3d> out;
    const toml::node* n = t_.get(key);
    if (!n) return out;
    const toml::array* a = n->as_array();
    const std::string usage = std::string(key) + " must be an array of points, e.g. [[0, 0, 1e-3]]";
    if (!a || a->empty()) fail(usage);
    for (const toml::node& item : *a) {
      const toml::array* p = item.as_array();
      if (!p || p->size() != 3) fail(usage);
      Eigen::Vector3d v;
      for (int k = 0; k < 3; ++k) {
        const auto x = (*p)[static_cast<std::size_t>(k)].value<double>();
        if (!x || !std::isfinite(*x)) fail(usage);
        v[k] = *x;
      }
      out.push_back(v);
    }
    return out;
  }
  const toml::table& raw() const { return t_; }

 private:
  const toml::table& t_;
  std::string where_;
};

/// The tables of an array of tables `[[name]]` (empty when absent).
inline std::vector<const toml::table*> tables(const toml::table& root, const char* name, const std::string& file) {
  std::vector<const toml::table*> out;
  const toml::node* n = root.get(name);
  if (!n) return out;
  const toml::array* a = n->as_array();
  if (!a) throw UsageError(file + ": " + name + " must be written as [[" + name + "]] tables");
  for (const toml::node& item : *a) {
    if (!item.is_table()) throw UsageError(file + ": " + name + " must be written as [[" + name + "]] tables");
    out.push_back(item.as_table());
  }
  return out;
}

}  // namespace graintwin::fdem::detail
