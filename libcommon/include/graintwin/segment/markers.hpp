#pragma once
// Watershed markers from the distance transform of the solid: one marker per grain, found either as
// the regional maxima left by an h-maxima filter or as EDT peaks a minimum distance apart; and a
// rule that proposes h from the image itself.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "graintwin/core/volume.hpp"
#include "graintwin/segment/connectivity.hpp"

namespace graintwin::segment {

/// Markers from the h-maxima transform of the EDT: the regional maxima of the morphological
/// reconstruction by dilation of (edt - h) under edt, each connected plateau one marker. A maximum
/// survives when its dynamic (how far one must descend from it to reach a higher peak) exceeds h,
/// so h removes the shallow maxima that rough or elongated grains produce.
///
/// edt: distances in metres, > 0 exactly on the solid (distance_transform); h_vox >= 0 in units of
/// the smallest voxel size (h = 0: plain regional maxima). Returns (nz, ny, nx) uint32 labelled
/// 1..K in raster order (z, y, x) of each plateau's first voxel, 0 elsewhere; same geometry as edt.
/// Reconstruction: hybrid raster / anti-raster scans plus a FIFO (Vincent 1993), O(N), sequential;
/// the maxima tests run in parallel. Extra memory: a float and a bit per voxel while it runs, then
/// the labels and the bit.
Volume<std::uint32_t> h_maxima_markers(const Volume<float>& edt, double h_vox,
                                       Connectivity c = Connectivity::corners);

/// The regional maxima of an EDT and their saddles, from one flood: what propose_h reads N(h) from
/// and what gives the h-maxima markers for any h without a reconstruction.
struct MaximaDynamics {
  std::vector<std::size_t> first_voxel;  ///< raster-first voxel of each regional maximum (raster order)
  std::vector<float> peak;               ///< EDT at each maximum, metres
  /// Highest level at which the maximum's basin meets the basin of a higher peak (ties: of a peak
  /// with a smaller raster index), metres; -inf for the top of each connected piece of solid.
  std::vector<float> saddle;
  /// Label (1-based index) of the maximum whose basin absorbed maximum i's basin at its saddle,
  /// always one with a higher peak (ties: smaller label); 0 for the tops.
  std::vector<std::uint32_t> absorbed_by;
  double unit = 1.0;                     ///< smallest voxel size, metres
  /// How far one descends from maximum i before a higher peak is reachable, metres (+inf for tops).
  double dynamic(std::size_t i) const { return static_cast<double>(peak[i]) - static_cast<double>(saddle[i]); }
};

/// Floods the EDT once from all its regional maxima (priority flood of decreasing distance,
/// union-find over the basins). Saddles are exact for isotropic voxels; with anisotropic voxels the
/// flood order is quantised to 1/8 squared smallest voxel, which may shift a saddle by as much.
/// If `basins` is given it receives the flood itself: every solid voxel labelled with the maximum
/// (1..K, the indices of the result plus one) whose basin reached it first, 0 elsewhere; that is
/// the watershed from all regional maxima, which watershed_from_dynamics coarsens for any h.
/// Memory: a uint32 and a bit per voxel plus the flood front (the uint32 kept in `basins`).
MaximaDynamics maxima_dynamics(const Volume<float>& edt, Connectivity c = Connectivity::corners,
                               Volume<std::uint32_t>* basins = nullptr);

/// The marker watershed for the h-maxima markers of h_vox, from the basins of maxima_dynamics
/// without a second flood: a maximum is a marker iff saddle < peak - h (the test of the
/// h-maxima transform), and every other basin joins, through the absorbed_by chain, the marker
/// whose basin absorbed it at its saddle. Each marker's plateau (edt >= peak - h around it) gets
/// the marker's label exactly as in watershed(edt, h_maxima_markers(edt, h_vox)); below the plateaus
/// the two differ only where the flood order decides a boundary voxel between two basins (the
/// flood starts from all maxima here, from the plateaus there). Labels 1..K' in the order of the
/// markers' maxima, 0 stays 0. Cost: one parallel pass over the voxels plus a sort of the maxima.
Volume<std::uint32_t> watershed_from_dynamics(Volume<std::uint32_t> basins, const MaximaDynamics& d,
                                              double h_vox);

/// Markers at EDT peaks at least `min_distance_vox` apart: candidates are the solid voxels not lower
/// than any neighbour (connectivity c); taken greedily from the highest EDT down (ties: lowest
/// raster index first), a candidate is dropped if an accepted peak lies closer than the minimum
/// distance (physical distance between voxel centres, min_distance_vox in units of the smallest
/// voxel size). Each accepted peak is a one-voxel marker, labelled 1..K in raster order.
Volume<std::uint32_t> peak_markers(const Volume<float>& edt, double min_distance_vox,
                                   Connectivity c = Connectivity::corners);

/// A piece of a label smaller than this share of the volume of a reference grain (a sphere of the
/// reference radius) is a fragment: merged into a neighbour (segment_grains) and not counted as a
/// grain by propose_h. Necks between grains give pieces of 2-4 %; the smallest Ottawa grain
/// (0.30 mm against d50 0.551 mm) has 16 %.
inline constexpr double kFragmentVolumeShare = 0.05;

/// What propose_h chose and why (the tool prints it).
struct HProposal {
  double h_vox = 0.0;                ///< proposed h (units of the smallest voxel size)
  std::size_t markers = 0;           ///< N(h_vox): maxima deeper than h_vox and big enough to be a grain
  double plateau_lo_vox = 0.0;       ///< the widest range of h over which the marker count is
  double plateau_hi_vox = 0.0;       ///<   stable to 1 %; h_vox is its geometric middle
  bool plateau_found = false;        ///< false: no range of a quarter octave or more; h = 0.5
  std::size_t markers_at_lo = 0;     ///< marker counts at the two ends of that range
  std::size_t markers_at_hi = 0;
  double reference_radius_m = 0.0;   ///< grain radius that bounds the search (given or estimated)
  bool radius_estimated = false;     ///< true if reference_radius_m was estimated from the EDT
  std::size_t regional_maxima = 0;   ///< regional maxima of the EDT (markers as h -> 0)
};

/// Proposes h from the dynamics of the EDT maxima.
///
/// Rule: one flood from all regional maxima of the EDT gives every maximum's dynamic (peak minus
/// the highest saddle to a higher peak), hence the marker count N(h) = #{dynamic > h} for every h
/// at once. h is searched on a log grid (8 steps per octave) from 0.5 voxel up to half the
/// reference grain radius: `expected_radius_m` if > 0 (e.g. d50 / 2), else the median, weighted by
/// peak^3 (by volume, as d50), of the EDT peaks of the maxima whose dynamic exceeds one voxel (the
/// inscribed radius of a typical grain; noise specks, however many, weigh almost nothing). Spurious
/// maxima of a grain have dynamics of a voxel or so, real grains of the order of their radius minus
/// the neck radius of their contacts, so N(h) has a plateau between the two; N(h) counts only
/// maxima whose peak reaches cbrt(kFragmentVolumeShare) times the reference radius (smaller
/// inscribed balls are fragments: noise specks, membrane pieces); the proposal is the
/// geometric middle of the widest range of h over which N(h) changes by at most 1 %, ties to the
/// smaller h; if that range is narrower than a quarter octave there is no plateau (the count keeps
/// falling: grains too small or too fused for their maxima to stand out) and h is the floor, 0.5. Cost: about one watershed; memory a uint32 and a bit per voxel plus the flood front.
HProposal propose_h(const Volume<float>& edt, double expected_radius_m = 0.0,
                    Connectivity c = Connectivity::corners);

/// The same from dynamics already computed (maxima_dynamics of the EDT).
HProposal propose_h(const MaximaDynamics& d, double expected_radius_m = 0.0);

}  // namespace graintwin::segment
