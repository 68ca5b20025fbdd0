// fdemrun_verify_bench (the longer contact checks), elastic spheres meshed fine only
// at the touching pole (fdem::SizeGrading), stable time step, one thread, no contact damping:
//  1. Hertz: glass sphere R = 1 mm (E = 48 GPa, nu = 0.2, rho = 2500) at 1 m/s onto a rigid wall;
//     contact time, peak force and approach against Hertz over the element size at the pole (in
//     units of the Hertz contact radius a) and over the normal penalty p_n (the default 100 E per
//     metre, and 1 / 10 / 100 x E / h, h the element size at the pole). Chart: error against cost.
//  2. Chung & Ooi (2011) test 1: two glass spheres R = 10 mm (E = 48 GPa, nu = 0.2, rho = 2800) at
//     +-10 m/s: max overlap 274 um, peak force 10.7 kN, duration 40.3 us (Hertz).
//  3. Test 2: aluminium-alloy sphere R = 0.1 m (E = 70 GPa, nu = 0.33, rho = 2699) at 0.2 m/s onto a
//     rigid wall: 49.3 um, 11.5 kN, 726 us.
//  4. Test 6: the test-2 sphere with spin onto the wall, mu = 0.4: tangential restitution of the
//     contact point against the sliding solution beta = -1 + 3.5 mu (1 + e) v_n / v_ct where the
//     contact point slides throughout (Coulomb, exact for any normal law; e measured).
//  5. Test 7: two test-2 spheres at +-0.2 m/s spinning so their contact points move together, mu = 0.4:
//     by symmetry no tangential force, so the tangential velocity stays 0 and the spin unchanged.
// Parts 1 and 2-5 publish their own docs/benchmarks.md sections (not with --quick); 2-5 write
// WORK/chung_ooi.csv, read by bench/fdem_crosscheck.py (LIGGGHTS side by side).
// usage: fdemrun_verify_bench [--quick] [--work DIR] [--part hertz|chung-ooi]
#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <string>

#include "graintwin/mesh/ellipsoid_grain.hpp"
#include "graintwin/fdem/impact.hpp"
#include "harness.hpp"

using namespace graintwin;
using namespace graintwin::fdem;

