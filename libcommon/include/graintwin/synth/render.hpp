#pragma once
// Rendering of synthetic CT scans: partial-volume fractions of star-shaped grains (analytic
// secant planes, or point samples) and of a membrane shell, the ground-truth label image, and the
// scanner model (grey levels, point-spread blur, ring artifacts, beam-hardening cupping, Poisson
// and Gaussian noise).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <vector>

#include "graintwin/core/volume.hpp"
#include "graintwin/shape/radial_table.hpp"
#include "graintwin/synth/solid_grains.hpp"

namespace graintwin::synth {

/// A grain at its pose: body origin (= centroid) at `position` (m, x y z), body -> world rotation.
/// A grain that is not star-shaped has a `solid`; `shape` is then a star-shaped hull containing it,
/// and voxels where the solid may differ from the hull are point-sampled on the solid
/// (RenderParams::supersample^3 points, or 4^3 with the analytic default).
struct PlacedGrain {
  const shape::RadialTable* shape = nullptr;
  Eigen::Vector3d position{0.0, 0.0, 0.0};
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
  std::uint32_t label = 0;  ///< > 0
  const GrainSolid* solid = nullptr;
};

struct RenderParams {
  /// Partial-volume method for the voxels the surface may cross (those whose centre is within half
  /// a voxel diagonal, times a per-grain slope factor, of the surface; the others are whole).
  /// 0 (default): analytic. The surface in the voxel is replaced by its secant plane: the normal
  /// of the table at the voxel centre's direction, through the mean of the 8 surface points
  /// radially nearest the voxel's 2 x 2 x 2 Gauss points; the voxel's fraction below that plane
  /// is exact (box_fraction_below_plane). Where those 8 points stray from a plane by more than
  /// 0.1 voxel (a kink or a bump smaller than the voxel), the voxel is split once into 8 halves,
  /// each done the same way. Measured (docs/benchmarks.md): 4 times more accurate than 4^3
  /// samples at a third of the cost.
  /// k in 1..16: k^3 point samples per voxel (the older method; the reference of the accuracy
  /// chart in docs/benchmarks.md).
  int supersample = 0;
};

/// Fraction (0..1) of the axis-aligned box with edge lengths `edges` (x y z), centred at the
/// origin, on the side normal . x <= offset of a plane (`normal` unit, x y z). Exact, in closed
/// form (the piecewise-cubic volume of a cube cut by a plane, Scardovelli & Zaleski, J. Comput.
/// Phys. 164, 2000), also for normals along an axis or an edge.
double box_fraction_below_plane(const Eigen::Vector3d& normal, double offset, const Eigen::Vector3d& edges);

/// Grain fraction per voxel (0..1) and the label of the grain containing each voxel centre (0 =
/// none). Geometry is that of `like` (shape, voxel size, origin); `progress` gets fractions done.
struct GrainImages {
  Volume<float> fraction;
  Volume<std::uint32_t> labels;
};
GrainImages render_grains(const std::vector<PlacedGrain>& grains, const Shape3& shape, const Vec3& voxel_size,
                          const Vec3& origin, const RenderParams& params,
                          const std::function<void(double)>& progress = {});

/// A cylindrical shell around the z axis through (centre_x, centre_y): inner radius r(z) given by
/// `inner_radius` (lets the membrane follow a bulging sample), constant thickness, between z0 and z1.
struct Shell {
  double centre_x = 0.0, centre_y = 0.0;
  std::function<double(double theta, double z)> inner_radius;  ///< m, at azimuth theta (rad) about the centre and height z
  double thickness = 0.0;
  double z0 = 0.0, z1 = 0.0;
};
/// Fraction of each voxel inside the shell. Voxels its surfaces may cross are point-sampled,
/// params.supersample^3 times, or 4^3 with the analytic default: the shell's rim, where a
/// cylinder meets a plane inside one voxel, has no single secant plane. `progress` (optional) gets
/// the fraction of z slices done, one call at a time.
Volume<float> render_shell(const Shell& shell, const Shape3& shape, const Vec3& voxel_size, const Vec3& origin,
                           const RenderParams& params, const std::function<void(double)>& progress = {});

/// The scanner: grey = void + (grain - void) f_grain + (membrane - void) f_membrane, then cupping,
/// rings, blur, noise, and the map to uint16.
struct ScannerParams {
  double grey_void = 0.10;       ///< air and pore space, in units of the grain grey level scale
  double grey_grain = 0.75;
  double grey_membrane = 0.35;
  double blur_sigma_vox = 0.8;   ///< Gaussian point-spread sigma (voxels); 0 = none
  double noise = 0.05;           ///< Gaussian noise sigma as a fraction of (grain - void) contrast
  double photons = 0.0;          ///< mean photon count at grain grey for Poisson noise; 0 = none
  double ring_amplitude = 0.0;   ///< ring artifact amplitude (fraction of contrast); 0 = none
  double beam_hardening = 0.0;   ///< cupping depth (fraction of grain grey at the axis); 0 = none
  double axis_x = 0.0, axis_y = 0.0;  ///< rotation axis (m) for rings and cupping
  double field_radius = 1.0;     ///< radius (m) over which cupping acts
  double uint16_scale = 50000.0; ///< uint16 value = grey * scale + offset (clamped)
  double uint16_offset = 5000.0;
  std::uint64_t seed = 1;        ///< noise and ring seed; per-voxel noise is hashed, so thread count
                                 ///< does not change the bytes
};
/// Refuses grey levels that would make a scan without a word of warning unusable (UsageError
/// naming ctsynth's options and the numbers): grains not brighter than the pores, a grain-void
/// contrast below one uint16 step, or a level (void, grain, membrane when `with_membrane`) that
/// --grey-scale and --grey-offset put beyond 65535, where every such voxel would saturate.
void check_grey_levels(const ScannerParams& params, bool with_membrane);

/// Peak bytes per voxel of rendering and simulating one scan: grain fraction (float, which becomes
/// the grey image) and labels (uint32), membrane fraction (float), the uint16 scan.
constexpr double kScanBytesPerVoxel = 4 + 4 + 4 + 2;

/// The scan of a grain fraction image (and a membrane's, optional): grey levels, rings, beam
/// hardening, blur, photon and read noise, uint16. The fraction is taken by value and turned into
/// the grey image in place: move it in when it is no longer needed.
Volume<std::uint16_t> simulate_scan(Volume<float> grain_fraction, const Volume<float>* membrane_fraction,
                                    const ScannerParams& params);

}  // namespace graintwin::synth
