#pragma once
// Reference numbers kept beside the tests, one JSON file per suite (tests/data/<suite>.json): per
// named quantity its value, its tolerance and a one-line note of what it is and how it was
// obtained. A measured reference (a figure a run of our own code gave) can be regenerated: with
// GRAINTWIN_REGENERATE_GOLDEN=1 a check writes the measured value into the file and fails, naming
// what it rewrote, so that the change is reviewed as a diff of tests/data and the next run, without
// the switch, checks it. A published reference (a figure from the literature) is never rewritten.
// docs/testing.md describes the workflow.
//
// File format (keys of an entry in this order; the writer keeps the file's order of entries):
//   { "<quantity>": { "value": 1.0392, "relative": 0.001, "source": "measured",
//                     "note": "what it is, how it was obtained" }, ... }
// "absolute" and/or "relative" give the tolerance: a measured value passes when
// |measured - value| <= max(absolute, relative * |value|).
#include <filesystem>
#include <optional>
#include <source_location>
#include <string>

namespace graintwin::test {

/// How far a measured value may lie from its reference: max(absolute, relative * |reference|).
struct Tolerance {
  double absolute = 0.0;
  double relative = 0.0;

  double allowed(double reference) const;
  bool operator==(const Tolerance&) const = default;
};

/// A measured reference a test creates when regenerating and its file lacks it.
struct NewReference {
  Tolerance tolerance;
  std::string note;
};

/// The environment variable that switches regeneration on (value 1).
inline constexpr const char* kRegenerateGolden = "GRAINTWIN_REGENERATE_GOLDEN";

class Golden {
 public:
  enum class Mode { check, regenerate };

  /// The suite's file tests/data/<suite>.json, in the mode GRAINTWIN_REGENERATE_GOLDEN sets.
  explicit Golden(const std::string& suite);
  /// Any file, in the given mode.
  Golden(std::filesystem::path file, Mode mode);

  /// Like EXPECT_NEAR against the stored reference: a non-fatal gtest failure, at the caller's
  /// line, that names the quantity, the measured and expected values, the tolerance and the
  /// file. When regenerating, a measured reference is rewritten instead (and the check fails
  /// saying so) unless the value stored is already the one measured. Returns whether it passed.
  bool check(const std::string& name, double measured,
             std::source_location where = std::source_location::current());
  /// The same, where the test states the tolerance and note a new entry gets when regenerating;
  /// an existing entry must carry the same tolerance (one definition of it).
  bool check(const std::string& name, double measured, const NewReference& create,
             std::source_location where = std::source_location::current());

  const std::filesystem::path& file() const { return file_; }
  Mode mode() const { return mode_; }

 private:
  bool run_check(const std::string& name, double measured, const std::optional<NewReference>& create,
                 std::source_location where);

  std::filesystem::path file_;
  Mode mode_;
};

/// The problems of a golden file's text (not JSON, an entry without a value, tolerance, source or
/// note, an unknown key, a negative tolerance), one per line; empty when it is sound.
std::string golden_file_problems(const std::string& text);
/// The text the writer gives the file's content: a regeneration's diff shows only what changed
/// if the stored files are in this form.
std::string canonical_golden_text(const std::string& text);

}  // namespace graintwin::test
