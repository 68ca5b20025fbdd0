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

/// Why a chart is missing when a stage has not run (panels and the error budget say the same).
inline constexpr const char* kNoSimulation =
    "This run has no simulation results (simulation.h5, kind=fdem_results): the pipeline's simulate stage (fdemrun) makes them.";
inline constexpr const char* kCtNoForces = "CT scans do not measure contact forces: this chart exists for the simulation only.";
inline constexpr const char* kNoSimulationMicro =
    "This run has no micro-mechanics of the simulation frames (simulation_micro.h5): tracks2micro on simulation.h5 makes it.";
inline constexpr const char* kNoMicro =
    "This run has no micro-mechanics of the scans (micro.h5): the micro stage (tracks2micro) makes it from two scans or more.";
inline constexpr const char* kNoContacts =
    "This run has no contacts files (scan_*/contacts.h5): the contacts stage (labels2contacts) makes them.";
inline constexpr const char* kNoModel =
    "This run has no FDEM model (model.h5): the mesh stage (shapes2mesh) makes the grain surfaces the twin's pictures show.";
inline constexpr const char* kNoShapes = "This run has no shapes files (scan_*/shapes.h5): the shapes stage (labels2shapes) makes them.";

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
