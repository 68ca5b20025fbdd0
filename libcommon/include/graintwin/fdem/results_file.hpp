#pragma once
// `kind=fdem_results` files (docs/formats.md), written by fdemrun while it runs: frames go to disk
// as they are taken (grain centroids, rotations, velocities, volume-averaged stresses; contacts
// with pair, point, normal, force), the time series (energies, platen forces and positions) at the
// end. Checkpoints (`kind=fdem_checkpoint`) hold the solver state and the contact history.
#include <Eigen/Core>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "graintwin/fdem/solver.hpp"
#include "graintwin/fdem/triaxial.hpp"
#include "graintwin/io/h5file.hpp"

namespace graintwin::io {
class AtomicOutput;
}

namespace graintwin::fdem {

/// A triaxial test's part of a series row.
struct TriaxialRow {
  TriaxialMeasure measure;  ///< after the step
  double inertial_number = std::numeric_limits<double>::quiet_NaN();  ///< while shearing
};

/// One time-series row: the energies at the start of a step and the platen state of that step.
struct SeriesRow {
  std::uint64_t step = 0;
  double time = 0;
  std::uint32_t stage = 0;
  Energies energies;
  std::uint64_t node_contacts = 0;
  std::vector<Eigen::Vector3d> platen_force, platen_position;
  std::optional<TriaxialRow> triaxial;
};

class ResultsWriter {
 public:
  /// Creates `path` and writes the grain and platen tables; `parameters_json` is written by finish().
  ResultsWriter(const std::filesystem::path& path, const Solver& solver, std::string parameters_json);
  /// Replaces the run's parameters (e.g. with what the run found out: steps taken, scalings).
  void set_parameters(std::string parameters_json) { parameters_ = std::move(parameters_json); }
  /// Names the next loading stage and its start time (s); rows refer to stages by their order.
  void add_stage(const std::string& name, double start);
  /// Books the step of `dt` just taken (its report holds the energies at its start), with the
  /// triaxial measurement after it in a triaxial test (every row of a run has one or none has).
  void add_row(const Solver& solver, const StepReport& report, std::uint32_t stage, double dt,
               const std::optional<TriaxialRow>& triaxial = std::nullopt);
  /// The reference of the triaxial strains (the start of shearing): rows booked from now on get
  /// eps_1 = ln(H0 / H) and eps_v = ln(V0 / V), earlier rows NaN.
  void set_strain_reference(double height, double volume);
  /// Writes frame /frames/<k> of the solver's current state; with a membrane on `boundary`, also
  /// its ball centres; `axial_strain` becomes the frame's attribute of that name.
  void add_frame(const Solver& solver, const TriaxialBoundary* boundary = nullptr,
                 std::optional<double> axial_strain = std::nullopt);
  std::size_t frames() const { return frames_; }
  /// Per frame, the median over the deformable grains that carry stress of the relative difference
  /// between their Love-Weber and element-averaged stresses (median_stress_difference); NaN where
  /// none does.
  const std::vector<double>& stress_differences() const { return stress_differences_; }
  /// Wall-clock seconds spent writing frames so far.
  double frame_seconds() const { return frame_seconds_; }
  /// Writes the series, the stages, the parameters and the provenance; the file is complete afterwards.
  void finish(const std::vector<std::string>& history);

 private:
  void write_triaxial_columns();

