#pragma once
// The flexible membrane of the triaxial test (docs/methods.md, Qu et al. 2019): one layer of equal
// balls on a hexagonal lattice wrapped on the sample cylinder, each bonded to its six neighbours by
// a normal and a shear spring (eq. 24), no friction and no moment between bonded balls; the
// confining pressure acts on the triangles of neighbouring balls (eq. 26); the enclosed volume by
// the divergence theorem (eq. 27) and by a radial flux sum (eq. 28). Balls have 6 degrees of
// freedom: a bond's shear force acts at the contact point, so the balls spin freely and a rigid
// rotation of the membrane stores no shear (the incremental shear force turns with the bond).
// Units: m, kg, N, Pa, s. Docs: docs/fdem_membrane.md.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

namespace graintwin::fdem {

/// Latex defaults (docs/methods.md, flexible membrane).
struct MembraneMaterial {
  double young = 1.25e6;      ///< Pa
  double poisson = 0.2;       ///< at most 1/3 (a triangular spring lattice cannot go beyond)
  double thickness = 0.3e-3;  ///< m
  double density = 1000.0;    ///< kg/m^3 (natural latex 920-1000)
};

/// Spring constants of one bond, N/m.
struct BondStiffness {
  double normal = 0, shear = 0;
};

/// Eq. 24: K_n = E t / (sqrt(3) (1 - nu)), K_s = E t (1 - 3 nu) / (sqrt(3) (1 - nu^2)). UsageError
/// for nu > 1/3 (K_s < 0: the lattice cannot reach it), nu <= -1, or a non-positive E or t.
BondStiffness bond_stiffness(const MembraneMaterial& material);
/// The lattice's own Poisson ratio, (K_n - K_s) / (3 K_n + K_s), and its E t:
/// 2 sqrt(3) K_n (K_n + K_s) / (3 K_n + K_s) (both spacing-independent).
double lattice_poisson(const BondStiffness& k);
double lattice_young_thickness(const BondStiffness& k);

/// Limits of the ratio membrane radius / ball radius (docs/methods.md): below 35 the stiffness is off
/// by more than 5 %, above 100 the membrane costs more than it brings.
inline constexpr double kMinRadiusRatio = 35, kMaxRadiusRatio = 100;
/// The ball radius: a third of d50 (docs/methods.md), moved into the radius-ratio window.
double choose_ball_radius(double membrane_radius, double d50);

/// The membrane's lattice. Ball (ring k, position i) has index k * per_ring + i; rings are
/// horizontal, ring k at z_min + k dz (dz = s sqrt(3)/2), odd rings turned by half a spacing.
struct Membrane {
  MembraneMaterial material;
  BondStiffness stiffness;
  Eigen::Vector2d axis_xy = Eigen::Vector2d::Zero();  ///< m, the cylinder axis
  double radius = 0;        ///< m, of the ball centres in the reference
  double ball_radius = 0;   ///< m
  double ball_mass = 0;     ///< kg: rho t times the lattice area per ball, (sqrt(3)/2) s^2
  double ball_inertia = 0;  ///< kg m^2: (2/5) m r^2
  std::size_t rings = 0, per_ring = 0;
  std::vector<Eigen::Vector3d> reference;              ///< ball centres, m
  std::vector<std::array<std::uint32_t, 2>> bonds;     ///< ball pairs, first < second
  std::vector<double> rest_length;                     ///< per bond, m
  std::vector<std::array<std::uint32_t, 3>> triangles; ///< counter-clockwise seen from outside
  /// Per ball, its bonds and its triangles in ascending order (ball b's are
  /// ball_bonds[bond_offset[b] .. bond_offset[b + 1]), likewise triangles): a ball gathers its
  /// bonds' and triangles' forces in the order a serial pass over them would add them, so the
  /// passes run in parallel and give the same bits.
  std::vector<std::uint32_t> bond_offset, ball_bonds, triangle_offset, ball_triangles;
  std::size_t balls() const { return reference.size(); }
  std::size_t ring_of(std::size_t ball) const { return ball / per_ring; }
};

/// Builds the lattice on the cylinder of `radius` (ball centres) around axis_xy, with rings from
/// z_min up to the first ring at or above z_max. per_ring = round(2 pi radius / (2 ball_radius)), so
/// neighbouring balls touch within the rounding. UsageError on non-positive sizes or fewer than 12
/// balls per ring.
Membrane build_membrane(const MembraneMaterial& material, const Eigen::Vector2d& axis_xy, double radius, double z_min,
                        double z_max, double ball_radius);

/// The moving state of the balls.
struct MembraneState {
  std::vector<Eigen::Vector3d> x;      ///< ball centres, m
  std::vector<Eigen::Vector3d> v;      ///< velocities at the last half step, m/s
  std::vector<Eigen::Vector3d> spin;   ///< angular velocities at the last half step, rad/s
  std::vector<Eigen::Vector3d> shear;  ///< per bond: elastic shear force on its second ball, N
};
/// The reference at rest, no shear.
MembraneState rest_state(const Membrane& membrane);

/// Bond forces and moments for the state's positions (added to force and moment, one entry per
/// ball). The shear force of each bond is first turned into the plane normal to the current bond,
/// then grows by -K_s times the tangential relative displacement of the contact point over dt
/// (velocities at the half step, spins included). Returns the elastic energy of the bonds, J.
double add_bond_forces(const Membrane& membrane, MembraneState& state, double dt, std::span<Eigen::Vector3d> force,
                       std::span<Eigen::Vector3d> moment);

/// Confining pressure on the outer face: each triangle's -pressure x area x outward normal, shared
/// equally by its three balls (eq. 26); pressure > 0 pushes towards the axis.
void add_pressure_forces(const Membrane& membrane, std::span<const Eigen::Vector3d> x, double pressure,
                         std::span<Eigen::Vector3d> force);

/// Stable step of the ball lattice alone, s: 2 / sqrt(lambda_max) with lambda_max bounded by
/// Gershgorin's theorem on the mass-scaled stiffness of a ball with six bonds (translation and
/// spin), times 0.8.
double membrane_stable_time_step(const Membrane& membrane);

/// What the step does to each ball.
enum class BallMotion : std::uint8_t {
  free = 0,  ///< integrates its forces
  clamped,   ///< moves with a prescribed velocity (a clamped end, e.g. with a platen), no spin
};

/// One central-difference step of the balls: free balls from force and moment with
/// mass-proportional damping alpha (1/s); clamped balls at clamp_velocity[group], where
/// group = clamp_group[ball] (ignored for free balls). `first`: the state holds velocities at t,
/// not t - dt/2. Returns the kinetic energy at the half step, J (free balls).
double integrate_balls(const Membrane& membrane, MembraneState& state, std::span<const Eigen::Vector3d> force,
                       std::span<const Eigen::Vector3d> moment, double dt, double damping,
                       std::span<const BallMotion> motion, std::span<const std::uint8_t> clamp_group,
                       std::span<const Eigen::Vector3d> clamp_velocity, bool first);

/// Static equilibrium of the membrane alone (no clamps) under `load`, which adds forces to the
/// second argument for the state given, by dynamic relaxation from rest: steps of
/// membrane_stable_time_step with mass-proportional `damping` (1/s; about twice the angular
/// frequency of the mode the load excites is critical) until the kinetic energy falls below
/// `tolerance` times its peak. DataError after max_steps. Returns the relaxed state.
MembraneState relax_membrane(const Membrane& membrane, double damping,
                             const std::function<void(const MembraneState&, std::vector<Eigen::Vector3d>&)>& load,
                             double tolerance = 1e-10, int max_steps = 200000);

/// The volume enclosed by the membrane's inner surface (ball centres moved towards the axis by the
/// ball radius) between the horizontal planes z_bottom < z_top (the platens), m^3, two ways, by the
/// divergence theorem over the lateral triangles clipped to the slab (one pass computes both):
/// - `volume` with F = (x - o) / 3 (eq. 27; o on the axis in the bottom plane): the clipped lateral
///   triangles plus the top cap (the bottom cap contributes nothing);
/// - `radial` with the radial field F = (x - axis) / 2 without its z part (eq. 28): the sum over the
///   clipped lateral triangles of half their area times rho_c . n_c (rho_c: horizontal vector from
///   the axis to the centroid); the platens contribute nothing. It needs no caps, so its agreement
///   with `volume` checks the caps and the clipping.
/// The same bits on any thread count. DataError when the membrane does not span the slab.
struct EnclosedVolumes {
  double volume = 0, radial = 0;
};
EnclosedVolumes enclosed_volumes(const Membrane& membrane, std::span<const Eigen::Vector3d> x, double z_bottom, double z_top);

}  // namespace graintwin::fdem
