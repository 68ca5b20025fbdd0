#pragma once
// Watershed markers from the distance transform of the solid: one marker per grain, found either as
// the regional maxima left by an h-maxima filter or as EDT peaks a minimum distance apart; and a
// rule that proposes h from the image itself.
#include <cstddef>
#include <cstdint>

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

/// Markers at EDT peaks at least `min_distance_vox` apart: candidates are the solid voxels not lower
/// than any neighbour (connectivity c); taken greedily from the highest EDT down (ties: lowest
/// raster index first), a candidate is dropped if an accepted peak lies closer than the minimum
/// distance (physical distance between voxel centres, min_distance_vox in units of the smallest
/// voxel size). Each accepted peak is a one-voxel marker, labelled 1..K in raster order.
Volume<std::uint32_t> peak_markers(const Volume<float>& edt, double min_distance_vox,
                                   Connectivity c = Connectivity::corners);

/// What propose_h chose and why (the tool prints it).
struct HProposal {
  double h_vox = 0.0;                ///< proposed h (units of the smallest voxel size)
  std::size_t markers = 0;           ///< number of markers h_maxima_markers gives at h_vox
  double plateau_lo_vox = 0.0;       ///< the widest range of h over which the marker count is
  double plateau_hi_vox = 0.0;       ///<   stable to 1 %; h_vox is its geometric middle
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
/// reference grain radius: `expected_radius_m` if > 0 (e.g. d50 / 2), else the median EDT peak of
/// the maxima whose dynamic exceeds one voxel (the inscribed radius of a typical grain). Spurious
/// maxima of a grain have dynamics of a voxel or so, real grains of the order of their radius minus
/// the neck radius of their contacts, so N(h) has a plateau between the two; the proposal is the
/// geometric middle of the widest range of h over which N(h) changes by at most 1 %, ties to the
/// smaller h. Cost: about one watershed; memory a uint32 and a bit per voxel plus the flood front.
HProposal propose_h(const Volume<float>& edt, double expected_radius_m = 0.0,
                    Connectivity c = Connectivity::corners);

}  // namespace graintwin::segment
