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
inline constexpr const char* fdem_checkpoint = "fdem_checkpoint";  ///< fdemrun --checkpoint
inline constexpr const char* fdem_checkpoint_part = "fdem_checkpoint_part";  ///< fdemrun --checkpoint on several ranks: rank k's file
inline constexpr const char* ground_truth = "ground_truth";
inline constexpr const char* micro = "micro";
inline constexpr const char* forces = "forces";
}  // namespace kind

namespace attr {
inline constexpr const char* kind = "kind";
inline constexpr const char* schema_version = "schema_version";
inline constexpr const char* units = "units";
inline constexpr const char* axis_order = "axis_order";  ///< "zyx" for every image dataset
inline constexpr const char* voxel_size = "voxel_size";  ///< metres, (dz, dy, dx)
inline constexpr const char* origin = "origin";          ///< metres, centre of voxel 0, (z, y, x)
inline constexpr const char* creator = "creator";        ///< "graintwin <version>"
inline constexpr const char* sh_degree = "degree";       ///< of every SH coefficient table: its degree L
inline constexpr const char* sh_basis = "basis";         ///< of every SH coefficient table: the basis' description
}  // namespace attr

namespace path {
inline constexpr const char* root = "/";  ///< holds the root attributes (kind, schema_version, creator)
inline constexpr const char* volume = "/volume";
inline constexpr const char* labels = "/labels";
inline constexpr const char* provenance = "/provenance";
inline constexpr const char* history = "/provenance/history";
}  // namespace path

}  // namespace graintwin::schema

// kind=contacts (labels2contacts), layout in docs/formats.md.
namespace graintwin::schema::contacts {
inline constexpr const char* group = "/contacts";
inline constexpr const char* pair = "/contacts/pair";                  ///< uint32 (M x 2), low first
inline constexpr const char* normal = "/contacts/normal";              ///< (M x 3) unit, low -> high: refined, else PCA
inline constexpr const char* normal_pca = "/contacts/normal_pca";      ///< (M x 3) unit, PCA of the contact voxels
inline constexpr const char* vector_area = "/contacts/vector_area";    ///< (M x 3) m^2, oriented faces low -> high
inline constexpr const char* area = "/contacts/area";                  ///< (M) m^2
inline constexpr const char* centroid = "/contacts/centroid";          ///< (M x 3) m, mean of the contact voxels
inline constexpr const char* point = "/contacts/point";                ///< (M x 3) m, refined contact point, else centroid
inline constexpr const char* branch = "/contacts/branch";              ///< (M x 3) m, centroid(high) - centroid(low)
inline constexpr const char* voxels = "/contacts/voxels";              ///< uint64 (M x 2), contact voxels of low, high
inline constexpr const char* confidence = "/contacts/confidence";      ///< (M) P(gap < tolerance); NaN unknown
inline constexpr const char* gap = "/contacts/gap";                    ///< (M) m, fitted surface gap; NaN unknown
inline constexpr const char* gap_sd = "/contacts/gap_sd";              ///< (M) m
inline constexpr const char* radius = "/contacts/radius";              ///< (M x 2) m, fitted local radii of low, high
inline constexpr const char* blur = "/contacts/blur";                  ///< (M) m, fitted edge width
inline constexpr const char* fit_rms = "/contacts/fit_rms";            ///< (M) residual rms / contrast
inline constexpr const char* fit_status = "/contacts/fit_status";      ///< uint8 (M), codes in its attribute
inline constexpr const char* accepted = "/contacts/accepted";          ///< uint8 (M), counted in Z, fabric, roses
inline constexpr const char* grain_label = "/grains/label";            ///< uint32 (N)
inline constexpr const char* grain_coordination = "/grains/coordination";  ///< uint32 (N)
inline constexpr const char* grain_touches_edge = "/grains/touches_edge";  ///< uint8 (N)
inline constexpr const char* coordination_z = "/coordination/z";       ///< uint32: Z = 0 .. max
inline constexpr const char* coordination_count = "/coordination/count";  ///< uint64: grains with that Z
inline constexpr const char* fabric_normal = "/fabric/normal";         ///< group: fabric of the normals
inline constexpr const char* fabric_branch = "/fabric/branch";         ///< group: fabric of the branch vectors
inline constexpr const char* rose_normal = "/rose/normal";             ///< group: rose counts of the normals
inline constexpr const char* rose_branch = "/rose/branch";             ///< group: rose counts of the branch vectors
// Members of each fabric group and each rose group.
inline constexpr const char* tensor = "tensor";                        ///< (3 x 3)
inline constexpr const char* principal_values = "principal_values";    ///< (3), descending
inline constexpr const char* principal_directions = "principal_directions";  ///< (3 x 3), row k = direction k
inline constexpr const char* anisotropy = "anisotropy";                ///< scalar a
inline constexpr const char* count = "count";                          ///< scalar, directions used
inline constexpr const char* theta_edges = "theta_edges";              ///< (n_theta + 1) rad
inline constexpr const char* phi_edges = "phi_edges";                  ///< (n_phi + 1) rad
inline constexpr const char* counts = "counts";                        ///< uint64 (n_theta x n_phi)
inline constexpr const char* density = "density";                      ///< (n_theta x n_phi) 1/sr
// Tables (groups) and attributes.
inline constexpr const char* grains = "/grains";                       ///< group: per-grain table (N)
inline constexpr const char* coordination = "/coordination";           ///< group: Z histogram; attributes below
inline constexpr const char* codes = "codes";                          ///< attribute of fit_status: the codes' meaning
inline constexpr const char* min_voxels = "min_voxels";                ///< attribute of /contacts
inline constexpr const char* refined = "refined";                      ///< attribute of /contacts, 0 or 1
inline constexpr const char* window_vox = "window_vox";                ///< attribute of /contacts, voxels
inline constexpr const char* gap_tolerance_vox = "gap_tolerance_vox";  ///< attribute of /contacts, voxels
inline constexpr const char* min_confidence = "min_confidence";        ///< attribute of /contacts
inline constexpr const char* coordination_mean = "mean";               ///< attribute of /coordination: mean Z
inline constexpr const char* grains_counted = "grains_counted";        ///< attribute of /coordination
inline constexpr const char* include_edge_grains = "include_edge_grains";  ///< attribute of /coordination, 0 or 1
}  // namespace graintwin::schema::contacts

