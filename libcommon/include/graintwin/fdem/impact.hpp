#pragma once
// Sphere impacts for verifying fdemrun's contact against exact answers (docs/fdemrun.md,
// verification): Hertz's elastic impact (contact time, peak force, approach), Chung & Ooi (2011)
// tests 1, 2, 6 and 7 (sphere on sphere or on a rigid wall, with spin), and the Coulomb sliding
// solution for the tangential restitution. The spheres are meshed fine only at the poles that
// touch (SizeGrading); gmsh is passed in, so this module does not link it
// (mesh/ellipsoid_grain.hpp: mesh::append_graded_ellipsoid_grain).
#include <Eigen/Core>
#include <cstddef>
#include <functional>

#include "graintwin/fdem/model.hpp"
#include "graintwin/fdem/scene.hpp"
#include "graintwin/fdem/size_grading.hpp"

namespace graintwin::fdem {

class Solver;

/// Hertz's elastic impact of two bodies (quasi-static contact, no friction): effective mass m*
/// (kg), radius R* (m), modulus E* (Pa) and relative approach speed v (m/s).
struct HertzImpact {
  double max_approach = 0;  ///< m, delta_max = (15 m* v^2 / (16 E* sqrt(R*)))^(2/5)
  double peak_force = 0;    ///< N, 4/3 E* sqrt(R*) delta_max^(3/2)
  double contact_time = 0;  ///< s, 2.868 (m*^2 / (R* E*^2 v))^(1/5)
};
HertzImpact hertz_impact(double mass, double radius, double modulus, double speed);

/// Tangential restitution of the contact point, beta = -v'_ct / v_ct, of a solid sphere that slides
/// throughout the impact (Coulomb friction mu, normal restitution e, normal speed v_n, incoming
/// contact-point tangential speed v_ct > 0): beta = -1 + 3.5 mu (1 + e) v_n / v_ct (Chung & Ooi
/// 2011, test 6; 3.5 = 1 + m R^2 / I). Valid while it stays below 0 (the contact point never stops).
double sliding_tangential_restitution(double mu, double e, double normal_speed, double tangential_speed);

/// Angular velocity (rad/s) of grain g from its nodes: I^-1 L about the mass centre, L and I summed
/// over the lumped node masses (any grain kind; a deformable grain's vibration averages out in L).
Eigen::Vector3d grain_angular_velocity(const Solver& solver, std::size_t grain);

/// One impact along z: an upper sphere centred above the contact point moving down, onto a rigid
/// wall (the platen z = 0) or onto an identical lower sphere moving up (mirror image; its spin is
/// minus the upper one's, so with spin the two contact points move together: Chung & Ooi test 7).
struct ImpactSetup {
  Material material;                  ///< density: nominal, rescaled so the mesh has the exact sphere mass
  double radius = 0;                  ///< m
  double speed = 0;                   ///< m/s, each sphere's normal approach speed
  Eigen::Vector3d spin = Eigen::Vector3d::Zero();  ///< rad/s, the upper sphere's
  bool two_spheres = false;           ///< else against the wall (friction: the material's)
  GrainKind kind = GrainKind::tet4;
  double fine = 0, growth = 0.1, coarse = 0;  ///< m, the mesh grading towards the contact pole(s)
  /// p_n = p_t = penalty_per_size x E / fine when > 0; 0 keeps the material's penalties.
  double penalty_per_size = 10;
  double max_steps = 5e6;             ///< a run still in contact after this many steps is an error
};

struct ImpactOutcome {
  double mass = 0;                 ///< kg, each sphere (exact: 4/3 pi R^3 rho)
  std::size_t elements = 0, nodes = 0;  ///< of the whole model
  double time_step = 0;            ///< s, the stable step used
  std::size_t steps = 0;           ///< steps run
  double contact_time = 0;         ///< s, from the first to the last step with a normal force
  double peak_force = 0;           ///< N, largest normal force
  /// m, largest approach of the centroids (to the wall or each other) since the contact started:
  /// the Hertz delta, penalty overlap and the spheres' compression included.
  double max_approach = 0;
  Eigen::Vector3d velocity_after = Eigen::Vector3d::Zero();  ///< m/s, the upper sphere's centroid after contact
  Eigen::Vector3d spin_after = Eigen::Vector3d::Zero();      ///< rad/s, the upper sphere's
  /// The upper sphere's moment of inertia about the spin axis (y) from its lumped node masses, over
  /// the exact 2/5 m R^2: lumping moves mass to the nodes, so a coarse mesh turns a little slower.
  double inertia_ratio = 0;
  double seconds = 0;              ///< wall time of the steps (meshing excluded)
  HertzImpact hertz;               ///< for this mass, radius and material (E* with the wall rigid)
};

/// A mesher of graded primitive grains, e.g. mesh::append_graded_ellipsoid_grain.
using GradedGrainMesher = std::function<void(Model&, const GrainSpec&, const SizeGrading&)>;

/// Builds the spheres (graded towards the contact pole), runs at the stable step until the
/// contact has ended (and for a quarter of its duration more) and measures. UsageError for a bad
/// setup; DataError when the contact does not end within max_steps.
ImpactOutcome run_impact(const ImpactSetup& setup, const GradedGrainMesher& mesher);

}  // namespace graintwin::fdem
