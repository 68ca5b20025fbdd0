#pragma once
// Non-affine motion and local strain of each grain between two states (docs/methods.md, Falk and
// Langer 1998): the best affine map Lambda of the grain's neighbourhood, the residual D2min, the
// local strain eps^L = I - (Lambda + Lambda^T)/2 (compression positive, the corrected form) and its
// deviatoric invariant eps_q = sqrt(2/3 e_dev : e_dev); and the same affine map over a whole
// sample's tracked grains, as its axial and volumetric strain.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace graintwin::micro {

/// Why a grain's local deformation is or is not defined.
enum class DeformationStatus : std::uint8_t {
  ok = 0,
  too_few_neighbours = 1,  ///< fewer than `min_neighbours` neighbours within the radius
  singular = 2,            ///< the neighbours span no volume (Y nearly singular): Lambda is not determined
  missing = 3,             ///< the grain is not present (or not finite) in both states
};

struct DeformationOptions {
  double radius = 0.0;          ///< m, neighbourhood radius in the first state (the paper: 1.5 d50)
  double d50 = 0.0;             ///< m, D2min is reported over d50^2
  std::size_t min_neighbours = 3;
  /// Smallest eigenvalue of Y over its largest below which Y counts as singular (neighbours nearly
  /// coplanar or collinear: Lambda would amplify noise without bound).
  double min_conditioning = 1e-6;
};

/// One grain's result. Strain in Voigt order (xx, yy, zz, yz, xz, xy), tensor components (not
/// engineering shear), compression positive. Every number is NaN unless status == ok.
struct LocalDeformation {
  double d2min = 0.0;             ///< D2min / d50^2 (dimensionless)
  Eigen::Matrix3d lambda;         ///< affine tensor Lambda = X Y^-1 (maps mu(e) to mu(e + de))
  Eigen::Matrix<double, 6, 1> strain;  ///< eps^L
  double eps_q = 0.0;             ///< sqrt(2/3 e_dev : e_dev)
  std::uint32_t neighbours = 0;   ///< N_i
  DeformationStatus status = DeformationStatus::missing;
};

/// The affine tensor and D2min of one neighbourhood: `before[k]`, `after[k]` are mu_ki = r_k - r_i
/// in the two states (m). D2min = (1/N) sum_k |mu_ki(after) - Lambda mu_ki(before)|^2 in m^2 (not
/// yet divided by d50^2). Returns false (leaving the outputs alone) when Y is singular by
/// `min_conditioning`.
bool affine_fit(const std::vector<Eigen::Vector3d>& before, const std::vector<Eigen::Vector3d>& after,
                double min_conditioning, Eigen::Matrix3d& lambda, double& d2min_m2);

/// eps^L = I - (Lambda + Lambda^T)/2 in Voigt order (xx, yy, zz, yz, xz, xy).
Eigen::Matrix<double, 6, 1> local_strain(const Eigen::Matrix3d& lambda);
/// sqrt(2/3 e_dev : e_dev) of a strain in Voigt order (shear components counted twice).
double deviatoric_strain(const Eigen::Matrix<double, 6, 1>& strain);

/// Every grain's local deformation. `before`, `after`: positions (m) of the same N grains in the
/// two states; a non-finite position marks a grain missing from that state (it is neither computed
/// nor anyone's neighbour). Neighbours are taken within options.radius in the first state with
/// a uniform grid (core/point_grid). Parallel over grains (OpenMP).
std::vector<LocalDeformation> local_deformation(const std::vector<Eigen::Vector3d>& before,
                                                const std::vector<Eigen::Vector3d>& after,
                                                const DeformationOptions& options);

/// The sample's log strains from its tracked grains: the least-squares affine map Lambda (affine_fit)
/// of the positions `centroid` (N tracks x T scans x 3, track-major, m, NaN = missing) about their
/// mean, from scan 0 to each scan, over the grains present in both: eps_1 = -ln Lambda_zz and
/// eps_v = -ln det Lambda (compression positive); NaN where fewer than 4 grains are present in both
/// or they span no volume. UsageError when `centroid` is not N x T x 3.
struct TrackedStrains {
  std::vector<double> axial, volumetric;
};
TrackedStrains tracked_strains(const std::vector<double>& centroid, std::size_t tracks, std::size_t scans);

}  // namespace graintwin::micro