// kind=tracks (shapes2tracks), layout in docs/formats.md. N tracks, T scans.
namespace graintwin::schema::tracks {
inline constexpr const char* label = "/tracks/label";                  ///< uint32 (N x T), label in each scan, 0 = missing
inline constexpr const char* centroid = "/tracks/centroid";            ///< (N x T x 3) m, NaN where missing
inline constexpr const char* displacement = "/tracks/displacement";    ///< (N x T x 3) m, from the track's first scan
inline constexpr const char* increment = "/tracks/increment";          ///< (N x T x 3) m, from the track's previous scan
inline constexpr const char* rotation = "/tracks/rotation";            ///< (N x T x 4) quaternion (w, x, y, z) from the first scan
inline constexpr const char* rotation_step = "/tracks/rotation_step";  ///< (N x T x 4) quaternion from the previous scan
inline constexpr const char* rotation_defined = "/tracks/rotation_defined";  ///< uint8 (N x T)
inline constexpr const char* rotation_misfit = "/tracks/rotation_misfit";    ///< (N x T) surface misfit / equivalent radius
inline constexpr const char* confidence = "/tracks/confidence";        ///< (N x T) of the match into scan t
inline constexpr const char* parameters = "/tracks/parameters";        ///< string (1), JSON
inline constexpr const char* group = "/tracks";                        ///< group: the per-track tables above
inline constexpr const char* steps = "/steps";                         ///< group: per-scan counts (T), entry t the step into scan t
inline constexpr const char* step_grains = "/steps/grains";            ///< uint64 (T) grains in scan t
inline constexpr const char* step_matched = "/steps/matched";          ///< uint64 (T)
inline constexpr const char* step_lost = "/steps/lost";                ///< uint64 (T)
inline constexpr const char* step_found = "/steps/found";              ///< uint64 (T)
inline constexpr const char* step_started = "/steps/started";          ///< uint64 (T)
inline constexpr const char* step_mean_confidence = "/steps/mean_confidence";  ///< (T)
inline constexpr const char* step_mean_candidates = "/steps/mean_candidates";  ///< (T), NaN for scan 0
inline constexpr const char* step_sigma_position = "/steps/sigma_position";    ///< (T) m, NaN for scan 0
inline constexpr const char* step_sigma_shape = "/steps/sigma_shape";          ///< (T), NaN for scan 0
inline constexpr const char* step_sigma_volume = "/steps/sigma_volume";        ///< (T), NaN for scan 0
inline constexpr const char* step_anchors = "/steps/anchors";                  ///< uint64 (T)
inline constexpr const char* step_backward_disagreements = "/steps/backward_disagreements";  ///< uint64 (T)
inline constexpr const char* scans = "/scans";                         ///< group: per-scan files and d50 (T)
inline constexpr const char* scan_file = "/scans/file";                ///< string (T)
inline constexpr const char* scan_d50 = "/scans/d50";                  ///< (T) m
}  // namespace graintwin::schema::tracks

// kind=fdem_model (shapes2mesh, fdemrun scenes), layout in docs/formats.md. Nn nodes, E elements,
// T surface triangles, G grains, K materials, P platens.
namespace graintwin::schema::fdem_model {
inline constexpr const char* nodes = "/nodes";                      ///< (Nn x 3) m, reference positions
inline constexpr const char* elements = "/elements";                ///< uint32 (E x W), gmsh order, W = 4 or 10, padding 2^32-1
inline constexpr const char* element_nodes = "/element_nodes";      ///< uint8 (E), 4 or 10
inline constexpr const char* element_grain = "/element_grain";      ///< uint32 (E), grain index
inline constexpr const char* triangles = "/triangles";              ///< uint32 (T x 3), outward, counter-clockwise
inline constexpr const char* triangle_grain = "/triangle_grain";    ///< uint32 (T), grain index
inline constexpr const char* grain_label = "/grains/label";         ///< uint32 (G)
inline constexpr const char* grain_kind = "/grains/kind";           ///< uint8 (G): 0 rigid, 1 tet4, 2 tet10
inline constexpr const char* grain_material = "/grains/material";   ///< uint32 (G), row of /materials
inline constexpr const char* grain_nodes = "/grains/node_range";    ///< uint32 (G x 2), half-open
inline constexpr const char* grain_elements = "/grains/element_range";    ///< uint32 (G x 2), half-open
inline constexpr const char* grain_triangles = "/grains/triangle_range";  ///< uint32 (G x 2), half-open
inline constexpr const char* materials = "/materials";              ///< group of (K) columns, names as fdem::Material
inline constexpr const char* material_name = "/materials/name";     ///< string (K)
inline constexpr const char* platen_name = "/platens/name";         ///< string (P)
inline constexpr const char* platen_point = "/platens/point";       ///< (P x 3) m
inline constexpr const char* platen_normal = "/platens/normal";     ///< (P x 3) unit, into the sample
inline constexpr const char* platen_friction = "/platens/friction"; ///< (P)
inline constexpr const char* sample = "/sample";                    ///< group, attrs below; absent = no sample cylinder
inline constexpr const char* sample_axis_xy = "axis_xy";            ///< float64[2] m
inline constexpr const char* sample_radius = "radius";              ///< m
inline constexpr const char* sample_z_range = "z_range";            ///< float64[2] m
inline constexpr const char* membrane_thickness = "membrane_thickness";  ///< m
}  // namespace graintwin::schema::fdem_model

