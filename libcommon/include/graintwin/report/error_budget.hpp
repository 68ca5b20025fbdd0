#pragma once
// The report's "Error budget" section: one line per item of validate's error budget
// (validation.json, read by validate's reader), each with one number and one chart, or one
// sentence saying why the line is empty (the stage did not run, the loading was prescribed).
#include <optional>
#include <string>
#include <vector>

#include "graintwin/report/charts.hpp"
#include "graintwin/validate/validation_file.hpp"

namespace graintwin::report {

struct BudgetLine {
  std::string id;           ///< HTML anchor and PNG stem
  std::string title;
  std::string value;        ///< the line's one number, with its unit ("n/a" when the line is empty)
  std::string description;  ///< what the number and the chart are
  std::optional<Chart> chart;
  std::string missing;      ///< why there is no chart (set exactly when chart is empty)
};

/// What the section says when the run has no validation.json.
inline constexpr const char* kNoValidation =
    "This run has no validation.json: the validate stage makes it for a ctsynth series, whose ground truth (truth_NNN.h5) "
    "it scores every stage against; a series without truth (a real scan such as soil_crop) has no error budget.";

/// Every line of the budget, in page order (the lines of validate/scores).
std::vector<BudgetLine> error_budget(const validate::Validation& validation);

/// P(X <= x) of a sample: one point per value, ascending, at (k + 1) / n; values multiplied by `x_scale`.
Series cdf_series(const std::vector<double>& values, std::string name, double x_scale = 1.0);

}  // namespace graintwin::report
