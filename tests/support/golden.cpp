#include "support/golden.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

namespace graintwin::test {

namespace {

using Json = nlohmann::ordered_json;

constexpr const char* kKeys[] = {"value", "absolute", "relative", "source", "note"};
constexpr const char* kMeasured = "measured";
constexpr const char* kPublished = "published";

std::optional<std::string> read_text(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string number(double v) { return fmt::format("{:.10g}", v); }

Tolerance tolerance_of(const Json& entry) {
  return {entry.value("absolute", 0.0), entry.value("relative", 0.0)};
}

std::string describe(const Tolerance& t) {
  std::string s;
  if (t.absolute > 0 || t.relative == 0) s = "absolute " + number(t.absolute);
  if (t.relative > 0) s += (s.empty() ? "" : ", ") + std::string("relative ") + number(t.relative);
  return s;
}

std::string entry_problems(const std::string& name, const Json& e) {
  if (!e.is_object()) return name + ": not an object of value, tolerance, source and note\n";
  std::string p;
  for (const auto& [key, v] : e.items())
    if (std::find(std::begin(kKeys), std::end(kKeys), key) == std::end(kKeys))
      p += name + ": unknown key \"" + key + "\" (the keys are value, absolute, relative, source, note)\n";
  if (!e.contains("value") || !e["value"].is_number() || !std::isfinite(e["value"].get<double>()))
    p += name + ": no finite number \"value\"\n";
  if (!e.contains("absolute") && !e.contains("relative")) p += name + ": no tolerance (\"absolute\" and/or \"relative\")\n";
  for (const char* key : {"absolute", "relative"})
    if (e.contains(key) && (!e[key].is_number() || !(e[key].get<double>() >= 0) || !std::isfinite(e[key].get<double>())))
      p += name + ": \"" + key + "\" must be a finite number >= 0\n";
  if (!e.contains("source") || (e["source"] != kMeasured && e["source"] != kPublished))
    p += name + ": \"source\" must be \"measured\" (regenerated from our runs) or \"published\" (never rewritten)\n";
  if (!e.contains("note") || !e["note"].is_string() || e["note"].get<std::string>().empty())
    p += name + ": no \"note\" saying what it is and how it was obtained\n";
  return p;
}

std::string problems_of(const Json& j) {
  if (j.is_discarded()) return "not valid JSON\n";
  if (!j.is_object()) return "not a JSON object of named quantities\n";
  std::string p;
  for (const auto& [name, e] : j.items()) p += entry_problems(name, e);
  return p;
}

std::string text_of(const Json& j) { return j.dump(2) + "\n"; }

/// `measured` to the significant digits that resolve a thousandth of its tolerance: regenerated
/// values read as figures, not as 17 digits of rounding.
double rounded(double measured, double allowed) {
  if (measured == 0 || allowed == 0) return measured;
  const int digits = std::clamp(int(std::floor(std::log10(std::abs(measured)))) - int(std::floor(std::log10(allowed / 1000))) + 1, 1, 17);
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.*e", digits - 1, measured);
  return std::strtod(buf, nullptr);
}

/// Regenerating tests of one suite may run side by side (ctest -j): each read-modify-write of a
/// file holds an exclusive lock on its folder, and the new text replaces the file by a rename.
class FolderLock {
 public:
  explicit FolderLock(const std::filesystem::path& folder) : fd_(::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC)) {
    if (fd_ < 0 || ::flock(fd_, LOCK_EX) != 0) throw std::runtime_error("cannot lock " + folder.string());
  }
  ~FolderLock() { ::close(fd_); }
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;

 private:
  int fd_;
};

void write_text(const std::filesystem::path& file, const std::string& text) {
  const std::filesystem::path tmp = file.parent_path() / fmt::format(".{}.tmp-{}", file.filename().string(), ::getpid());
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << text;
    if (!out.flush()) throw std::runtime_error("cannot write " + tmp.string());
  }
  std::filesystem::rename(tmp, file);
}

Golden::Mode mode_from_environment() {
  const char* v = std::getenv(kRegenerateGolden);
  if (v == nullptr || std::string(v).empty() || std::string(v) == "0") return Golden::Mode::check;
  if (std::string(v) == "1") return Golden::Mode::regenerate;
  throw std::runtime_error(std::string(kRegenerateGolden) + "=" + v + ": set it to 1 to regenerate, or leave it unset");
}

}  // namespace

