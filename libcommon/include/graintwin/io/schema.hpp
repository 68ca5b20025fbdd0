#pragma once
// Every file kind, dataset name and attribute name of GrainTwin's HDF5 files lives here and in
// docs/formats.md; keep the two in step.
namespace graintwin::schema {

/// Bump on any incompatible change of a kind's layout; readers refuse newer files.
inline constexpr int version = 1;

namespace kind {
inline constexpr const char* volume = "volume";
inline constexpr const char* labels = "labels";
inline constexpr const char* contacts = "contacts";
inline constexpr const char* shapes = "shapes";
inline constexpr const char* tracks = "tracks";
inline constexpr const char* fdem_model = "fdem_model";
inline constexpr const char* fdem_results = "fdem_results";
inline constexpr const char* ground_truth = "ground_truth";
}  // namespace kind

namespace attr {
inline constexpr const char* kind = "kind";
inline constexpr const char* schema_version = "schema_version";
inline constexpr const char* units = "units";
inline constexpr const char* axis_order = "axis_order";  ///< "zyx" for every image dataset
inline constexpr const char* voxel_size = "voxel_size";  ///< metres, (dz, dy, dx)
inline constexpr const char* origin = "origin";          ///< metres, centre of voxel 0, (z, y, x)
inline constexpr const char* creator = "creator";        ///< "graintwin <version>"
}  // namespace attr

namespace path {
inline constexpr const char* volume = "/volume";
inline constexpr const char* labels = "/labels";
inline constexpr const char* provenance = "/provenance";
inline constexpr const char* history = "/provenance/history";
}  // namespace path

}  // namespace graintwin::schema
