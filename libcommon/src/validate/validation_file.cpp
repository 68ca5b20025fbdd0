#include "graintwin/validate/validation_file.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>

#include "graintwin/core/error.hpp"
#include "graintwin/core/statistics.hpp"
#include "graintwin/io/schema.hpp"

namespace graintwin::validate {

namespace sv = schema::validation;
using nlohmann::json;

namespace {

// One field list per record, walked by the writer and by the reader, so the two cannot drift apart.
// Numbers are SI (m, 1) or degrees where the name says so; NaN is written as null.
struct JsonWriter {
  json& j;
  void operator()(const char* key, const double& v) { j[key] = std::isfinite(v) ? json(v) : json(nullptr); }
  void operator()(const char* key, const std::size_t& v) { j[key] = v; }
  void operator()(const char* key, const bool& v) { j[key] = v; }
  void operator()(const char* key, const std::string& v) { j[key] = v; }
  void operator()(const char* key, const std::vector<double>& v) {
    json a = json::array();
    for (double x : v) a.push_back(std::isfinite(x) ? json(x) : json(nullptr));
    j[key] = std::move(a);
  }
};

struct JsonReader {
  const json& j;
  const std::string& file;
  const json& at(const char* key) const {
    if (!j.is_object() || !j.contains(key))
      throw DataError(file + ": key \"" + key + "\" is missing; the file is damaged, write it again with validate");
    return j[key];
  }
  [[noreturn]] void wrong(const char* key, const char* what) const {
    throw DataError(file + ": key \"" + key + "\" is not " + what + "; the file is damaged, write it again with validate");
  }
  static double number(const json& v) { return v.is_null() ? kNaN : v.get<double>(); }
  void operator()(const char* key, double& v) const {
    const json& x = at(key);
    if (!x.is_number() && !x.is_null()) wrong(key, "a number or null");
    v = number(x);
  }
  void operator()(const char* key, std::size_t& v) const {
    const json& x = at(key);
    if (!x.is_number_unsigned()) wrong(key, "a count");
    v = x.get<std::size_t>();
  }
  void operator()(const char* key, bool& v) const {
    const json& x = at(key);
    if (!x.is_boolean()) wrong(key, "true or false");
    v = x.get<bool>();
  }
  void operator()(const char* key, std::string& v) const {
    const json& x = at(key);
    if (!x.is_string()) wrong(key, "a string");
    v = x.get<std::string>();
  }
  void operator()(const char* key, std::vector<double>& v) const {
    const json& x = at(key);
    if (!x.is_array()) wrong(key, "an array of numbers");
    v.clear();
    for (const json& e : x) {
      if (!e.is_number() && !e.is_null()) wrong(key, "an array of numbers");
      v.push_back(number(e));
    }
  }
};

template <class Io>
void fields(Io& io, SegmentationScore& s) {
  io("true_grains", s.true_grains), io("right", s.right), io("split", s.split), io("merged", s.merged);
  io("missed", s.missed), io("boundary", s.boundary), io("labels", s.labels), io("spurious", s.spurious);
  io("right_share", s.right_share), io("void_ratio", s.void_ratio), io("void_ratio_true", s.void_ratio_true);
}

template <class Io>
void fields(Io& io, ContactScore& s) {
  io("true_touching", s.true_touching), io("found", s.found), io("missed", s.missed), io("false", s.false_found);
  io("found_share", s.found_share), io("normal_error_median_deg", s.normal_error_median_deg);
  io("normal_error_p90_deg", s.normal_error_p90_deg), io("anisotropy", s.anisotropy), io("anisotropy_true", s.anisotropy_true);
  io("normal_error_deg", s.normal_error_deg);
}

template <class Io>
void fields(Io& io, ShapeScore& s) {
  io("grains", s.grains), io("invariant_error_by_degree", s.invariant_error_by_degree);
  io("invariant_error_median", s.invariant_error_median), io("volume_error_median", s.volume_error_median);
  io("diameter_error_median", s.diameter_error_median), io("volume_error", s.volume_error);
}

template <class Io>
void fields(Io& io, TrackingScore& s) {
  io("from", s.from), io("to", s.to), io("targets", s.targets), io("right", s.right), io("wrong", s.wrong), io("lost", s.lost);
  io("displacement_error_median_m", s.displacement_error_median_m), io("displacement_error_p90_m", s.displacement_error_p90_m);
  io("displacement_error_rel_median", s.displacement_error_rel_median);
  io("rotation_error_median_deg", s.rotation_error_median_deg), io("rotation_error_p90_deg", s.rotation_error_p90_deg);
  io("displacement_error_m", s.displacement_error_m), io("rotation_error_deg", s.rotation_error_deg);
}

template <class Io>
void fields(Io& io, DeformationScore& s) {
  io("from", s.from), io("to", s.to), io("grains", s.grains), io("d2min_spearman", s.d2min_spearman);
  io("eps_q_spearman", s.eps_q_spearman), io("cluster_members", s.cluster_members);
  io("cluster_members_true", s.cluster_members_true), io("cluster_common", s.cluster_common);
  io("cluster_jaccard", s.cluster_jaccard), io("d2min", s.d2min), io("d2min_true", s.d2min_true);
}

template <class Io>
void fields(Io& io, TwinScore& s) {
  io("simulated", s.simulated), io("stress_ratio_rms_rel", s.stress_ratio_rms_rel);
  io("volumetric_strain_max_abs", s.volumetric_strain_max_abs), io("axial_strain_max", s.axial_strain_max);
  io("axial_strain", s.axial_strain), io("stress_ratio_true", s.stress_ratio_true), io("stress_ratio", s.stress_ratio);
  io("volumetric_strain_true", s.volumetric_strain_true), io("volumetric_strain", s.volumetric_strain);
}

template <class T>
json to_json(const T& record) {
  json j = json::object();
  JsonWriter w{j};
  fields(w, const_cast<T&>(record));  // the writer only reads
  return j;
}

template <class T>
T from_json(const json& j, const std::string& file) {
  T record;
  JsonReader r{j, file};
  fields(r, record);
  return record;
}

const json& section(const json& j, const char* key, const std::string& file) {
  if (!j.contains(key) || !j[key].is_object())
    throw DataError(file + ": section \"" + key + "\" is missing; the file is damaged, write it again with validate");
  return j[key];
}

const json& list(const json& j, const char* key, const std::string& file) {
  if (!j.contains(key) || !j[key].is_array())
    throw DataError(file + ": \"" + key + "\" is not a list; the file is damaged, write it again with validate");
  return j[key];
}

double mean_finite(const std::vector<double>& v) {
  double sum = 0.0;
  std::size_t n = 0;
  for (double x : v)
    if (std::isfinite(x)) sum += x, ++n;
  return n ? sum / static_cast<double>(n) : kNaN;
}

double largest_abs_difference(const std::vector<std::pair<double, double>>& pairs) {
  double largest = kNaN;
  for (const auto& [a, b] : pairs)
    if (std::isfinite(a - b)) largest = std::isfinite(largest) ? std::max(largest, std::abs(a - b)) : std::abs(a - b);
  return largest;
}

double median_or_nan(const std::vector<double>& v) { return v.empty() ? kNaN : median(v); }

}  // namespace

BudgetSummary summarise(const Validation& v) {
  BudgetSummary s;
  std::size_t right = 0, grains = 0, found = 0, touching = 0;
  std::vector<std::pair<double, double>> void_ratios, anisotropies;
  std::vector<double> normal_errors, invariant_medians, volume_errors;
  bool contacts = false, shapes = false;
  for (const ScanValidation& sc : v.scans) {
    right += sc.segmentation.right, grains += sc.segmentation.true_grains;
    void_ratios.emplace_back(sc.segmentation.void_ratio, sc.segmentation.void_ratio_true);
    if (sc.has_contacts) {
      contacts = true;
      found += sc.contacts.found, touching += sc.contacts.true_touching, s.contacts_false += sc.contacts.false_found;
      normal_errors.insert(normal_errors.end(), sc.contacts.normal_error_deg.begin(), sc.contacts.normal_error_deg.end());
      anisotropies.emplace_back(sc.contacts.anisotropy, sc.contacts.anisotropy_true);
    }
    if (sc.has_shapes) {
      shapes = true;
      invariant_medians.push_back(sc.shapes.invariant_error_median);
      volume_errors.insert(volume_errors.end(), sc.shapes.volume_error.begin(), sc.shapes.volume_error.end());
    }
  }
  if (grains) s.grains_right = static_cast<double>(right) / static_cast<double>(grains);
  s.void_ratio_error_max_abs = largest_abs_difference(void_ratios);
  if (contacts) {
    if (touching) s.contacts_found_share = static_cast<double>(found) / static_cast<double>(touching);
    s.normal_error_median_deg = median_or_nan(normal_errors);
    s.anisotropy_error_max_abs = largest_abs_difference(anisotropies);
  }
  if (shapes) {
    s.invariant_error_median = mean_finite(invariant_medians);
    s.volume_error_median = median_or_nan(volume_errors);
  }
  std::vector<double> displacement, relative, rotation;
  for (const TrackingScore& t : v.tracking) {
    s.tracking_right += t.right, s.tracking_wrong += t.wrong, s.tracking_lost += t.lost;
    displacement.insert(displacement.end(), t.displacement_error_m.begin(), t.displacement_error_m.end());
    rotation.insert(rotation.end(), t.rotation_error_deg.begin(), t.rotation_error_deg.end());
  }
  s.displacement_error_median_m = median_or_nan(displacement);
  s.rotation_error_median_deg = median_or_nan(rotation);
  for (const TrackingScore& t : v.tracking) relative.push_back(t.displacement_error_rel_median);
  s.displacement_error_rel_median = mean_finite(relative);
  std::vector<double> d2min, eps_q, jaccard;
  for (const DeformationScore& d : v.deformation)
    d2min.push_back(d.d2min_spearman), eps_q.push_back(d.eps_q_spearman), jaccard.push_back(d.cluster_jaccard);
  s.d2min_spearman = mean_finite(d2min);
  s.eps_q_spearman = mean_finite(eps_q);
  s.cluster_jaccard = mean_finite(jaccard);
  return s;
}

void write_validation(const std::filesystem::path& path, const Validation& v) {
  const BudgetSummary s = summarise(v);
  json j = json::object();
  JsonWriter top{j};
  j[schema::attr::kind] = sv::kind;
  j[schema::attr::schema_version] = sv::version;
  top(sv::run, v.run), top(sv::series, v.series);

  json seg = json::object(), con = json::object(), sha = json::object();
  JsonWriter ws{seg}, wc{con}, wh{sha};
  ws("grains_right", s.grains_right), ws("void_ratio_error_max_abs", s.void_ratio_error_max_abs);
  wc("found_share", s.contacts_found_share), wc("false", s.contacts_false), wc("normal_error_median_deg", s.normal_error_median_deg);
  wc("anisotropy_error_max_abs", s.anisotropy_error_max_abs);
  wh("invariant_error_median", s.invariant_error_median), wh("volume_error_median", s.volume_error_median);
  seg[sv::scans] = con[sv::scans] = sha[sv::scans] = json::array();
  for (const ScanValidation& sc : v.scans) {
    json a = to_json(sc.segmentation), b = sc.has_contacts ? to_json(sc.contacts) : json::object(),
         c = sc.has_shapes ? to_json(sc.shapes) : json::object();
    for (json* x : {&a, &b, &c}) (*x)["name"] = sc.name;
    b["present"] = sc.has_contacts, c["present"] = sc.has_shapes;
    seg[sv::scans].push_back(std::move(a)), con[sv::scans].push_back(std::move(b)), sha[sv::scans].push_back(std::move(c));
  }
  j[sv::segmentation] = std::move(seg), j[sv::contacts] = std::move(con), j[sv::shapes] = std::move(sha);

  json tr = json::object();
  JsonWriter wt{tr};
  wt("right", s.tracking_right), wt("wrong", s.tracking_wrong), wt("lost", s.tracking_lost);
  wt("displacement_error_median_m", s.displacement_error_median_m), wt("displacement_error_rel_median", s.displacement_error_rel_median);
  wt("rotation_error_median_deg", s.rotation_error_median_deg);
  tr[sv::increments] = json::array();
  for (const TrackingScore& t : v.tracking) tr[sv::increments].push_back(to_json(t));
  j[sv::tracking] = std::move(tr);

  json d2 = json::object(), eq = json::object(), cl = json::object();
  JsonWriter wd{d2}, we{eq}, wl{cl};
  wd("spearman", s.d2min_spearman), we("spearman", s.eps_q_spearman), wl("jaccard", s.cluster_jaccard);
  d2[sv::increments] = json::array();
  for (const DeformationScore& d : v.deformation) d2[sv::increments].push_back(to_json(d));
  j[sv::d2min] = std::move(d2), j[sv::eps_q] = std::move(eq), j[sv::clusters] = std::move(cl);

  json twin = to_json(v.twin);
  twin["simulation"] = v.has_simulation;
  j[sv::twin] = std::move(twin);
  j[sv::history] = v.history;
  std::ofstream out(path);
  out << j.dump(1) << "\n";
  if (!out) throw DataError("cannot write " + path.string() + "; check the folder's space and permissions");
}

Validation read_validation(const std::filesystem::path& path) {
  const std::string file = path.string();
  std::ifstream in(path);
  if (!in) throw UsageError(file + " cannot be read; check the path (validate writes runs/<series>/validation.json)");
  const json j = json::parse(in, nullptr, false);
  if (j.is_discarded() || !j.is_object() || !j.contains(schema::attr::kind) || j[schema::attr::kind] != sv::kind)
    throw UsageError(file + " is not a validation.json; pass the file the validate tool writes");
  if (!j.contains(schema::attr::schema_version) || !j[schema::attr::schema_version].is_number_integer() ||
      j[schema::attr::schema_version].get<int>() > sv::version)
    throw UsageError(file + " was written by a newer validate; read it with that version or write it again");
  Validation v;
  const JsonReader top{j, file};
  top(sv::run, v.run), top(sv::series, v.series);
  const json &seg = list(section(j, sv::segmentation, file), sv::scans, file),
             &con = list(section(j, sv::contacts, file), sv::scans, file),
             &sha = list(section(j, sv::shapes, file), sv::scans, file);
  if (con.size() != seg.size() || sha.size() != seg.size())
    throw DataError(file + ": the sections' scan lists differ in length; the file is damaged, write it again with validate");
  for (std::size_t k = 0; k < seg.size(); ++k) {
    ScanValidation sc;
    JsonReader{seg[k], file}("name", sc.name);
    sc.segmentation = from_json<SegmentationScore>(seg[k], file);
    JsonReader{con[k], file}("present", sc.has_contacts);
    JsonReader{sha[k], file}("present", sc.has_shapes);
    if (sc.has_contacts) sc.contacts = from_json<ContactScore>(con[k], file);
    if (sc.has_shapes) sc.shapes = from_json<ShapeScore>(sha[k], file);
    v.scans.push_back(std::move(sc));
  }
  for (const json& t : list(section(j, sv::tracking, file), sv::increments, file)) v.tracking.push_back(from_json<TrackingScore>(t, file));
  for (const json& d : list(section(j, sv::d2min, file), sv::increments, file)) v.deformation.push_back(from_json<DeformationScore>(d, file));
  const json& twin = section(j, sv::twin, file);
  v.twin = from_json<TwinScore>(twin, file);
  JsonReader{twin, file}("simulation", v.has_simulation);
  for (const json& line : list(j, sv::history, file)) {
    if (!line.is_string()) throw DataError(file + ": \"history\" holds a line that is not a string; write it again with validate");
    v.history.push_back(line.get<std::string>());
  }
  return v;
}

}  // namespace graintwin::validate