namespace {

const std::string kSource = GRAINTWIN_SOURCE_DIR;
const Material kHertzGlass{"glass", 2500, 48e9, 0.2, 0.0, 0.0, 0.0, 0.0};
const Material kChungGlass{"glass", 2800, 48e9, 0.2, 0.0, 0.0, 0.0, 0.0};
const Material kAluminium{"aluminium_alloy", 2699, 70e9, 0.33, 0.4, 0.0, 0.0, 0.0};

ImpactOutcome impact(const ImpactSetup& setup) { return run_impact(setup, mesh::append_graded_ellipsoid_grain); }

/// The Hertz contact radius a = sqrt(R* delta_max) of a setup (exact mass), m.
double contact_radius(const ImpactSetup& s) {
  const int n = s.two_spheres ? 2 : 1;
  const double mass = 4.0 / 3.0 * M_PI * std::pow(s.radius, 3) * s.material.density;
  const double e_star = s.material.young / (1 - s.material.poisson * s.material.poisson) / n;
  return std::sqrt(s.radius / n * hertz_impact(mass / n, s.radius / n, e_star, n * s.speed).max_approach);
}

/// The setup meshed at `cells` elements per Hertz contact radius at the pole, growing by 0.1 up to
/// R / 4.
ImpactSetup graded(ImpactSetup s, double cells) {
  s.fine = contact_radius(s) / cells;
  s.growth = 0.1;
  s.coarse = s.radius / 4;
  return s;
}

double ratio_error(double measured, double exact) { return std::abs(measured / exact - 1); }

std::string penalty_name(const ImpactSetup& s) {
  return s.penalty_per_size > 0 ? fmt::format("p_n = {:g} E/h", s.penalty_per_size) : "p_n = 100 E/m (the default)";
}

struct Writer {
  bench::Report hertz, chung_ooi;  ///< one docs/benchmarks.md section per part
  std::ofstream csv;               ///< Chung & Ooi figures for bench/fdem_crosscheck.py
  std::ofstream chart;             ///< Hertz error against elements
};

/// One normal impact: prints, adds a report row and the CSV rows of a Chung & Ooi test.
ImpactOutcome normal_case(Writer& w, const std::string& name, const ImpactSetup& s, const std::string& test) {
  const ImpactOutcome r = impact(s);
  const double e = r.velocity_after.z() / s.speed;
  const std::string note = fmt::format(
      "{} elements, {} steps of {:.3g} ns, h = {:.3g} um at the pole (a / {:.2g}), {}: overlap {:.4g} um (Hertz {:.4g}, "
      "{:+.1f} %), F_max {:.4g} N (Hertz {:.4g}, {:+.1f} %), t_c {:.4g} us (Hertz {:.4g}, {:+.1f} %), rebound e = {:.4f}",
      r.elements, r.steps, 1e9 * r.time_step, 1e6 * s.fine, contact_radius(s) / s.fine, penalty_name(s),
      1e6 * r.max_approach, 1e6 * r.hertz.max_approach, 100 * (r.max_approach / r.hertz.max_approach - 1), r.peak_force,
      r.hertz.peak_force, 100 * (r.peak_force / r.hertz.peak_force - 1), 1e6 * r.contact_time, 1e6 * r.hertz.contact_time,
      100 * (r.contact_time / r.hertz.contact_time - 1), e);
  std::printf("%s: %s (%.1f s)\n", name.c_str(), note.c_str(), r.seconds);
  std::fflush(stdout);
  (name.rfind("Hertz", 0) == 0 ? w.hertz : w.chung_ooi).add({name, "graintwin, 1 thread", r.seconds, 0, note});
  if (!test.empty()) {
    w.csv << fmt::format("{},max_overlap_um,{},{}\n", test, 1e6 * r.max_approach, 1e6 * r.hertz.max_approach);
    w.csv << fmt::format("{},peak_force_N,{},{}\n", test, r.peak_force, r.hertz.peak_force);
    w.csv << fmt::format("{},contact_time_us,{},{}\n", test, 1e6 * r.contact_time, 1e6 * r.hertz.contact_time);
    w.csv << fmt::format("{},restitution,{},1\n", test, e);
    w.csv << fmt::format("{},seconds,{},\n", test, r.seconds);
    w.csv.flush();
  }
  return r;
}

void hertz_study(Writer& w, bool quick) {
  ImpactSetup s;
  s.material = kHertzGlass;
  s.radius = 1e-3;
  s.speed = 1.0;
  // Runs one case and adds its point to each chart series given as (series, label).
  using Points = std::vector<std::pair<std::string, std::string>>;
  const auto run = [&](const ImpactSetup& c, const Points& points) {
    const ImpactOutcome r = normal_case(w,
                                        fmt::format("Hertz, R = 1 mm, {}, h = a/{:.0f} growing by {:g}, {}", c.kind == GrainKind::tet4 ? "tet4" : "tet10",
                                                    contact_radius(c) / c.fine, c.growth, penalty_name(c)),
                                        c, "");
    const double error = 100 * std::max(ratio_error(r.contact_time, r.hertz.contact_time), ratio_error(r.peak_force, r.hertz.peak_force));
    for (const auto& [series, label] : points) w.chart << fmt::format("{},{},{},{}\n", series, label, r.elements, std::max(error, 0.01));
  };
  // The size at the pole: a, a/2 (in the growth loop below), a/4, growing by 0.1.
  const auto pole_size = [&](double cells) {
    ImpactSetup c = graded(s, cells);
    c.growth = 0.1;
    run(c, {{"tet4 growth 0.1", fmt::format("a/{:g}", cells)}});
  };
  if (!quick) pole_size(1);
  // The growth rate of the element size away from the pole (the field of a contact decays like
  // 1/r, so every scale up to R counts), then the size at the pole.
  for (double growth : quick ? std::vector<double>{0.15} : std::vector<double>{0.3, 0.2, 0.15, 0.1, 0.07}) {
    ImpactSetup c = graded(s, 2);
    c.growth = growth;
    Points points{{"tet4 h = a/2 at the pole", fmt::format("growth {:g}", growth)}};
    if (growth == 0.1) points.push_back({"tet4 growth 0.1", "a/2"});
    run(c, points);
  }
  if (quick) return;
  pole_size(4);
  // The penalty at a/2, growth 0.1: the default absolute 100 E per metre, then per element size.
  for (double factor : {0.0, 1.0, 100.0}) {
    ImpactSetup c = graded(s, 2);
    c.growth = 0.1;
    c.penalty_per_size = factor;
    c.material.normal_penalty = c.material.tangential_penalty = 100 * c.material.young;
    run(c, {});
  }
  for (double growth : {0.3, 0.15}) {
    ImpactSetup c = graded(s, 1);
    c.kind = GrainKind::tet10;
    c.growth = growth;
    run(c, {{"tet10 h = a at the pole", fmt::format("growth {:g}", growth)}});
  }
}

void chung_ooi_normal(Writer& w, bool quick) {
  // 10-node elements of the contact radius at the poles (within 1 % of Hertz on the 1 mm sphere);
  // test 1 also with 4-node ones at a/2 for comparison.
  const auto ten_node = [](ImpactSetup s) {
    s = graded(s, 1);
    s.kind = GrainKind::tet10;
    s.growth = 0.15;
    return s;
  };
  ImpactSetup t1;
  t1.material = kChungGlass;
  t1.radius = 10e-3;
  t1.speed = 10.0;
  t1.two_spheres = true;
  normal_case(w, "Chung & Ooi test 1, glass R = 10 mm at +-10 m/s, two spheres, tet10, h = a growing by 0.15", ten_node(t1), "test1_glass");
  if (!quick)
    normal_case(w, "Chung & Ooi test 1, glass R = 10 mm at +-10 m/s, two spheres, tet4, h = a/2 growing by 0.1", graded(t1, 2), "");
  ImpactSetup t2;
  t2.material = kAluminium;
  t2.material.friction = 0;
  t2.radius = 0.1;
  t2.speed = 0.2;
  normal_case(w, "Chung & Ooi test 2, Al alloy R = 0.1 m at 0.2 m/s on a wall, tet10, h = a growing by 0.15", ten_node(t2), "test2_al_alloy");
}

/// Tests 6 and 7: spin about y; the upper sphere's contact point (at -R z) moves at v_x - omega_y R.
void chung_ooi_spin(Writer& w, bool quick) {
  ImpactSetup s;
  s.material = kAluminium;
  s.radius = 0.1;
  s.speed = 0.2;
  const double mu = s.material.friction, R = s.radius, vn = s.speed;
  for (double omega : quick ? std::vector<double>{14} : std::vector<double>{1, 4, 8, 14, 21}) {
    ImpactSetup c = graded(s, 2);
    c.growth = 0.15;  // the sliding solution does not depend on the normal law
    c.spin = Eigen::Vector3d(0, omega, 0);
    const ImpactOutcome r = impact(c);
    const double e = r.velocity_after.z() / vn;
    const double v_ct = omega * R, v_ct_after = -(r.velocity_after.x() - r.spin_after.y() * R);
    const double beta = -v_ct_after / v_ct, sliding = sliding_tangential_restitution(mu, e, vn, v_ct);
    const double impulse_ratio = r.velocity_after.x() / (mu * (1 + e) * vn);  // tangential / (mu x normal) impulse
    const bool slides = sliding < 0;
    const std::string note = fmt::format(
        "{} elements, {} steps; e = {:.4f}; beta = {:.4f} ({}: {:.4f}); tangential / (mu normal) impulse {:.4f}; spin after {:.4f} "
        "rad/s (sliding: {:.4f}; with the mesh's lumped inertia, {:.4f} x 2/5 m R^2: {:.4f}); rebound angle of the contact point {:.2f} deg",
        r.elements, r.steps, e, beta, slides ? "sliding solution" : "contact point stops; rigid no-slip limit 0", slides ? sliding : 0.0,
        impulse_ratio, r.spin_after.y(), omega - 2.5 * mu * (1 + e) * vn / R, r.inertia_ratio,
        omega - 2.5 * mu * (1 + e) * vn / R / r.inertia_ratio, std::atan2(v_ct_after, r.velocity_after.z()) * 180 / M_PI);
    const std::string name = fmt::format("Chung & Ooi test 6, Al alloy at 0.2 m/s, spin {:g} rad/s (v_ct / v_n = {:.2g}), h = a/{:.0f} growing by {:g}",
                                         omega, v_ct / vn, contact_radius(c) / c.fine, c.growth);
    std::printf("%s: %s (%.1f s)\n", name.c_str(), note.c_str(), r.seconds);
    std::fflush(stdout);
    w.chung_ooi.add({name, "graintwin, 1 thread", r.seconds, 0, note});
    w.csv << fmt::format("test6_spin_{:g},beta,{},{}\n", omega, beta, slides ? fmt::format("{}", sliding) : "");
    w.csv << fmt::format("test6_spin_{:g},spin_after_rad_s,{},{}\n", omega, r.spin_after.y(),
                         slides ? fmt::format("{}", omega - 2.5 * mu * (1 + e) * vn / R) : "");
    w.csv << fmt::format("test6_spin_{:g},restitution,{},\n", omega, e);
    w.csv << fmt::format("test6_spin_{:g},seconds,{},\n", omega, r.seconds);
    w.csv.flush();
  }
  for (double omega : quick ? std::vector<double>{} : std::vector<double>{4, 21}) {
    ImpactSetup c = graded(s, 2);
    c.growth = 0.15;
    c.two_spheres = true;
    c.spin = Eigen::Vector3d(0, omega, 0);
    const ImpactOutcome r = impact(c);
    const std::string note = fmt::format(
        "{} elements, {} steps; tangential velocity after {:.3g} m/s (exact 0; v_n = 0.2), spin after {:.5f} rad/s (exact {:g}), "
        "e = {:.4f}, t_c {:.4g} us (Hertz {:.4g})",
        r.elements, r.steps, r.velocity_after.x(), r.spin_after.y(), omega, r.velocity_after.z() / vn, 1e6 * r.contact_time,
        1e6 * r.hertz.contact_time);
    const std::string name = fmt::format("Chung & Ooi test 7, two Al-alloy spheres at +-0.2 m/s, spin {:g} rad/s, h = a/{:.0f} growing by {:g}",
                                         omega, contact_radius(c) / c.fine, c.growth);
    std::printf("%s: %s (%.1f s)\n", name.c_str(), note.c_str(), r.seconds);
    std::fflush(stdout);
    w.chung_ooi.add({name, "graintwin, 1 thread", r.seconds, 0, note});
    w.csv << fmt::format("test7_spin_{:g},tangential_velocity_after_m_s,{},0\n", omega, r.velocity_after.x());
    w.csv << fmt::format("test7_spin_{:g},spin_after_rad_s,{},{}\n", omega, r.spin_after.y(), omega);
    w.csv << fmt::format("test7_spin_{:g},seconds,{},\n", omega, r.seconds);
    w.csv.flush();
  }
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false, hertz = true, chung_ooi = true;
  std::filesystem::path work = kSource + "/bench/out/fdemrun_verify";
  std::vector<char*> rest{argv[0]};
  for (int i = 1; i < argc; ++i)
    if (std::string(argv[i]) == "--part" && i + 1 < argc) {
      const std::string part = argv[++i];
      hertz = part == "hertz", chung_ooi = part == "chung-ooi";
    } else {
      rest.push_back(argv[i]);
    }
  if (!bench::parse_quick_work(static_cast<int>(rest.size()), rest.data(), quick, work) || (!hertz && !chung_ooi)) {
    std::cerr << "usage: fdemrun_verify_bench [--quick] [--work DIR] [--part hertz|chung-ooi]\n";
    return 2;
  }
  std::filesystem::create_directories(work);
  const std::string method =
      "Elastic spheres meshed by gmsh fine at the touching pole (size h there, growing linearly with the distance up to "
      "R/4), density scaled so the mesh has the exact sphere mass, no contact damping, stable time step, one thread. h in "
      "units of the Hertz contact radius a; p_n = p_t. Time: the steps (meshing excluded). ";
  Writer w{bench::Report("fdemrun_verify_bench", "fdemrun: elastic sphere impact against Hertz, mesh grading and penalty",
                         method + "Glass sphere R = 1 mm (E = 48 GPa, nu = 0.2, rho = 2500) at 1 m/s onto a rigid wall. Target: "
                                  "contact time, peak force and overlap within 5 % of Hertz. Chart docs/img/fdemrun_hertz_accuracy.png."),
           bench::Report("fdemrun_verify_bench_chung_ooi", "fdemrun: Chung & Ooi (2011) tests 1, 2, 6, 7",
                         method + "Tests 1 and 2 against Hertz (5 %); test 6: the contact point's tangential restitution on the "
                                  "Coulomb sliding solution where it slides; test 7: tangential velocity 0 and spin unchanged. "
                                  "LIGGGHTS side by side: bench/fdem_crosscheck.py."),
           std::ofstream(work / "chung_ooi.csv"), std::ofstream(work / "hertz_accuracy.csv")};
  w.csv << "case,quantity,graintwin,reference\n";
  w.chart << "series,label,x,y\n";
  const std::filesystem::path benchmarks_md = kSource + "/docs/benchmarks.md";
  if (hertz) {
    hertz_study(w, quick);
    w.chart.close();
    if (!quick) {
      bench::plot_xy(work / "hertz_accuracy.csv", kSource + "/docs/img/fdemrun_hertz_accuracy.png",
                     "glass sphere R = 1 mm at 1 m/s: worst of t_c, F_max error vs Hertz", "elements", "error, %");
      w.hertz.publish("graintwin, 1 thread", benchmarks_md);
    }
  }
  if (chung_ooi) {
    chung_ooi_normal(w, quick);
    chung_ooi_spin(w, quick);
    std::cout << "wrote " << (work / "chung_ooi.csv").string() << "\n";
    if (!quick) w.chung_ooi.publish("graintwin, 1 thread", benchmarks_md);
  }
}
