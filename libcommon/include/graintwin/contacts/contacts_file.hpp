#pragma once
// `kind=contacts` files (docs/formats.md): the contacts of one scan with their normals, areas,
// branch vectors and contact confidences, the grains' coordination numbers, and the fabric tensors
// and rose counts of the counted contacts. Built from the detected and refined contacts by
// `contacts_content`, written by labels2contacts, read by tracks2micro (coordination numbers) and
// report (coordination and roses). Dataset names: io/schema.hpp, namespace schema::contacts.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "graintwin/contacts/detect.hpp"
#include "graintwin/contacts/fabric.hpp"
#include "graintwin/contacts/network.hpp"
#include "graintwin/contacts/refine.hpp"
#include "graintwin/segment/labels.hpp"

namespace graintwin::io {
class H5File;
}

namespace graintwin::contacts {

/// /contacts/fit_status of a contact whose fit was not attempted (no grey volume, or --no-refine);
/// codes 0-3 are RefineStatus.
inline constexpr std::uint8_t kFitNotAttempted = 4;
/// The description of the fit_status codes, stored as its attribute `codes`.
inline constexpr const char* kFitStatusCodes =
    "0 fitted, 1 few_voxels, 2 not_converged, 3 rejected, 4 not attempted (no grey volume)";

/// The per-contact table (M rows, in the order find_contacts returns them). Positions in metres,
/// vectors (x, y, z). Where the fit to the grey levels failed or was not attempted, `normal` is
/// the PCA normal, `point` the centroid, and the fit columns are NaN.
struct ContactTable {
  std::vector<std::uint32_t> pair;    ///< M x 2, labels (low, high), low < high
  std::vector<std::uint64_t> voxels;  ///< M x 2, contact voxels of low, high
  std::vector<Vec3> normal;           ///< unit, low -> high: refined, else PCA
  std::vector<Vec3> normal_pca;       ///< unit, PCA of the contact voxel pairs
  std::vector<Vec3> vector_area;      ///< m^2, oriented faces low -> high
  std::vector<double> area;           ///< m^2, |vector_area|
  std::vector<Vec3> centroid;         ///< m, mean of the contact voxels
  std::vector<Vec3> point;            ///< m, refined contact point, else the centroid
  std::vector<Vec3> branch;           ///< m, centroid(high) - centroid(low)
  std::vector<double> confidence;     ///< P(gap < tolerance); NaN unknown
  std::vector<double> gap, gap_sd;    ///< m; NaN unknown
  std::vector<double> radius;         ///< M x 2, m, fitted local radii of low, high
  std::vector<double> blur;           ///< m, fitted edge width
  std::vector<double> fit_rms;        ///< residual rms / contrast
  std::vector<std::uint8_t> fit_status;  ///< RefineStatus, or kFitNotAttempted
  std::vector<std::uint8_t> accepted;    ///< 1: counted in Z, the fabric and the roses
  std::size_t size() const { return area.size(); }
};

/// What labels2contacts used; stored as attributes of /contacts and /coordination.
struct ContactsSettings {
  std::uint64_t min_voxels = 2;          ///< contact voxels each grain of a pair needs
  bool refined = false;                  ///< normals fitted to the grey levels
  double window_vox = RefineParams{}.window_vox;  ///< fit window radius (voxels; 0 = automatic)
  double gap_tolerance_vox = RefineParams{}.gap_tolerance_vox;  ///< confidence = P(gap < this), voxels
  double min_confidence = 0.5;           ///< counted contacts need at least this (NaN counts)
  bool include_edge_grains = false;      ///< edge grains in the coordination histogram and mean
  int theta_bins = 9, phi_bins = 36;     ///< rose bins (polar angle over 0-90 deg, azimuth over 0-360 deg)
};

/// The whole content of a kind=contacts file.
struct ContactsFile {
  ContactTable contacts;
  std::vector<std::uint32_t> grain_label;       ///< N, every grain of the labels file, by label
  std::vector<std::uint8_t> grain_touches_edge;  ///< N
  /// per_grain is /grains/coordination (N); histogram, mean and counted as stored.
  Coordination coordination;
  Fabric fabric_normal, fabric_branch;  ///< of the counted contacts' normals and branch vectors
  Rose rose_normal, rose_branch;        ///< likewise
  /// On reading, theta_bins and phi_bins are those of the stored roses.
  ContactsSettings settings;
};

/// The file content of contacts `found` (find_contacts) of the grains `grains` (sorted by label),
/// with `fits` (one per contact, refine_contacts; used only when settings.refined, and then of
/// the same length as `found`, UsageError otherwise). A contact is counted in the coordination
/// numbers, fabric tensors and roses when its confidence is at least settings.min_confidence or
/// unknown (NaN); the counted contacts take the refined normal where the fit succeeded.
ContactsFile contacts_content(const std::vector<Contact>& found, const std::vector<Refinement>& fits,
                              const std::vector<segment::GrainRecord>& grains, const ContactsSettings& settings);

/// Contacts of `content` counted in Z, the fabric and the roses.
std::size_t accepted_count(const ContactsFile& content);

/// The contact network of `content` for ParaView: each contact at its point with its normal, its
/// branch between the centroids of its grains in `grains` (the labels file's table, sorted by
/// label; DataError when a contact's label has no row), and cell values area, confidence, gap
/// and accepted.
ContactNetwork contact_network(const ContactsFile& content, const std::vector<segment::GrainRecord>& grains);

/// Writes `content` as a kind=contacts file with provenance `history`.
void write_contacts_file(const std::filesystem::path& path, const ContactsFile& content,
                         const std::vector<std::string>& history);

/// The checks read_contacts_file makes on the tables of an open kind=contacts file (io/table_checks):
/// the /contacts, /grains and /coordination columns agree in length, the geometry columns hold no
/// NaN, and no column holds infinity. DataError naming the file and the column.
void check_contacts_tables(const io::H5File& file);

/// Reads a kind=contacts file. UsageError when `path` is not one (naming labels2contacts);
/// DataError naming the file and the dataset when its tables differ in length, a column that is
/// never NaN holds NaN, any column holds infinity, or a fabric, rose or coordination table does
/// not have the size its bins say.
ContactsFile read_contacts_file(const std::filesystem::path& path);

}  // namespace graintwin::contacts