// The per-grain figures shapes2mesh writes into its kind=fdem_model file (one row per grain of the
// model, G rows), and the run's parameters.
namespace graintwin::schema::fdem_model::mesh {
inline constexpr const char* label = "/mesh/label";                    ///< uint32 (G), in the model
inline constexpr const char* source_label = "/mesh/source_label";      ///< uint32 (G), in the shapes file
inline constexpr const char* surface_origin = "/mesh/surface_origin";  ///< uint8 (G), codes in its attribute
inline constexpr const char* path = "/mesh/path";                      ///< uint8 (G), codes in its attribute
inline constexpr const char* codes = "codes";                          ///< attribute: what each code means
inline constexpr const char* overran_budget = "/mesh/overran_budget";  ///< uint8 (G)
inline constexpr const char* kind = "/mesh/kind";                      ///< uint8 (G), as /grains/kind
inline constexpr const char* element_size = "/mesh/element_size";      ///< (G) m
inline constexpr const char* elements = "/mesh/elements";              ///< uint64 (G)
inline constexpr const char* nodes = "/mesh/nodes";                    ///< uint64 (G)
inline constexpr const char* surface_nodes = "/mesh/surface_nodes";    ///< uint64 (G)
inline constexpr const char* min_gamma = "/mesh/min_gamma";            ///< (G)
inline constexpr const char* mean_gamma = "/mesh/mean_gamma";          ///< (G)
inline constexpr const char* min_jacobian_ratio = "/mesh/min_jacobian_ratio";          ///< (G)
inline constexpr const char* inverted_after_curving = "/mesh/inverted_after_curving";  ///< uint64 (G)
inline constexpr const char* optimized = "/mesh/optimized";            ///< uint8 (G)
inline constexpr const char* inverted = "/mesh/inverted";              ///< uint64 (G)
inline constexpr const char* remeshed = "/mesh/remeshed";              ///< uint8 (G)
inline constexpr const char* volume = "/mesh/volume";                  ///< (G) m^3
inline constexpr const char* surface_volume = "/mesh/surface_volume";  ///< (G) m^3
inline constexpr const char* volume_error = "/mesh/volume_error";      ///< (G), volume / surface_volume - 1
inline constexpr const char* cut_share = "/mesh/cut_share";            ///< (G)
inline constexpr const char* gmsh_seconds = "/mesh/gmsh_seconds";      ///< (G) s
inline constexpr const char* seconds = "/mesh/seconds";                ///< (G) s
inline constexpr const char* note = "/mesh/note";                      ///< string (G)
inline constexpr const char* parameters = "/mesh/parameters";          ///< string (1), JSON
}  // namespace graintwin::schema::fdem_model::mesh

// The element quality shapes2mesh writes per grain (fdem::MeshQualityTable, G rows), and the
// run's thresholds as attributes of the group.
namespace graintwin::schema::fdem_model::mesh_quality {
inline constexpr const char* group = "/mesh/quality";
inline constexpr const char* label = "/mesh/quality/label";                      ///< uint32 (G), in the model
inline constexpr const char* min_dihedral = "/mesh/quality/min_dihedral";        ///< (G) degrees
inline constexpr const char* min_altitude = "/mesh/quality/min_altitude";        ///< (G) m
inline constexpr const char* median_altitude = "/mesh/quality/median_altitude";  ///< (G) m
inline constexpr const char* worst_element = "/mesh/quality/worst_element";      ///< uint64 (G), model element index
inline constexpr const char* step_ratio = "/mesh/quality/step_ratio";            ///< (G) min / median altitude
inline constexpr const char* below_thresholds = "/mesh/quality/below_thresholds";  ///< uint64 (G)
inline constexpr const char* min_dihedral_threshold = "min_dihedral_threshold";  ///< attribute, degrees (0: none)
inline constexpr const char* min_altitude_ratio_threshold = "min_altitude_ratio_threshold";  ///< attribute (0: none)
}  // namespace graintwin::schema::fdem_model::mesh_quality

