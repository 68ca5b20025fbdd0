// report's stage (report/run_report): the page's default title and the run summary's rows, which
// name the stage that makes each file a run lacks.
#include <gtest/gtest.h>

#include "graintwin/report/run_report.hpp"

using namespace graintwin;
using namespace graintwin::report;

TEST(RunReport, TheTitleNamesTheRunFolderUnlessGiven) {
  EXPECT_EQ(report_title("runs/sand_small", ""), "Experiment against simulation: sand_small");
  EXPECT_EQ(report_title("runs/sand_small/", ""), "Experiment against simulation: sand_small");
  EXPECT_EQ(report_title("runs/sand_small", "My sand"), "My sand");
}

TEST(RunReport, TheSummaryNamesTheStageOfEveryMissingFile) {
  RunFiles files;
  ExperimentData e;
  e.scans.resize(1);
  e.scans[0].name = "scan_000";
  e.scans[0].grains = 12, e.scans[0].contacts = 30, e.scans[0].void_ratio = 0.61234;
  const SimulationData s;
  const auto rows = run_summary("runs/x", files, e, s);
  ASSERT_EQ(rows.size(), 9u);
  EXPECT_EQ(rows[0], (std::pair<std::string, std::string>{"run directory", "runs/x"}));
  EXPECT_EQ(rows[1], (std::pair<std::string, std::string>{"scan_000", "12 grains, 30 contacts, void ratio 0.6123"}));
  EXPECT_EQ(rows[2].second, "none (the track stage makes it)");
  EXPECT_EQ(rows[4].second, "none (the mesh stage makes it)");
  EXPECT_EQ(rows[5].second, "none (the simulate stage makes it)");
  EXPECT_EQ(rows[6].second, "none (tracks2micro on simulation.h5 makes it)");
  EXPECT_EQ(rows[7].second, "none (the forces stage makes it)");
  EXPECT_EQ(rows[8].second, "none (the validate stage makes it)");

  files.tracks = "runs/x/tracks.h5";
  files.model = "runs/x/model.h5";
  files.validation = "runs/x/validation.json";
  e.tracks = 10;
  const auto with = run_summary("runs/x", files, e, s);
  EXPECT_EQ(with[2].second, "10 tracks over 1 scans");
  EXPECT_EQ(with[4].second, "runs/x/model.h5");
  EXPECT_EQ(with[8].second, "runs/x/validation.json");
}
