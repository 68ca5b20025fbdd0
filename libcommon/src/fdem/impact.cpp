#include "graintwin/fdem/impact.hpp"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <chrono>
#include <cmath>
#include <numbers>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/element.hpp"
#include "graintwin/fdem/solver.hpp"

namespace graintwin::fdem {

HertzImpact hertz_impact(double mass, double radius, double modulus, double speed) {
  HertzImpact h;
  h.max_approach = std::pow(15 * mass * speed * speed / (16 * modulus * std::sqrt(radius)), 0.4);
  h.peak_force = 4.0 / 3.0 * modulus * std::sqrt(radius) * std::pow(h.max_approach, 1.5);
  h.contact_time = 2.868 * std::pow(mass * mass / (radius * modulus * modulus * speed), 0.2);
  return h;
}

double sliding_tangential_restitution(double mu, double e, double normal_speed, double tangential_speed) {
  return -1 + 3.5 * mu * (1 + e) * normal_speed / tangential_speed;
}

Eigen::Vector3d grain_angular_velocity(const Solver& solver, std::size_t grain) {
  const Grain& g = solver.model().grains.at(grain);
  const auto& x = solver.state().x;
  const auto& v = solver.state().v;
  const auto mass = solver.node_mass();
  const Eigen::Vector3d c = solver.grain_centroid(grain), vc = solver.grain_velocity(grain);
  Eigen::Vector3d momentum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();
  for (std::uint32_t i = g.node_begin; i < g.node_end; ++i) {
    const Eigen::Vector3d r = x[i] - c;
    momentum += mass[i] * r.cross(v[i] - vc);
    inertia += mass[i] * (r.squaredNorm() * Eigen::Matrix3d::Identity() - r * r.transpose());
  }
  return inertia.ldlt().solve(momentum);
}

namespace {

void check_setup(const ImpactSetup& s) {
  if (!(s.radius > 0) || !(s.speed > 0))
    throw UsageError(fmt::format("an impact needs a positive radius and speed (got {} m and {} m/s)", s.radius, s.speed));
  if (!(s.fine < s.radius) || !(s.coarse <= s.radius))
    throw UsageError(fmt::format("an impact's element sizes must be below the radius {} m (got fine {} m, coarse {} m)",
                                 s.radius, s.fine, s.coarse));
  if (s.penalty_per_size < 0) throw UsageError("an impact's penalty per element size cannot be negative");
}

}  // namespace

ImpactOutcome run_impact(const ImpactSetup& setup, const GradedGrainMesher& mesher) {
  check_setup(setup);
  const double R = setup.radius, gap = 0.01 * setup.fine;
  Material material = setup.material;
  if (setup.penalty_per_size > 0)
    material.normal_penalty = material.tangential_penalty = setup.penalty_per_size * material.young / setup.fine;
  Model model;
  model.materials.clear();
  const int spheres = setup.two_spheres ? 2 : 1;
  for (int k = 0; k < spheres; ++k) {
    const double side = k == 0 ? 1.0 : -1.0;  // upper sphere, then the lower one
    GrainSpec sphere;
    sphere.shape = PrimitiveShape::sphere;
    sphere.size = Eigen::Vector3d::Constant(R);
    sphere.position = Eigen::Vector3d(0, 0, side * (R + gap));
    sphere.element_size = setup.coarse;
    sphere.kind = setup.kind;
    sphere.material = static_cast<std::uint32_t>(k);
    sphere.label = static_cast<std::uint32_t>(k + 1);
    SizeGrading grading{{Eigen::Vector3d(0, 0, side * gap)}, setup.fine, setup.growth, setup.coarse};
    model.materials.push_back(material);
    mesher(model, sphere, grading);
    // Each sphere gets the density that gives its mesh the exact mass (a faceted 4-node sphere
    // lacks a few per cent of the volume, which would shift every Hertz figure by m^(2/5)).
    const double exact = 4.0 / 3.0 * std::numbers::pi * R * R * R;
    model.materials[k].density = material.density * exact / body_properties(model, k).volume;
  }
  if (!setup.two_spheres) model.platens = {Platen{"wall", Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), material.friction}};

  Solver s(model, SolverOptions{});
  s.set_grain_velocity(0, {0, 0, -setup.speed}, setup.spin);
  if (setup.two_spheres) s.set_grain_velocity(1, {0, 0, setup.speed}, -setup.spin);
  ImpactOutcome out;
  out.mass = 4.0 / 3.0 * std::numbers::pi * R * R * R * material.density;
  out.elements = model.element_count();
  out.nodes = model.nodes.size();
  out.time_step = s.time_step_limits().stable();
  {
    const Eigen::Vector3d c = s.grain_centroid(0);
    double inertia = 0;
    for (std::uint32_t i = model.grains[0].node_begin; i < model.grains[0].node_end; ++i) {
      const Eigen::Vector3d r = model.nodes[i] - c;
      inertia += s.node_mass()[i] * (r.x() * r.x() + r.z() * r.z());
    }
    out.inertia_ratio = inertia / (0.4 * out.mass * R * R);
  }
  const double e_star = material.young / (1 - material.poisson * material.poisson) / spheres;
  out.hertz = hertz_impact(out.mass / spheres, R / spheres, e_star, spheres * setup.speed);

  const auto normal_force = [&] {
    if (!setup.two_spheres) return -s.platen_force(0).z();
    for (const ContactRecord& r : s.contacts())
      if (r.a == 0 && r.b == 1) return r.force.dot(r.normal);
    return 0.0;
  };
  const auto centroid_distance = [&] {
    return setup.two_spheres ? s.grain_centroid(0).z() - s.grain_centroid(1).z() : s.grain_centroid(0).z();
  };
  // The approach counts from the step the contact starts: the lumped node masses of a graded mesh
  // put the mass centre slightly off the sphere's centre, so the geometric touching distance would
  // carry that offset.
  double touching = 0;
  std::int64_t first = -1, last = -1;
  const auto t0 = std::chrono::steady_clock::now();
  for (std::int64_t n = 0;; ++n) {
    if (n >= setup.max_steps)
      throw DataError(fmt::format("the impact was still in contact after {} steps of {:.3g} s; check the setup", n, out.time_step));
    s.step(out.time_step);
    out.steps = static_cast<std::size_t>(n + 1);
    const double f = normal_force();
    if (f > 0 && first < 0) first = n, touching = centroid_distance();
    if (first >= 0) out.max_approach = std::max(out.max_approach, touching - centroid_distance());
    if (f > 0) {
      out.peak_force = std::max(out.peak_force, f);
      last = n;
    } else if (first >= 0 && n - last > std::max<std::int64_t>(20, (last - first) / 4)) {
      break;
    }
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  out.contact_time = double(last - first + 1) * out.time_step;
  out.velocity_after = s.grain_velocity(0);
  out.spin_after = grain_angular_velocity(s, 0);
  return out;
}

}  // namespace graintwin::fdem
