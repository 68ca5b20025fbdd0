// The report module's helpers against exact answers: base64 and HTML escaping, the even pick of
// series, rose profiles, distributions and fitted curves, the error budget's CDF, log axes, and
// the benchmark charts found with their stage.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <random>

#include "graintwin/contacts/fabric.hpp"
#include "graintwin/report/charts.hpp"
#include "graintwin/report/page.hpp"
#include "support/run_tool.hpp"

using namespace graintwin;

TEST(ReportCharts, Base64AndEscapingFollowTheStandards) {
  EXPECT_EQ(report::base64(""), "");
  EXPECT_EQ(report::base64("f"), "Zg==");
  EXPECT_EQ(report::base64("fo"), "Zm8=");
  EXPECT_EQ(report::base64("foo"), "Zm9v");
  EXPECT_EQ(report::base64("foobar"), "Zm9vYmFy");
  EXPECT_EQ(report::base64(std::string("\xff\x00\x80", 3)), "/wCA");
  EXPECT_EQ(report::html_escape("a<b & \"c\" 'd'>"), "a&lt;b &amp; &quot;c&quot; &#39;d&#39;&gt;");
}

TEST(ReportCharts, PickEvenlyKeepsTheEnds) {
  EXPECT_EQ(report::pick_evenly(3, 4), (std::vector<std::size_t>{0, 1, 2}));
  EXPECT_EQ(report::pick_evenly(10, 4), (std::vector<std::size_t>{0, 3, 6, 9}));
  EXPECT_EQ(report::pick_evenly(10, 1), (std::vector<std::size_t>{9}));
  EXPECT_TRUE(report::pick_evenly(0, 4).empty());
}

TEST(ReportCharts, RoseProfileOfIsotropicDirectionsIsOneOverFourPi) {
  std::mt19937 rng(5);
  std::normal_distribution<double> g;
  std::vector<Vec3> d;
  for (int i = 0; i < 200000; ++i) d.push_back({g(rng), g(rng), g(rng)});
  const contacts::Rose r = contacts::rose(d, 6, 12);
  const report::Series s = report::rose_profile({r.theta_edges, r.phi_edges, r.counts, {}}, report::RoseValue::density, "iso");
  ASSERT_EQ(s.x.size(), 7u);
  EXPECT_DOUBLE_EQ(s.x.back(), 90.0);
  for (double v : s.y) EXPECT_NEAR(v, 1.0 / (4.0 * std::numbers::pi), 0.03 / (4.0 * std::numbers::pi));
  // Mean force per band weighs the bins by their counts.
  micro::ForceRose f{{0.0, std::numbers::pi / 2}, {0.0, std::numbers::pi, 2 * std::numbers::pi}, {1, 3}, {10.0, 2.0}};
  EXPECT_DOUBLE_EQ(report::rose_profile(f, report::RoseValue::mean_force, "f").y[0], (10.0 + 3 * 2.0) / 4.0);
}

TEST(ReportCharts, DistributionsAndFitCurves) {
  const report::Series c = report::ccdf_series({3, 1, 1, 2, 8, std::nan("")}, "s");
  EXPECT_EQ(c.x, (std::vector<double>{1, 2, 3, 8}));
  EXPECT_EQ(c.y, (std::vector<double>{1.0, 0.6, 0.4, 0.2}));
  // The fitted CCDF starts at the tail's share and falls as the Hurwitz zeta ratio (alpha 2: 1/s^2 sums).
  const report::Series p = report::power_law_ccdf(2.0, 2.0, 4.0, 30, 100, "fit");
  ASSERT_EQ(p.x.size(), 3u);
  EXPECT_DOUBLE_EQ(p.y[0], 0.3);
  EXPECT_NEAR(p.y[1], 0.3 * (std::pow(std::numbers::pi, 2) / 6 - 1.25) / (std::pow(std::numbers::pi, 2) / 6 - 1.0), 1e-12);
  // A line through points on R = 2 s^0.5 comes back exactly.
  const report::Series l = report::log_line_through_mean({2, 4, 8, 16}, {2 * std::sqrt(2.0), 4.0, 2 * std::sqrt(8.0), 8.0}, 0.5, "fit");
  EXPECT_NEAR(l.y[0], 2 * std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(l.y[1], 8.0, 1e-12);
  micro::Histogram h{{0.1, 1.0, 10.0}, {3, 1}, {1.0, 0.01}, 4, 0};
  EXPECT_DOUBLE_EQ(report::share_at_or_above(h, 1.0), 0.25);
  const report::Series pdf = report::pdf_series(h, true, "pdf");
  EXPECT_NEAR(pdf.x[0], std::sqrt(0.1), 1e-15);
  // The strong fit is the exponential tail scaled by its share: at f = 1 it is share / scale.
  EXPECT_NEAR(report::strong_force_fit(0.5, 0.25, 10.0, "s").y[0], 0.5, 1e-12);
  EXPECT_NEAR(report::weak_force_fit(0.5, 0.25, 0.01, "w").y.back(), 0.75 * 1.5, 1e-12);
}

TEST(ReportCharts, CdfOfTheErrorBudget) {
  const report::Series c = report::cdf_series({3, 1, std::nan(""), 2, 4}, "e", 10.0);
  EXPECT_EQ(c.x, (std::vector<double>{10, 20, 30, 40}));
  EXPECT_EQ(c.y, (std::vector<double>{0.25, 0.5, 0.75, 1.0}));
}

TEST(ReportCharts, LogAxesDropWhatTheyCannotShow) {
  report::Chart c;
  c.x_log = true;
  EXPECT_TRUE(c.add({"a", "line", {-1.0, 0.0, 2.0, std::nan("")}, {1.0, 2.0, 3.0, 4.0}, ""}));
  EXPECT_EQ(c.series[0].x, (std::vector<double>{2.0}));
  EXPECT_FALSE(c.add({"b", "line", {0.0}, {1.0}, ""}));
  EXPECT_EQ(c.series.size(), 1u);
}

TEST(ReportPage, BenchChartsAreFoundWithTheirStage) {
  test::TempDir d;
  for (const char* name : {"ct2labels_accuracy.png", "ctsynth_supersample.png", "ctsynth_supersample.csv", "shapes2mesh_preview.png",
                           "sand_small_sections.png", "fdem2forces_accuracy.png", "fdem_membrane_accuracy.png"})
    std::ofstream(d / name) << "x";
  const auto charts = report::find_bench_charts(d.path());
  ASSERT_EQ(charts.size(), 4u);
  EXPECT_EQ(charts[0].tool, "ctsynth");
  EXPECT_EQ(charts[1].stage, "segment");
  EXPECT_EQ(charts[2].stage, "simulate");
  EXPECT_EQ(charts[3].tool, "fdem2forces");
  EXPECT_EQ(charts[3].stage, "forces");
}