// kind=micro (tracks2micro), layout in docs/formats.md. N grains (tracks), T states, K increments.
namespace graintwin::schema::micro {
inline constexpr const char* grain_label = "/grains/label";            ///< uint32 (N x T), label in each state, 0 = absent
inline constexpr const char* grain_d2min = "/grains/d2min";            ///< (N x K) D2min / d50^2
inline constexpr const char* grain_affine = "/grains/affine";          ///< (N x K x 3 x 3) Lambda
inline constexpr const char* grain_strain = "/grains/strain";          ///< (N x K x 6) eps^L, Voigt xx yy zz yz xz xy
inline constexpr const char* grain_eps_q = "/grains/eps_q";            ///< (N x K)
inline constexpr const char* grain_neighbours = "/grains/neighbours";  ///< uint32 (N x K)
inline constexpr const char* grain_status = "/grains/status";          ///< uint8 (N x K), codes in its attribute
inline constexpr const char* codes = "codes";                          ///< attribute of /grains/status: the codes' meaning
inline constexpr const char* grain_cluster = "/grains/cluster";        ///< int32 (N x K), -1 = not in the top fraction
inline constexpr const char* grain_coordination = "/grains/coordination";  ///< uint32 (N x T)
inline constexpr const char* increment_from = "/increments/from";      ///< uint64 (K), state
inline constexpr const char* increment_to = "/increments/to";          ///< uint64 (K), state
inline constexpr const char* increment_d50 = "/increments/d50";        ///< (K) m, of the first state
inline constexpr const char* increments = "/increments";               ///< group; /increments/<k>/... per increment
inline constexpr const char* states = "/states";                       ///< group; /states/<t>/... per state
inline constexpr const char* state_file = "/states/file";              ///< string (T)
inline constexpr const char* state_d50 = "/states/d50";                ///< (T) m
inline constexpr const char* d50_column = "d50";                       ///< member of /increments and /states: the d50 above
inline constexpr const char* parameters = "/micro/parameters";         ///< string (1), JSON
inline constexpr const char* grains = "/grains";                       ///< group: the per-grain tables
// Members of each histogram group (pdf_d2min, pdf_eps_q, displacement/x, ...) and its attributes.
inline constexpr const char* edges = "edges";
inline constexpr const char* density = "density";
inline constexpr const char* count = "count";
inline constexpr const char* histogram_used = "used";        ///< attribute: values binned
inline constexpr const char* histogram_outside = "outside";  ///< attribute: values outside the edges
// Members of each state group /states/<t>.
inline constexpr const char* rdf = "rdf";                              ///< group; the attributes below
inline constexpr const char* rdf_r = "rdf/r";                          ///< m
inline constexpr const char* rdf_g = "rdf/g";                          ///< 1
inline constexpr const char* rdf_density = "density";                  ///< attribute of rdf: points per m^3
inline constexpr const char* rdf_points = "points";                    ///< attribute of rdf: grains counted
inline constexpr const char* rdf_region = "region";                    ///< attribute of rdf: cylinder or box
inline constexpr const char* rdf_region_lo = "region_lo";              ///< attribute of rdf, m (x, y, z)
inline constexpr const char* rdf_region_hi = "region_hi";              ///< attribute of rdf, m (x, y, z)
inline constexpr const char* rdf_region_axis_xy = "region_axis_xy";    ///< attribute of rdf (cylinder), m
inline constexpr const char* rdf_region_radius = "region_radius";      ///< attribute of rdf (cylinder), m
inline constexpr const char* state_coordination = "coordination";      ///< group; attributes mean, source
inline constexpr const char* coordination_source = "source";           ///< attribute of coordination: contacts or distance
inline constexpr const char* state_coordination_z = "coordination/z";  ///< uint32: Z = 0 .. max
inline constexpr const char* state_coordination_count = "coordination/count";  ///< uint64: grains with that Z
inline constexpr const char* psd = "psd";                              ///< group (optional); attribute d50 (m)
inline constexpr const char* psd_diameter = "psd/diameter";            ///< m
inline constexpr const char* psd_percent_passing = "psd/percent_passing";  ///< %
inline constexpr const char* mean = "mean";                            ///< attribute of coordination
inline constexpr const char* d50 = "d50";                              ///< attribute of psd, m
// Members of each increment group /increments/<k>.
inline constexpr const char* pdf_d2min = "pdf_d2min";                  ///< histogram of D2min / d50^2
inline constexpr const char* pdf_eps_q = "pdf_eps_q";                  ///< histogram of eps_q
inline constexpr const char* displacement = "displacement";            ///< group of histograms x, y, z, magnitude (over d50)
/// The histograms of the displacement group: the components, then the magnitude.
inline constexpr const char* displacement_histograms[4] = {"x", "y", "z", "magnitude"};
inline constexpr const char* clusters = "clusters";                    ///< group; attributes below
inline constexpr const char* cluster_size = "clusters/size";           ///< grains per cluster
inline constexpr const char* cluster_rg = "clusters/radius_of_gyration";  ///< m
inline constexpr const char* selected = "selected";                    ///< attribute: grains in the top fraction
inline constexpr const char* threshold_d2min = "threshold_d2min";      ///< attribute: least D2min / d50^2 selected
inline constexpr const char* size_fit_valid = "size_fit_valid";        ///< attribute, 0 or 1
inline constexpr const char* size_alpha = "size_alpha";                ///< attribute, NaN unless fitted
inline constexpr const char* size_alpha_error = "size_alpha_error";    ///< attribute
inline constexpr const char* size_s_min = "size_s_min";                ///< attribute
inline constexpr const char* size_ks = "size_ks";                      ///< attribute: Kolmogorov-Smirnov distance of the fit
inline constexpr const char* size_tail = "size_tail";                  ///< attribute: clusters in the fitted tail
inline constexpr const char* fractal_dimension = "fractal_dimension";  ///< attribute
inline constexpr const char* fractal_dimension_error = "fractal_dimension_error";  ///< attribute
inline constexpr const char* rg_fit_clusters = "rg_fit_clusters";      ///< attribute: clusters in the R_g ~ s fit
}  // namespace graintwin::schema::micro

