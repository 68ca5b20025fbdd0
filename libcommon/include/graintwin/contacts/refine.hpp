#pragma once
// Sub-voxel contact normals and contact confidence from the grey levels around each contact.
//
// Near a contact both grain surfaces are tangent to one plane, so locally they are two osculating
// spheres whose centres lie on the contact normal. refine_contact fits that model to the grey
// values of a small ball of voxels around the contact: the image of each sphere is a blurred ball
// (the exact Gaussian-blurred ball profile, with curvature term), the two add up (disjoint grains),
// and the parameters are the contact point p, the normal n, the two radii, the gap between the
// surfaces along n, the edge width (blur) and the two grey levels. Levenberg-Marquardt with
// analytic derivatives, started from the voxel-based contact. The normal of the fit is the refined
// normal; the fitted gap and its standard error give the confidence that the grains really touch
// (a global threshold merges grains up to about a voxel apart: the partial-volume effect).
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "graintwin/contacts/detect.hpp"
#include "graintwin/core/volume.hpp"
#include "graintwin/segment/labels.hpp"

namespace graintwin::contacts {

struct RefineParams {
  /// Radius of the ball of voxels fitted, in voxels; 0 = automatic: 0.6 x the smaller grain's
  /// equivalent radius, clamped to [3, 7] voxels.
  double window_vox = 0.0;
  /// Voxels closer than this (voxels, chessboard distance) to a third grain are left out: its
  /// blurred edge is not part of the two-grain model.
  int exclusion_vox = 2;
  /// The confidence is the probability that the gap is below this (voxels). Half a voxel: on rough
  /// sand grains the fitted gap of truly touching pairs scatters by about 0.35 voxel.
  double gap_tolerance_vox = 0.5;
  int max_iterations = 40;
};

/// How a fit ended; only `fitted` results carry a refined normal.
enum class RefineStatus {
  fitted,          ///< converged to an accepted solution
  few_voxels,      ///< too few voxels of either grain or of the pore space in the window
  not_converged,   ///< no convergence within max_iterations
  rejected,        ///< converged outside the model's sane range (centre off the window, radius,
                   ///< blur or contrast implausible): the two-sphere model does not fit here
};
/// "fitted", "few_voxels", "not_converged", "rejected".
const char* status_name(RefineStatus s);

/// The fit of one contact. Positions and vectors (x, y, z) in metres.
struct Refinement {
  RefineStatus status = RefineStatus::few_voxels;
  bool ok() const { return status == RefineStatus::fitted; }
  Vec3 normal{kNaN, kNaN, kNaN};        ///< unit, low -> high
  Vec3 point{kNaN, kNaN, kNaN};         ///< midway between the two fitted surfaces
  double gap = kNaN;                    ///< m, surface separation along the normal (< 0: overlap)
  double gap_sd = kNaN;                 ///< m, standard error of the gap
  double confidence = kNaN;             ///< P(gap < tolerance) from the fitted gap and its error
  std::array<double, 2> radius{kNaN, kNaN};  ///< m, local radii of curvature of low and high
  double blur = kNaN;                   ///< m, fitted edge width (point spread plus partial volume)
  double rms = kNaN;                    ///< residual rms / fitted grain-void contrast
  int iterations = 0;
  std::size_t voxels = 0;               ///< voxels in the fit
};

/// Refuses (DataError naming `name`, the grey volume's file) a grey volume that cannot give
/// refined normals or confidences: NaN or infinite voxels, or one value in every voxel (no contrast
/// between grains and pores to fit, so every confidence would be undefined).
void check_grey_for_refinement(const AnyVolume& grey, const std::string& name);

/// How the confidences of a set of fits compare with a threshold. A fit that failed has no
/// confidence (NaN): it is `unknown`, neither above nor below.
struct ConfidenceCount {
  std::size_t at_least = 0;  ///< confidence >= the threshold
  std::size_t below = 0;     ///< confidence < the threshold
  std::size_t unknown = 0;   ///< NaN: the fit failed
};
ConfidenceCount count_confidences(const std::vector<Refinement>& fits, double min_confidence);

/// Refines one contact. grey and labels: same shape and geometry (not checked here). `radius_low`
/// and `radius_high` (m) seed the local radii (e.g. equivalent-sphere radii). A fit that fails does
/// not throw: its status says why and the other fields stay NaN.
template <class T>
Refinement refine_contact(const Volume<T>& grey, const Volume<std::uint32_t>& labels, const Contact& contact,
                          double radius_low, double radius_high, const RefineParams& params = {});

/// Refines every contact, in parallel (dynamic schedule; each contact is independent, so the
/// results do not depend on the thread count). `grains` sorted by label gives the seeding radii
/// from the grain volumes. Throws UsageError if grey and labels differ in shape.
template <class T>
std::vector<Refinement> refine_contacts(const Volume<T>& grey, const Volume<std::uint32_t>& labels,
                                        const std::vector<Contact>& contacts,
                                        const std::vector<segment::GrainRecord>& grains,
                                        const RefineParams& params = {},
                                        const std::function<void(double)>& progress = {});

}  // namespace graintwin::contacts
