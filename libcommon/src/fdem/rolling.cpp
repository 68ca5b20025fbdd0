#include "graintwin/fdem/rolling.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <unordered_set>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/element.hpp"
#include "graintwin/fdem/solver.hpp"

namespace graintwin::fdem {

namespace {

void check_setup(const RollingSetup& s) {
  if (!(s.radius > 0) || !(s.speed > 0) || !(s.turns > 0) || !(s.gravity > 0))
    throw UsageError(fmt::format("a rolling sphere needs a positive radius, speed, distance and gravity (got {} m, {} m/s, "
                                 "{} turns, {} m/s^2)", s.radius, s.speed, s.turns, s.gravity));
  if (!(s.element_size > 0) || !(s.element_size < s.radius))
    throw UsageError(fmt::format("a rolling sphere's element size must lie in (0, {} m), its radius (got {} m)", s.radius,
                                 s.element_size));
  if (!(s.penalty_per_size >= 0)) throw UsageError("a rolling sphere's penalty per element size cannot be negative");
}

std::size_t surface_node_count(const Model& model) {
  std::unordered_set<std::uint32_t> nodes;
  for (const auto& t : model.triangles) nodes.insert(t.begin(), t.end());
  return nodes.size();
}

}  // namespace

RollingOutcome run_rolling(const RollingSetup& setup, const CurvedGrainMesher& mesher) {
  check_setup(setup);
  const double R = setup.radius;
  Material material = setup.material;
  if (setup.penalty_per_size > 0)
    material.normal_penalty = material.tangential_penalty = setup.penalty_per_size * material.young / setup.element_size;
  Model model;
  model.materials = {material};
  GrainSpec sphere;
  sphere.shape = PrimitiveShape::sphere;
  sphere.size = Eigen::Vector3d::Constant(R);
  sphere.element_size = setup.element_size;
  sphere.kind = setup.kind;
  sphere.label = 1;
  mesher(model, sphere);
  // The exact sphere's mass and weight: a faceted mesh lacks a few per cent of the volume.
  const double mass = 4.0 / 3.0 * std::numbers::pi * R * R * R * material.density;
  const BodyProperties meshed = body_properties(model, 0);
  model.materials[0].density = mass / meshed.volume;
  // Resting on the plane at its lowest node.
  const double lowest = std::ranges::min(model.nodes, {}, [](const Eigen::Vector3d& x) { return x.z(); }).z();
  for (Eigen::Vector3d& x : model.nodes) x.z() -= lowest;
  model.platens = {Platen{"plane", Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), material.friction}};

  RollingOutcome out;
  out.elements = model.element_count();
  out.nodes = model.nodes.size();
  out.centroid_offset = meshed.centroid.norm();
  const double h = contact_element_size(model, 0);
  out.pivot_rise = h * h / (8 * R);
  const double node_area = 4 * std::numbers::pi * R * R / double(surface_node_count(model));
  out.static_overlap = mass * setup.gravity / (material.normal_penalty * node_area);

  SolverOptions options;
  options.gravity = Eigen::Vector3d(0, 0, -setup.gravity);
  Solver s(model, options);
  s.set_grain_velocity(0, {setup.speed, 0, 0}, {0, setup.speed / R, 0});
  out.time_step = s.time_step_limits().stable();
  const double distance = setup.turns * 2 * std::numbers::pi * R;
  const double steps_needed = distance / (setup.speed * out.time_step);
  if (steps_needed > setup.max_steps)
    throw UsageError(fmt::format("rolling {:.3g} m at {} m/s takes {:.3g} steps of {:.3g} s, more than the {:.3g} allowed; "
                                 "roll faster, fewer turns or on a coarser mesh",
                                 distance, setup.speed, steps_needed, out.time_step, setup.max_steps));

  const Eigen::Vector3d start = s.grain_centroid(0);
  double rotation = 0;
  std::size_t touching = 0;
  const auto t0 = std::chrono::steady_clock::now();
  // The run ends on distance; a sphere that stops (friction losses, a mesh that locks) ends at
  // twice the steps rolling would take.
  while (s.grain_centroid(0).x() - start.x() < distance && double(out.steps) < 2 * steps_needed) {
    s.step(out.time_step);
    ++out.steps;
    if (-s.platen_force(0).z() > 0) ++touching;
    rotation += s.grain_spin(0).y() * out.time_step;
    out.largest_rise = std::max(out.largest_rise, s.grain_centroid(0).z() - start.z());
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  out.contact_share = double(touching) / double(out.steps);
  out.rolling_ratio = rotation * R / (s.grain_centroid(0).x() - start.x());
  out.speed_ratio = s.grain_velocity(0).x() / setup.speed;
  return out;
}

}  // namespace graintwin::fdem