// kind=fdem_results (fdemrun), layout in docs/formats.md. R series rows, P platens, G grains,
// M contacts of a frame; frames are groups /frames/000000, /frames/000001, ...
namespace graintwin::schema::fdem_results {
inline constexpr const char* series = "/series";                      ///< group of (R) columns
inline constexpr const char* series_time = "/series/time";            ///< (R) s
inline constexpr const char* series_step = "/series/step";            ///< uint64 (R)
inline constexpr const char* series_stage = "/series/stage";          ///< uint32 (R), row of /stages
inline constexpr const char* series_kinetic = "/series/kinetic";      ///< (R) J
inline constexpr const char* series_strain = "/series/strain";        ///< (R) J
inline constexpr const char* series_contact_elastic = "/series/contact_elastic";  ///< (R) J
inline constexpr const char* series_dissipated = "/series/dissipated";            ///< (R) J, cumulative
inline constexpr const char* series_external_work = "/series/external_work";      ///< (R) J, cumulative
inline constexpr const char* series_node_contacts = "/series/node_contacts";      ///< uint64 (R)
inline constexpr const char* series_platen_force = "/series/platen_force";        ///< (R x P x 3) N, grains on platen
inline constexpr const char* series_platen_position = "/series/platen_position";  ///< (R x P x 3) m, platen point
inline constexpr const char* grains = "/grains";                      ///< group of (G) columns
inline constexpr const char* grain_label = "/grains/label";           ///< uint32 (G)
inline constexpr const char* grain_kind = "/grains/kind";             ///< uint8 (G): 0 rigid, 1 tet4, 2 tet10
inline constexpr const char* grain_mass = "/grains/mass";             ///< (G) kg
inline constexpr const char* grain_volume = "/grains/volume";         ///< (G) m^3
inline constexpr const char* platen_name = "/platens/name";           ///< string (P)
inline constexpr const char* stages = "/stages";                      ///< group of (S) columns
inline constexpr const char* stage_name = "/stages/name";             ///< string (S)
inline constexpr const char* stage_start = "/stages/start";           ///< (S) s
inline constexpr const char* parameters = "/run/parameters";          ///< string (1), JSON
inline constexpr const char* elements = "/elements";                  ///< group of (E) columns: the deformable grains' elements
inline constexpr const char* element_index = "/elements/element";     ///< uint32 (E), the element's row in the model (kind=fdem_model /elements)
inline constexpr const char* element_grain = "/elements/grain";       ///< uint32 (E), its grain's row of /grains
inline constexpr const char* frames = "/frames";                      ///< group; attrs time, step per frame group
// Attributes of each frame group.
inline constexpr const char* frame_time = "time";                     ///< s
inline constexpr const char* frame_step = "step";                     ///< the solver's step count
inline constexpr const char* frame_axial_strain = "axial_strain";     ///< triaxial scenes: eps_1 from the start of shearing
inline constexpr const char* frame_stress_difference = "love_weber_difference";  ///< median relative difference, Love-Weber against element stress
// Members of each frame group.
inline constexpr const char* frame_grains = "grains";                 ///< group of the frame's (G) columns below
inline constexpr const char* frame_centroid = "grains/centroid";      ///< (G x 3) m
inline constexpr const char* frame_rotation = "grains/rotation";      ///< (G x 4) quaternion (w, x, y, z) from the reference
inline constexpr const char* frame_stress = "grains/stress";          ///< (G x 3 x 3) Pa, compression positive, volume average
inline constexpr const char* frame_love_weber_stress = "grains/love_weber_stress";  ///< (G x 3 x 3) Pa, compression positive, of the contact and boundary forces
inline constexpr const char* frame_element_stress = "elements/stress";  ///< float32 (E x 3 x 3) Pa, compression positive, rows of /elements
inline constexpr const char* frame_velocity = "grains/velocity";      ///< (G x 3) m/s, centroid velocity (half step)
inline constexpr const char* frame_spin = "grains/spin";              ///< (G x 3) rad/s, angular velocity, world axes (half step)
inline constexpr const char* contact_pair = "contacts/pair";          ///< uint32 (M x 2) labels, low first; platen contacts: (label, 0)
inline constexpr const char* contact_platen = "contacts/platen";      ///< int32 (M), platen row, -1 for grain pairs
inline constexpr const char* contact_point = "contacts/point";        ///< (M x 3) m
inline constexpr const char* contact_normal = "contacts/normal";      ///< (M x 3) unit, first -> second (grain -> platen)
inline constexpr const char* contact_force = "contacts/force";        ///< (M x 3) N, on the second (the platen)
inline constexpr const char* contact_overlap = "contacts/overlap";    ///< (M) m
}  // namespace graintwin::schema::fdem_results

// fdemrun's checkpoints (kind schema::kind::fdem_checkpoint), layout in docs/formats.md: the
// solver's state under /state, the contact history and the sample boundary in its groups, a
// triaxial test's progress under /triaxial. Member names are relative to their group.
namespace graintwin::schema::fdem_checkpoint {
inline constexpr const char* scene_digest = "scene_digest";  ///< root attribute: the scene and model it was written for
// Root attributes of a checkpoint written by several ranks (its main file and each part).
inline constexpr const char* parts = "parts";                ///< the ranks that wrote it, one file each (1 or absent: one file)
inline constexpr const char* part = "part";                  ///< a part's rank, 1 .. parts - 1 (the main file is rank 0's)
inline constexpr const char* part_files = "/part_files";     ///< main file: the parts' file names (strings), beside it, rank 1 first
inline constexpr const char* part_step = "step";             ///< a part's solver step: the same as the main file's /state step
inline constexpr const char* state = "/state";               ///< group: the solver's state
// Attributes of /state.
inline constexpr const char* step = "step";
inline constexpr const char* time = "time";                        ///< s
inline constexpr const char* dissipated = "dissipated";            ///< J
inline constexpr const char* external_work = "external_work";      ///< J
inline constexpr const char* energy_input = "energy_input";        ///< J
inline constexpr const char* last_time_step = "last_time_step";    ///< s, the step node_force belongs to (models with deformable grains)
// Members of /state.
inline constexpr const char* grains = "grains";                    ///< uint32 (n): in a part, the grains whose rows it holds (below: their nodes grain by grain)
inline constexpr const char* node_position = "x";                  ///< (nodes x 3) m
inline constexpr const char* node_velocity = "v";                  ///< (nodes x 3) m/s, at the half step
inline constexpr const char* bodies = "bodies";                    ///< (G x 13) rigid bodies
inline constexpr const char* platens = "platens";                  ///< (P x 10) point, normal, velocity, friction
inline constexpr const char* platen_force = "platen_force";        ///< (P x 3) N, the last step's
inline constexpr const char* rigid_loads = "rigid_loads";          ///< (G x 12) force and moment sum of rigid grains
inline constexpr const char* node_force = "node_force";            ///< (nodes x 3) N, the last step's forces on deformable grains' nodes
inline constexpr const char* contact = "contact";                  ///< group: the contact history, members below
inline constexpr const char* boundary = "boundary";                ///< group: the sample boundary, members below
// Attributes and members of /state/contact.
inline constexpr const char* history_entries = "entries";                ///< attribute: rows of pair, node, spring
inline constexpr const char* ball_entries = "ball_entries";              ///< attribute: rows of ball_grain, ball_spring
inline constexpr const char* record_entries = "record_entries";          ///< attribute: rows of record_pair, record_values
inline constexpr const char* deep_pair_entries = "deep_pair_entries";    ///< attribute: rows of deep_pair, deep_pair_depth
inline constexpr const char* history_pair = "pair";                      ///< uint32 (n x 2) grains
inline constexpr const char* history_node = "node";                      ///< uint32 (n)
inline constexpr const char* history_spring = "spring";                  ///< (n x 3) N
inline constexpr const char* history_offset = "offset";                  ///< (n) m, kept initial overlap
inline constexpr const char* ball_grain = "ball_grain";                  ///< uint32 (n x 2) membrane ball, grain
inline constexpr const char* ball_spring = "ball_spring";                ///< (n x 3) N
inline constexpr const char* record_pair = "record_pair";                ///< uint32 (n x 2), the last step's contacts
inline constexpr const char* record_values = "record_values";            ///< (n x 11) point, normal, force, overlap, stiffness (10 before stiffness)
inline constexpr const char* deep_pair = "deep_pair";                    ///< uint32 (n x 2)
inline constexpr const char* deep_pair_depth = "deep_pair_depth";        ///< (n) m
// Attributes and members of /state/boundary.
inline constexpr const char* wall = "wall";                        ///< attribute: radius, radial velocity, radial force, radial stiffness (3 values before stiffness)
inline constexpr const char* boundary_platens = "platens";         ///< attribute: z bottom, z top, their velocities
inline constexpr const char* pressure = "pressure";                ///< attribute, Pa
inline constexpr const char* ball_radius = "ball_radius";          ///< attribute, m
inline constexpr const char* membrane_frame = "membrane_frame";    ///< attribute: centre radius, z min, z max, density scaling, started
inline constexpr const char* ball_position = "ball_x";             ///< (balls x 3) m
inline constexpr const char* ball_velocity = "ball_v";             ///< (balls x 3) m/s
inline constexpr const char* ball_spin = "ball_spin";              ///< (balls x 3)
inline constexpr const char* bond_shear = "bond_shear";            ///< (bonds x 3)
inline constexpr const char* ball_motion = "ball_motion";          ///< uint8 (balls)
inline constexpr const char* ball_clamp_group = "ball_clamp_group";  ///< uint8 (balls)
// A triaxial test's progress.
inline constexpr const char* triaxial = "/triaxial";               ///< group, attributes below
inline constexpr const char* procedure = "procedure";              ///< phase, step, settled, released, h0
inline constexpr const char* run = "run";                          ///< consolidation steps, membrane steps, next frame, max kinetic ratio
inline constexpr const char* start = "start";                      ///< the measurements at the start of shearing
}  // namespace graintwin::schema::fdem_checkpoint