  io::H5File file_;
  std::size_t platens_ = 0;
  std::size_t frames_ = 0;
  std::vector<double> stress_differences_;
  double frame_seconds_ = 0;
  std::vector<SeriesRow> rows_;
  std::string parameters_;
  std::vector<std::string> stage_names_;
  std::vector<double> stage_starts_;
  std::optional<std::size_t> reference_row_;  ///< first row of the strains
  double reference_height_ = 0, reference_volume_ = 0;
};

/// ||a - b|| / max(||a||, ||b||) (Frobenius norms); NaN when both are zero.
double relative_stress_difference(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b);
/// The median of relative_stress_difference(element_average[g], love_weber[g]) over the deformable
/// grains g (kind not rigid) where it is defined; NaN when it is nowhere.
double median_stress_difference(std::span<const Eigen::Matrix3d> element_average, std::span<const Eigen::Matrix3d> love_weber,
                                std::span<const Grain> grains);

/// Frame k of a results file, as stored.
struct ResultsFrame {
  double time = 0;
  std::uint64_t step = 0;
  std::vector<double> centroid, rotation, stress, velocity;  ///< G x 3, G x 4, G x 9, G x 3
  /// G x 9 Love-Weber stress of each grain's contact and boundary forces (compression positive);
  /// empty in files written before it was kept. A rigid grain's equals its `stress`.
  std::vector<double> love_weber_stress;
  std::vector<double> spin;  ///< G x 3 angular velocity (rad/s); empty in files written before it was kept
  std::vector<std::uint32_t> pair;                           ///< M x 2
  std::vector<std::int32_t> platen;                          ///< M
  std::vector<double> point, normal, force, overlap;         ///< M x 3, M x 3, M x 3, M
  /// The frame's log axial strain (a triaxial test's frames); NaN when the frame has none.
  double axial_strain = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> membrane_position;  ///< B x 3 ball centres (m); empty without a membrane
};
struct ResultsSeries {
  std::vector<double> time, kinetic, strain, contact_elastic, dissipated, external_work;
  std::vector<std::uint64_t> step;
  std::vector<double> platen_force, platen_position;  ///< R x P x 3
};
/// UsageError naming the file when it is not a results file; DataError when a table is missing.
ResultsSeries read_results_series(const std::filesystem::path& path);
/// The curves of a triaxial test (a scene with [triaxial]): log axial and volumetric strains and
/// the stress ratio sigma_1 / sigma_3 over the shearing rows of the series (the strains are NaN
/// before shearing starts). `missing` names the columns the file lacks (then the curves are empty).
struct TriaxialSeries {
  std::vector<double> axial_strain, volumetric_strain, stress_ratio;
  std::vector<std::uint64_t> step;  ///< the rows' steps
  std::vector<std::string> missing;
};
/// UsageError naming the file when it is not a results file; DataError when the columns differ in length.
TriaxialSeries read_triaxial_series(const std::filesystem::path& path);
/// The checks the report makes on the tables of an open kind=fdem_results file before it draws
/// from them (io/table_checks): the /grains, /series and /stages columns agree in length, no column
/// holds infinity, and the series' time and kinetic energy and every frame's grain centroids and
/// rotations hold no NaN either. DataError naming the file and the column.
void check_results_tables(const io::H5File& file);
std::size_t results_frame_count(const std::filesystem::path& path);
ResultsFrame read_results_frame(const std::filesystem::path& path, std::size_t frame);
/// The grain table of a results file: labels and kinds (GrainKind codes), one row per grain of
/// every frame.
struct ResultsGrains {
  std::vector<std::uint32_t> label;
  std::vector<GrainKind> kind;
};
ResultsGrains read_results_grains(const std::filesystem::path& path);
/// The element stresses of frame k: one row per element of the grains that carry stress (the
/// deformable ones, and rigid ones run with [run] rigid_stress = "elastostatic"), in model order.
/// Read apart from read_results_frame: at 16 000 grains of ~170 elements a frame holds 98 MB of them.
struct FrameElementStress {
  std::vector<std::uint32_t> element;  ///< E: row in the model's element table
  std::vector<std::uint32_t> grain;    ///< E: grain row (of /grains and the frames' grain columns)
  std::vector<float> stress;           ///< E x 9, Pa, volume average over the element, compression positive
};
/// DataError naming the file when the frame or the element table is missing (files written before
/// element stresses were kept; rerun fdemrun).
FrameElementStress read_frame_element_stress(const std::filesystem::path& path, std::size_t frame);

/// Writes a checkpoint (solver state, contact history, `scene_digest`) to `path`; `also` adds more
/// (a triaxial test's progress).
void write_checkpoint(const std::filesystem::path& path, const Solver& solver, const std::string& scene_digest,
                      const std::function<void(io::H5File&)>& also = {});
/// Restores a checkpoint into `solver` and hands the file to `also`; UsageError when it was written
/// for another scene. A checkpoint written by several ranks is its main file at `path` and its
/// parts beside it (checkpoint_part_path): all are read, on any rank count. UsageError when a part
/// is missing, DataError when one belongs to another checkpoint. Its parts are declared inputs
/// (io::declare_input), so no output may replace them.
void read_checkpoint(const std::filesystem::path& path, Solver& solver, const std::string& scene_digest,
                     const std::function<void(const io::H5File&)>& also = {});

// A checkpoint written by R ranks at once (docs/formats.md, fdem_checkpoint): rank 0 writes the
// main file at the checkpoint's path, what every rank holds alike and the rows of its own grains;
// every other rank k the rows of its grains to a part beside it. Parts come in two sets, a and b,
// that take turns, so that the last whole checkpoint stays whole while the next is written.

/// Rank k's part (1 <= k) in `set` ('a' or 'b') of the checkpoint at `path`: run.ckpt.h5 ->
/// run.ckpt.rank1-a.h5.
std::filesystem::path checkpoint_part_path(const std::filesystem::path& path, int rank, char set);
/// Rank `rank`'s file of a checkpoint of `ranks` ranks at `path`, written under a temporary name
/// beside its place (rank 0's the main file, naming the parts of `set`; rank k's its part of
/// `set`): the rows of `grains` (the grains this rank advanced in the last step, sorted), and on
/// rank 0 the shared state and `also`'s. place() puts it where it belongs (a rank places its part
/// before rank 0 places the main file that names it); unplaced, it is removed.
class CheckpointPartFile {
 public:
  CheckpointPartFile(const std::filesystem::path& path, const Solver& solver, const std::string& scene_digest,
                     const std::vector<std::uint32_t>& grains, int rank, int ranks, char set,
                     const std::function<void(io::H5File&)>& also = {});
  ~CheckpointPartFile();
  CheckpointPartFile(const CheckpointPartFile&) = delete;
  CheckpointPartFile& operator=(const CheckpointPartFile&) = delete;
  void place();
  /// Removes this rank's part of the other set (k > 0), once the main file names this one.
  void drop_other_set() const;

 private:
  std::filesystem::path path_;
  int rank_;
  char set_;
  std::unique_ptr<io::AtomicOutput> out_;
};
/// UsageError unless every part file a checkpoint of `ranks` ranks at `path` may write is allowed
/// as an output (io::check_output_allowed).
void check_checkpoint_parts_allowed(const std::filesystem::path& path, int ranks, bool force);

}  // namespace graintwin::fdem
