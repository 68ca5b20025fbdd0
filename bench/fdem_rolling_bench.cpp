// fdem_rolling_bench: a meshed sphere rolling on a rigid plane under gravity (fdem/rolling.hpp):
// when does a faceted sphere keep its contact (roll) and when does it hop from vertex to vertex,
// and how close is its rotation x R to the distance it travels? Ottawa-sand sphere R = 0.5 mm,
// friction 0.5, p_n = 10 E / h, stable step, one thread, a quarter turn from rolling without slip.
// Swept: the speed as v^2 / (g R) (the share of the pivots' centripetal demand g carries), the mesh
// as R / h, the contact damping ratio beta (restitution 0.91 at 0.03, 0.05 at 0.7) and the kind
// (rigid, tet4). The sweep runs at E / 1000, which changes the step and not the outcome (one case at
// the real E shows it). Publishes docs/benchmarks.md, section fdem_rolling_bench, and two charts:
// docs/img/fdem_rolling_airborne.png (share of steps without contact against the speed) and
// docs/img/fdem_rolling_accuracy.png (rolling error against the cost, per mesh size).
// usage: fdem_rolling_bench [--quick] [--work DIR]
#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "graintwin/fdem/rolling.hpp"
#include "graintwin/mesh/ellipsoid_grain.hpp"
#include "harness.hpp"

using namespace graintwin;
using namespace graintwin::fdem;

namespace {

const std::string kSource = GRAINTWIN_SOURCE_DIR;
constexpr double kRadius = 0.5e-3, kGravity = 9.81;

struct Case {
  GrainKind kind;
  double cells;         ///< R / h
  double froude;        ///< v^2 / (g R)
  double beta;          ///< contact damping ratio
  double stiffness = 1e-3;  ///< E over Ottawa sand's
};

std::string kind_name(GrainKind k) { return k == GrainKind::rigid ? "rigid" : k == GrainKind::tet4 ? "tet4" : "tet10"; }

}  // namespace

int main(int argc, char** argv) {
  bool quick = false;
  std::filesystem::path work = kSource + "/bench/out/fdem_rolling";
  if (!bench::parse_quick_work(argc, argv, quick, work)) {
    std::cerr << "usage: fdem_rolling_bench [--quick] [--work DIR]\n";
    return 2;
  }
  std::filesystem::create_directories(work);
  std::vector<Case> cases;
  const std::vector<double> froudes = quick ? std::vector<double>{0.005, 0.08} : std::vector<double>{0.002, 0.005, 0.02, 0.08};
  for (double cells : quick ? std::vector<double>{4} : std::vector<double>{4, 8, 12})
    for (double beta : {0.03, 0.7})
      for (double froude : froudes) cases.push_back({GrainKind::rigid, cells, froude, beta});
  if (!quick) {
    // A deformable sphere's step is its elements' (10 to 30 times shorter): the two corners only.
    cases.push_back({GrainKind::tet4, 4, 0.005, 0.7});
    cases.push_back({GrainKind::tet4, 4, 0.08, 0.03});
    cases.push_back({GrainKind::rigid, 8, 0.08, 0.03, 1.0});  // the real stiffness
    cases.push_back({GrainKind::rigid, 8, 0.005, 0.7, 1.0});
  }

  bench::Report report(
      "fdem_rolling_bench", "fdemrun: a meshed sphere rolling on a plane",
      "Ottawa-sand sphere R = 0.5 mm (rho 2650, nu 0.118, friction 0.5) meshed by gmsh at a uniform size h, set on a "
      "rigid plane at its lowest node and started rolling without slip along x at speed v under g = 9.81 m/s^2; p_n = "
      "p_t = 10 E / h; stable step; one thread; a quarter turn. E is Ottawa sand's 92.1 GPa / 1000 unless the case says "
      "E x 1 (the outcome does not depend on it: compare the pairs). Contact: the share of steps with a normal force on "
      "the plane (target at least 95 %); rolling: rotation x R / distance (target within 1 %); rise: the highest the "
      "centroid rose; pivot rise: h_med^2 / (8 R); static overlap: m g / k of one surface node. Charts "
      "docs/img/fdem_rolling_airborne.png and docs/img/fdem_rolling_accuracy.png.");
  std::ofstream airborne(work / "airborne.csv"), accuracy(work / "accuracy.csv");
  airborne << "series,label,x,y\n";
  accuracy << "series,label,x,y\n";
  for (const Case& c : cases) {
    RollingSetup s;
    s.material.young *= c.stiffness;
    s.material.damping_ratio = c.beta;
    s.radius = kRadius;
    s.element_size = kRadius / c.cells;
    s.kind = c.kind;
    s.gravity = kGravity;
    s.speed = std::sqrt(c.froude * kGravity * kRadius);
    s.turns = 0.25;
    const RollingOutcome r = run_rolling(s, mesh::append_ellipsoid_grain);
    const std::string name = fmt::format("{}, R/h = {:g}, v^2/(gR) = {:g} (v = {:.3g} mm/s), beta = {:g}{}", kind_name(c.kind),
                                         c.cells, c.froude, 1e3 * s.speed, c.beta, c.stiffness == 1 ? ", E x 1" : "");
    const std::string note = fmt::format(
        "{} elements, {} steps of {:.3g} ns; contact {:.1f} % of steps; rolling {:.4f}; speed at the end {:.3f} v; rise "
        "{:.3g} um; pivot rise {:.3g} um; static overlap {:.3g} um; mesh centroid {:.3g} um off the centre",
        r.elements, r.steps, 1e9 * r.time_step, 100 * r.contact_share, r.rolling_ratio, r.speed_ratio, 1e6 * r.largest_rise,
        1e6 * r.pivot_rise, 1e6 * r.static_overlap, 1e6 * r.centroid_offset);
    std::printf("%s: %s (%.1f s)\n", name.c_str(), note.c_str(), r.seconds);
    std::fflush(stdout);
    report.add({name, "graintwin, 1 thread", r.seconds, 0, note});
    if (c.stiffness != 1) {
      // Log axes: a share of 0 is drawn at 0.1 %.
      airborne << fmt::format("{} R/h {:g} beta {:g},{:g},{},{}\n", kind_name(c.kind), c.cells, c.beta, c.cells, c.froude,
                              std::max(0.1, 100 * (1 - r.contact_share)));
      if (c.froude == 0.005)
        accuracy << fmt::format("{} beta {:g},R/h {:g},{},{}\n", kind_name(c.kind), c.beta, c.cells,
                                r.seconds / s.turns, std::max(1e-3, 100 * std::abs(r.rolling_ratio - 1)));
    }
  }
  airborne.close();
  accuracy.close();
  if (!quick) {
    bench::plot_xy(work / "airborne.csv", kSource + "/docs/img/fdem_rolling_airborne.png",
                   "sphere R = 0.5 mm rolling on a plane: steps without contact", "v^2 / (g R)", "steps without contact, %");
    bench::plot_xy(work / "accuracy.csv", kSource + "/docs/img/fdem_rolling_accuracy.png",
                   "rolling at v^2/(gR) = 0.005: |rotation R / distance - 1|", "seconds per turn (1 thread)", "error, %");
    report.publish("graintwin, 1 thread", kSource + "/docs/benchmarks.md");
  }
}