// kind=forces (fdem2forces), layout in docs/formats.md. G grains, F analysed frames, W strain
// windows; per-frame groups /frames/<f>/pdf and /frames/<f>/rose (f = 0..F-1, row of /frames/index).
namespace graintwin::schema::forces {
inline constexpr const char* grain_label = "/grains/label";            ///< uint32 (G)
inline constexpr const char* grain_q = "/grains/q";                    ///< (G x F) Pa; attribute `definition`
inline constexpr const char* grain_volatility = "/grains/volatility";  ///< (G x W)
inline constexpr const char* grain_d2min = "/grains/d2min";            ///< (G x W) D2min / d50^2; attribute `source`
inline constexpr const char* definition = "definition";                ///< attribute of /grains/q and /grains/volatility
inline constexpr const char* d2min_source = "source";                  ///< attribute of /grains/d2min: where D2min came from
inline constexpr const char* grains = "/grains";                       ///< group: the per-grain tables
inline constexpr const char* frames = "/frames";                       ///< group; /frames/<f>/pdf, /frames/<f>/rose
inline constexpr const char* frame_index = "/frames/index";            ///< uint64 (F), frame of the results file
inline constexpr const char* frame_time = "/frames/time";              ///< (F) s
inline constexpr const char* frame_contacts = "/frames/contacts";      ///< uint64 (F), grain-grain contacts
inline constexpr const char* frame_platen_contacts = "/frames/platen_contacts";  ///< uint64 (F)
inline constexpr const char* frame_mean_force = "/frames/mean_normal_force";     ///< (F) N, <f_n>
inline constexpr const char* frame_strong = "/frames/strong_contacts";           ///< uint64 (F), f_n >= threshold <f_n>
inline constexpr const char* chain_threshold = "chain_threshold";                ///< attribute of /frames/strong_contacts
inline constexpr const char* frame_strong_scale = "/frames/strong_scale";        ///< (F) exponential scale of f >= 1
inline constexpr const char* frame_strong_scale_error = "/frames/strong_scale_error";  ///< (F)
inline constexpr const char* frame_weak_theta = "/frames/weak_theta";            ///< (F) P(f) ~ f^theta for f < 1
inline constexpr const char* frame_weak_theta_error = "/frames/weak_theta_error";  ///< (F)
inline constexpr const char* windows = "/windows";                     ///< group: the per-window tables
inline constexpr const char* window_from = "/windows/from";            ///< uint64 (W), frame
inline constexpr const char* window_to = "/windows/to";                ///< uint64 (W), frame
inline constexpr const char* window_r = "/windows/pearson_r";          ///< (W) volatility against D2min
inline constexpr const char* window_p = "/windows/p_value";            ///< (W) two-sided
inline constexpr const char* window_count = "/windows/count";          ///< uint64 (W) grains in the correlation
inline constexpr const char* parameters = "/forces/parameters";        ///< string (1), JSON
// Members of each frame group /frames/<f>.
inline constexpr const char* frame_pdf = "pdf";                        ///< histogram of f_n / <f_n> (schema::micro's members)
inline constexpr const char* frame_rose = "rose";                      ///< group, members below
// Members of each frame's rose group (the pdf group uses schema::micro's edges/count/density).
inline constexpr const char* rose_theta_edges = "theta_edges";       ///< rad
inline constexpr const char* rose_phi_edges = "phi_edges";           ///< rad
inline constexpr const char* rose_count = "count";                   ///< uint64 (n_theta x n_phi)
inline constexpr const char* rose_mean_force = "mean_force";         ///< (n_theta x n_phi) N, NaN in empty bins
}  // namespace graintwin::schema::forces