double Tolerance::allowed(double reference) const { return std::max(absolute, relative * std::abs(reference)); }

Golden::Golden(const std::string& suite)
    : Golden(std::filesystem::path(GRAINTWIN_TEST_DATA) / (suite + ".json"), mode_from_environment()) {}

Golden::Golden(std::filesystem::path file, Mode mode) : file_(std::move(file)), mode_(mode) {}

bool Golden::check(const std::string& name, double measured, std::source_location where) {
  return run_check(name, measured, std::nullopt, where);
}

bool Golden::check(const std::string& name, double measured, const NewReference& create, std::source_location where) {
  return run_check(name, measured, create, where);
}

bool Golden::run_check(const std::string& name, double measured, const std::optional<NewReference>& create,
                       std::source_location where) {
  const auto fail = [&](const std::string& message) {
    ADD_FAILURE_AT(where.file_name(), int(where.line())) << file_.string() << ": " << name << ": " << message;
    return false;
  };
  const bool regenerate = mode_ == Mode::regenerate;
  if (regenerate) std::filesystem::create_directories(file_.parent_path());
  std::optional<FolderLock> lock;
  if (regenerate) lock.emplace(file_.parent_path());
  const std::optional<std::string> text = read_text(file_);
  if (!text && !regenerate)
    return fail("no such file; create it with " + std::string(kRegenerateGolden) + "=1 (docs/testing.md)");
  Json j = text ? Json::parse(*text, nullptr, false) : Json::object();
  if (const std::string p = problems_of(j); !p.empty()) return fail("the file is damaged, fix it by hand:\n" + p);
  if (!std::isfinite(measured)) return fail("measured " + number(measured) + ", not a finite number");

  if (!j.contains(name)) {
    if (!regenerate) return fail("no reference of this name; add it with " + std::string(kRegenerateGolden) + "=1 (docs/testing.md)");
    if (!create) return fail("a new reference needs its tolerance and note, in the file or in the test's call");
    Json e = Json::object();
    e["value"] = rounded(measured, create->tolerance.allowed(measured));
    if (create->tolerance.absolute > 0 || create->tolerance.relative == 0) e["absolute"] = create->tolerance.absolute;
    if (create->tolerance.relative > 0) e["relative"] = create->tolerance.relative;
    e["source"] = kMeasured;
    e["note"] = create->note;
    if (const std::string p = entry_problems(name, e); !p.empty()) return fail("not created: " + p);
    j[name] = e;
    write_text(file_, text_of(j));
    return fail("regenerated: created with value " + number(e["value"].get<double>()) + "; review `git diff " +
                file_.filename().string() + "` and run again without " + kRegenerateGolden);
  }

  Json& e = j[name];
  const Tolerance tolerance = tolerance_of(e);
  const double value = e["value"].get<double>();
  if (create && !(create->tolerance == tolerance))
    return fail("the test gives tolerance " + describe(create->tolerance) + ", the file " + describe(tolerance) +
                "; keep one (the file's)");
  if (regenerate && e["source"] == kMeasured) {
    const double now = rounded(measured, tolerance.allowed(measured));
    if (now == value) return true;
    e["value"] = now;
    write_text(file_, text_of(j));
    return fail("regenerated: " + number(now) + " (was " + number(value) + ", tolerance " + describe(tolerance) +
                "); review `git diff " + file_.filename().string() + "` and run again without " + kRegenerateGolden);
  }
  const double allowed = tolerance.allowed(value);
  if (std::abs(measured - value) <= allowed) return true;
  std::string message = number(measured) + " measured, " + number(value) + " expected, tolerance " + number(allowed) +
                        " (" + describe(tolerance) + "; " + e["note"].get<std::string>() + ")";
  if (e["source"] == kMeasured)
    message += "; if the change is meant, regenerate with " + std::string(kRegenerateGolden) +
               "=1 and review the diff of tests/data (docs/testing.md)";
  return fail(message);
}

std::string golden_file_problems(const std::string& text) { return problems_of(Json::parse(text, nullptr, false)); }

std::string canonical_golden_text(const std::string& text) { return text_of(Json::parse(text, nullptr, false)); }

}  // namespace graintwin::test
