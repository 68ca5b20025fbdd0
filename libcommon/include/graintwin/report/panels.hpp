#pragma once
// The report's panels: one per chart people expect (DESIGN.md, "Charts people expect"), each with
// the experiment's chart on the left and the simulation's on the right, or, where a side has no
// data, one plain sentence saying why and which stage makes them.
#include <optional>
#include <string>
#include <vector>

#include "graintwin/report/charts.hpp"
#include "graintwin/report/run_data.hpp"

namespace graintwin::report {

struct Side {
  std::optional<Chart> chart;
  std::string missing;  ///< why there is no chart (set exactly when chart is empty)
  std::string note;     ///< figures shown under the chart (fits, correlations)
};

struct Panel {
  std::string id;           ///< HTML anchor and PNG stem
  std::string title;
  std::string description;  ///< what the chart shows and where its numbers come from
  Side experiment, simulation;
};

struct PanelOptions {
  std::size_t max_series = 4;  ///< states, increments or frames drawn per chart (pick_evenly)
};

/// Every panel, in page order.
std::vector<Panel> build_panels(const ExperimentData& experiment, const SimulationData& simulation, const PanelOptions& options);

/// Every chart of `panels`, for the chart script.
std::vector<const Chart*> panel_charts(const std::vector<Panel>& panels);

}  // namespace graintwin::report