// kind=labels (ct2labels), layout in docs/formats.md. N grains; the label image is path::labels.
namespace graintwin::schema::labels {
inline constexpr const char* grains = "/grains";                           ///< group: the grain table
inline constexpr const char* grain_label = "/grains/label";                ///< uint32 (N), 1..N
inline constexpr const char* grain_voxels = "/grains/voxels";              ///< uint64 (N)
inline constexpr const char* grain_volume = "/grains/volume";              ///< (N) m^3
inline constexpr const char* grain_centroid = "/grains/centroid";          ///< (N x 3) m, (x, y, z)
inline constexpr const char* grain_bbox = "/grains/bbox";                  ///< uint64 (N x 6) voxels, half-open (z0, y0, x0, z1, y1, x1)
inline constexpr const char* grain_touches_edge = "/grains/touches_edge";  ///< uint8 (N)
inline constexpr const char* sample = "/sample";                           ///< group; the attributes below
inline constexpr const char* cylinder_centre_xy = "cylinder_centre_xy";    ///< attribute of /sample, float64[2] m
inline constexpr const char* cylinder_radius = "cylinder_radius";          ///< attribute of /sample, m; NaN = unbounded
inline constexpr const char* cylinder_z_range = "cylinder_z_range";        ///< attribute of /sample, float64[2] m; NaN = unbounded
inline constexpr const char* sample_void_ratio = "/sample/void_ratio";     ///< (1) e = V_void / V_solid
inline constexpr const char* sample_solid_volume = "/sample/solid_volume";  ///< (1) m^3
inline constexpr const char* sample_void_volume = "/sample/void_volume";   ///< (1) m^3
inline constexpr const char* parameters = "/segmentation/parameters";      ///< string (1), JSON
}  // namespace graintwin::schema::labels

// The triaxial measurements of fdemrun's time series (a scene with [triaxial]; docs/fdem_triaxial.md),
// read by fdem::read_triaxial_series for the report; one value per series row, stresses and strains
// compression positive. Strains are from the start of shearing (H0, V0) and NaN before it; the
// inertial number is NaN before it too.
namespace graintwin::schema::fdem_results {
inline constexpr const char* series_axial_strain = "/series/axial_strain";            ///< (R) eps_1 = ln(H0 / H)
inline constexpr const char* series_volumetric_strain = "/series/volumetric_strain";  ///< (R) eps_v = ln(V0 / V), eq. 27
inline constexpr const char* series_stress_ratio = "/series/stress_ratio";            ///< (R) sigma_1 / sigma_3
inline constexpr const char* series_axial_stress = "/series/axial_stress";            ///< (R) Pa, sigma_1 from the platens
inline constexpr const char* series_lateral_stress = "/series/lateral_stress";        ///< (R) Pa, sigma_3: wall or membrane
inline constexpr const char* series_height = "/series/height";                        ///< (R) m, platen gap H
inline constexpr const char* series_volume = "/series/volume";                        ///< (R) m^3, eq. 27
inline constexpr const char* series_volume_radial = "/series/volume_radial";          ///< (R) m^3, eq. 28
inline constexpr const char* series_kinetic_ratio = "/series/kinetic_ratio";          ///< (R) kinetic / elastic energy
inline constexpr const char* series_inertial_number = "/series/inertial_number";      ///< (R) eps_1' d50 sqrt(rho / p)
/// Membrane ball centres of a frame (B x 3, m), in frames taken while the membrane is on.
inline constexpr const char* frame_membrane_position = "membrane/position";
}  // namespace graintwin::schema::fdem_results

// kind=shapes (labels2shapes), layout in docs/formats.md. N grains, SH degree L.
namespace graintwin::schema::shapes {
inline constexpr const char* grain_label = "/grains/label";                          ///< uint32 (N)
inline constexpr const char* grain_voxels = "/grains/voxels";                        ///< uint64 (N)
inline constexpr const char* grain_volume = "/grains/volume";                        ///< (N) m^3
inline constexpr const char* grain_centroid = "/grains/centroid";                    ///< (N x 3) m
inline constexpr const char* grain_surface_area = "/grains/surface_area";            ///< (N) m^2
inline constexpr const char* grain_equivalent_diameter = "/grains/equivalent_diameter";  ///< (N) m
inline constexpr const char* grain_sphericity = "/grains/sphericity";                ///< (N)
inline constexpr const char* grain_semi_axes = "/grains/semi_axes";                  ///< (N x 3) m, a >= b >= c
inline constexpr const char* grain_axes = "/grains/axes";                            ///< (N x 3 x 3), [i, k, :] direction of axis k
inline constexpr const char* grain_aspect_ratio = "/grains/aspect_ratio";            ///< (N) a / c
inline constexpr const char* grain_elongation = "/grains/elongation";                ///< (N) b / a
inline constexpr const char* grain_flatness = "/grains/flatness";                    ///< (N) c / b
inline constexpr const char* coeffs = "/sh/coeffs";                                  ///< (N x (L+1)^2) m; attributes sh_degree, sh_basis, origin
inline constexpr const char* coeffs_origin = "origin";                               ///< attribute of /sh/coeffs: the expansion's origin
inline constexpr const char* degree = "/sh/degree";                                  ///< int32 (N), degree kept
inline constexpr const char* invariants = "/sh/invariants";                          ///< (N x (L+1)) m
inline constexpr const char* rms_error = "/sh/rms_error";                            ///< (N) / equivalent radius
inline constexpr const char* max_error = "/sh/max_error";                            ///< (N) / equivalent radius
inline constexpr const char* volume_error = "/sh/volume_error";                      ///< (N) (V_sh - V) / V
inline constexpr const char* multi_exit_fraction = "/sh/multi_exit_fraction";    ///< (N) share of re-entrant rays
inline constexpr const char* hidden_void_fraction = "/sh/hidden_void_fraction";  ///< (N) void inside the radial surface / V
inline constexpr const char* reentry_depth = "/sh/reentry_depth";                ///< (N) m, deepest missed surface
inline constexpr const char* edge_sigma = "/sh/edge_sigma";                      ///< (N) m, edge width (Gaussian sigma)
inline constexpr const char* flags = "/sh/flags";                                ///< uint8 (N); attribute bits
inline constexpr const char* flag_bits = "bits";                                 ///< attribute of /sh/flags: the bits' meaning
inline constexpr const char* psd_diameter = "/psd/diameter";                     ///< m
inline constexpr const char* psd_percent_passing = "/psd/percent_passing";       ///< %
inline constexpr const char* psd_d50 = "/psd/d50";                               ///< (1) m
inline constexpr const char* parameters = "/shapes/parameters";                  ///< string (1), JSON
}  // namespace graintwin::schema::shapes

// kind=ground_truth (ctsynth: truth_NNN.h5 beside scan_NNN.h5), layout in docs/formats.md. N
// grains, M contact pairs; the label image is path::labels.
namespace graintwin::schema::ground_truth {
// Root attributes.
inline constexpr const char* scan_index = "scan_index";
inline constexpr const char* axial_strain = "axial_strain";
inline constexpr const char* sample_height = "sample_height";          ///< m
inline constexpr const char* sample_radius = "sample_radius";          ///< m
inline constexpr const char* solid_fraction = "solid_fraction";
inline constexpr const char* void_ratio = "void_ratio";
inline constexpr const char* contact_tolerance = "contact_tolerance";  ///< m
inline constexpr const char* loading = "loading";                      ///< "prescribed" or "simulated"
inline constexpr const char* stress_ratio = "stress_ratio";            ///< simulated loading: sigma_1 / sigma_3
inline constexpr const char* volumetric_strain = "volumetric_strain";  ///< simulated loading: ln(V0 / V)
inline constexpr const char* grains = "/grains";                       ///< the grain table's group
inline constexpr const char* contacts = "/contacts";                   ///< the contact table's group
inline constexpr const char* curve = "/loading";                       ///< the loading curve's group
inline constexpr const char* grain_label = "/grains/label";            ///< uint32 (N), 1..N
inline constexpr const char* grain_centroid = "/grains/centroid";      ///< (N x 3) m
inline constexpr const char* grain_orientation = "/grains/orientation";  ///< (N x 4) quaternion; attribute convention
inline constexpr const char* orientation_convention = "convention";    ///< attribute of /grains/orientation
inline constexpr const char* grain_volume = "/grains/volume";          ///< (N) m^3
inline constexpr const char* grain_equivalent_diameter = "/grains/equivalent_diameter";  ///< (N) m
inline constexpr const char* grain_sphericity = "/grains/sphericity";  ///< (N)
inline constexpr const char* grain_aspect_ratio = "/grains/aspect_ratio";  ///< (N)
inline constexpr const char* grain_multi_exit_fraction = "/grains/multi_exit_fraction";    ///< (N), series with non-star grains
inline constexpr const char* grain_hidden_void_fraction = "/grains/hidden_void_fraction";  ///< (N), the same
inline constexpr const char* grain_reentry_depth = "/grains/reentry_depth";                ///< (N) m, the same
inline constexpr const char* sh_coeffs = "/sh/coeffs";                 ///< (N x (L+1)^2) m, world frame; attributes sh_degree, sh_basis
inline constexpr const char* sh_coeffs_body = "/sh/coeffs_body";       ///< (N x (L+1)^2) m, body frame
inline constexpr const char* sh_invariants = "/sh/invariants";         ///< (N x (L+1)) m
inline constexpr const char* contact_pair = "/contacts/pair";          ///< uint32 (M x 2), low first
inline constexpr const char* contact_normal = "/contacts/normal";      ///< (M x 3) unit, low -> high
inline constexpr const char* contact_point = "/contacts/point";        ///< (M x 3) m
inline constexpr const char* contact_overlap = "/contacts/overlap";    ///< (M) m, > 0 interpenetration
inline constexpr const char* contact_touching = "/contacts/touching";  ///< uint8 (M)
inline constexpr const char* contact_force = "/contacts/force";        ///< (M x 3) N on the higher label; simulated loading
// Simulated loading: the test's stress-strain curve from the start of shearing (K rows, one per
// recorded step; the same in every scan of the series).
inline constexpr const char* curve_axial_strain = "/loading/axial_strain";            ///< (K) ln(H0 / H)
inline constexpr const char* curve_stress_ratio = "/loading/stress_ratio";            ///< (K) sigma_1 / sigma_3
inline constexpr const char* curve_volumetric_strain = "/loading/volumetric_strain";  ///< (K) ln(V0 / V)
}  // namespace graintwin::schema::ground_truth

// series.json (ctsynth, beside a series' scans; JSON), layout in docs/formats.md: what each scan
// shows and how the series was made. Written by synth/series, read by io/series_record.
namespace graintwin::schema::series_record {
inline constexpr const char* file_name = "series.json";
inline constexpr const char* scans = "scans";                ///< one object per scan, in order
inline constexpr const char* scan = "scan";                  ///< the scan's file stem (scan_NNN)
inline constexpr const char* truth = "truth";                ///< its truth's file stem (truth_NNN)
inline constexpr const char* axial_strain = "axial_strain";  ///< applied axial strain (compression positive)
inline constexpr const char* loading = "loading";            ///< "prescribed" or "simulated"
inline constexpr const char* packing = "packing";
inline constexpr const char* history = "history";
}  // namespace graintwin::schema::series_record

// validation.json (validate; JSON, not HDF5), layout in docs/formats.md: the sections of a run's
// error budget against ctsynth's ground truth. Each section holds its summary numbers and, under
// `scans` or `increments`, the per-scan or per-increment lines (field names in docs/validate.md).
namespace graintwin::schema::validation {
inline constexpr const char* kind = "validation";  ///< value of the top-level key attr::kind
inline constexpr int version = 1;                   ///< value of the top-level key attr::schema_version
inline constexpr const char* run = "run";
inline constexpr const char* series = "series";
inline constexpr const char* segmentation = "segmentation";
inline constexpr const char* contacts = "contacts";
inline constexpr const char* shapes = "shapes";
inline constexpr const char* tracking = "tracking";
inline constexpr const char* d2min = "d2min";
inline constexpr const char* eps_q = "eps_q";
inline constexpr const char* clusters = "clusters";
inline constexpr const char* twin = "twin";
inline constexpr const char* scans = "scans";            ///< per-scan lines of segmentation, contacts, shapes
inline constexpr const char* increments = "increments";  ///< per-increment lines of tracking and d2min
inline constexpr const char* history = "history";        ///< the inputs' provenance lines, then validate's own
}  // namespace graintwin::schema::validation
