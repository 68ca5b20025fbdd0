#include "graintwin/fdem/results_file.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "graintwin/core/error.hpp"
#include "graintwin/core/interval.hpp"
#include "graintwin/core/statistics.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/table_checks.hpp"
#include "graintwin/io/volume_io.hpp"

namespace graintwin::fdem {
namespace ck = schema::fdem_checkpoint;
namespace sr = schema::fdem_results;
using io::units;

namespace {

std::string frame_group(std::size_t k) { return fmt::format("{}/{:06d}", sr::frames, k); }

void push(std::vector<double>& out, const Eigen::Vector3d& v) { out.insert(out.end(), {v[0], v[1], v[2]}); }

/// Appends the 9 components of `s`, compression positive (docs/conventions.md), row by row.
template <class T>
void push_compression(std::vector<T>& out, const Eigen::Matrix3d& s) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) out.push_back(static_cast<T>(-s(i, j)));
}

}  // namespace

ResultsWriter::ResultsWriter(const std::filesystem::path& path, const Solver& solver, std::string parameters_json)
    : file_(io::H5File::create(path)), platens_(solver.model().platens.size()), parameters_(std::move(parameters_json)) {
  io::write_root_attrs(file_, schema::kind::fdem_results);
  const Model& m = solver.model();
  std::vector<std::uint32_t> label;
  std::vector<std::uint8_t> kind;
  std::vector<double> mass, volume;
  for (std::size_t g = 0; g < m.grains.size(); ++g) {
    label.push_back(m.grains[g].label);
    kind.push_back(static_cast<std::uint8_t>(m.grains[g].kind));
    mass.push_back(solver.body(g).mass);
    volume.push_back(solver.body(g).volume);
  }
  file_.write(sr::grain_label, label);
  file_.write(sr::grain_kind, kind);
  file_.write(sr::grain_mass, mass, units("kg"));
  file_.write(sr::grain_volume, volume, units("m^3"));
  // The rows of every frame's element stresses: the elements of the grains that carry stress (the
  // deformable ones, and the rigid ones with their elastostatic stress), in model order.
  std::vector<std::uint32_t> element, element_grain;
  for (std::size_t g = 0; g < m.grains.size(); ++g)
    if (solver.carries_element_stress(g))
      for (std::uint32_t e = m.grains[g].element_begin; e < m.grains[g].element_end; ++e)
        element.push_back(e), element_grain.push_back(static_cast<std::uint32_t>(g));
  file_.write(sr::element_index, element);
  file_.write(sr::element_grain, element_grain);
  std::vector<std::string> names;
  for (const Platen& p : m.platens) names.push_back(p.name);
  file_.write_strings(sr::platen_name, names);
  file_.ensure_group(sr::frames);
}

void ResultsWriter::add_stage(const std::string& name, double start) {
  stage_names_.push_back(name);
  stage_starts_.push_back(start);
}

void ResultsWriter::set_strain_reference(double height, double volume) {
  reference_row_ = rows_.size();
  reference_height_ = height;
  reference_volume_ = volume;
}

void ResultsWriter::add_row(const Solver& solver, const StepReport& report, std::uint32_t stage, double dt,
                            const std::optional<TriaxialRow>& triaxial) {
  if (!rows_.empty() && rows_.front().triaxial.has_value() != triaxial.has_value())
    throw UsageError("a results series has triaxial measurements in every row or in none");
  SeriesRow r;
  r.step = solver.step_count() - 1;  // the report is of the step just taken
  r.time = solver.time() - dt;
  r.stage = stage;
  r.energies = report.energies;
  r.node_contacts = report.contact.node_contacts;
  for (std::size_t p = 0; p < platens_; ++p) {
    r.platen_force.push_back(solver.platen_force(p));
    r.platen_position.push_back(solver.platens()[p].point);
  }
  r.triaxial = triaxial;
  rows_.push_back(std::move(r));
}

void ResultsWriter::add_frame(const Solver& solver, const TriaxialBoundary* boundary, std::optional<double> axial_strain) {
  const double start = monotonic_seconds();
  const std::string group = frame_group(frames_++);
  file_.ensure_group(group);
  file_.set_attr(group, sr::frame_time, solver.time());
  file_.set_attr(group, sr::frame_step, static_cast<long long>(solver.step_count()));
  if (axial_strain) file_.set_attr(group, sr::frame_axial_strain, *axial_strain);
  if (boundary && boundary->membrane_state()) {
    std::vector<double> position;
    for (const Eigen::Vector3d& x : boundary->membrane_state()->x) push(position, x);
    file_.write(group + "/" + sr::frame_membrane_position, position.data(), {position.size() / 3, 3}, units("m"));
  }
  const Model& m = solver.model();
  const hsize_t G = m.grains.size();
  std::vector<double> centroid, rotation, stress, love_weber_stress, velocity, spin;
  std::vector<Eigen::Matrix3d> grain_stress(G);
  const std::vector<Eigen::Matrix3d> love_weber = solver.love_weber_stresses();
  for (std::size_t g = 0; g < G; ++g) {
    push(centroid, solver.grain_centroid(g));
    push(velocity, solver.grain_velocity(g));
    push(spin, solver.grain_spin(g));
    const Eigen::Quaterniond q = solver.grain_rotation(g);
    rotation.insert(rotation.end(), {q.w(), q.x(), q.y(), q.z()});
    grain_stress[g] = solver.grain_stress(g);
    push_compression(stress, grain_stress[g]);
    push_compression(love_weber_stress, love_weber[g]);
  }
  file_.write(group + "/" + sr::frame_centroid, centroid.data(), {G, 3}, units("m"));
  file_.write(group + "/" + sr::frame_rotation, rotation.data(), {G, 4}, units("1"));
  file_.write(group + "/" + sr::frame_stress, stress.data(), {G, 3, 3}, units("Pa"));
  file_.write(group + "/" + sr::frame_love_weber_stress, love_weber_stress.data(), {G, 3, 3}, units("Pa"));
  const double difference = median_stress_difference(grain_stress, love_weber, m.grains);
  file_.set_attr(group, sr::frame_stress_difference, difference);
  stress_differences_.push_back(difference);
  // float32: 7 digits are far below the elements' discretisation error and halve the largest
  // dataset of a deformable twin (docs/formats.md).
  std::vector<float> element_stress;
  for (std::size_t g = 0; g < G; ++g)
    if (solver.carries_element_stress(g))
      for (std::uint32_t e = m.grains[g].element_begin; e < m.grains[g].element_end; ++e)
        push_compression(element_stress, solver.element_stress(e));
  file_.write(group + "/" + sr::frame_element_stress, element_stress.data(), {element_stress.size() / 9, 3, 3}, units("Pa"));
  file_.write(group + "/" + sr::frame_velocity, velocity.data(), {G, 3}, units("m/s"));
  file_.write(group + "/" + sr::frame_spin, spin.data(), {G, 3}, units("rad/s"));
  std::vector<std::uint32_t> pair;
  std::vector<std::int32_t> platen;
  std::vector<double> point, normal, force, overlap;
  for (const ContactRecord& c : solver.contacts()) {
    const bool with_platen = c.b >= G;
    pair.insert(pair.end(), {m.grains[c.a].label, with_platen ? 0u : m.grains[c.b].label});
    platen.push_back(with_platen ? static_cast<std::int32_t>(c.b - G) : -1);
    push(point, c.point);
    push(normal, c.normal);
    push(force, c.force);
    overlap.push_back(c.overlap);
  }
  const hsize_t M = platen.size();
  file_.write(group + "/" + sr::contact_pair, pair.data(), {M, 2});
  file_.write(group + "/" + sr::contact_platen, platen.data(), {M});
  file_.write(group + "/" + sr::contact_point, point.data(), {M, 3}, units("m"));
  file_.write(group + "/" + sr::contact_normal, normal.data(), {M, 3}, units("1"));
  file_.write(group + "/" + sr::contact_force, force.data(), {M, 3}, units("N"));
  file_.write(group + "/" + sr::contact_overlap, overlap.data(), {M}, units("m"));
  frame_seconds_ += monotonic_seconds() - start;
}

void ResultsWriter::finish(const std::vector<std::string>& history) {
  const hsize_t R = rows_.size(), P = platens_;
  const auto column = [&](const char* name, auto get, const char* unit) {
    std::vector<decltype(get(rows_.front()))> v;
    for (const SeriesRow& r : rows_) v.push_back(get(r));
    file_.write(name, v.data(), {R}, unit ? units(unit) : io::DatasetOptions{});
  };
  if (R > 0) {
    column(sr::series_time, [](const SeriesRow& r) { return r.time; }, "s");
    column(sr::series_step, [](const SeriesRow& r) { return r.step; }, nullptr);
    column(sr::series_stage, [](const SeriesRow& r) { return r.stage; }, nullptr);
    column(sr::series_kinetic, [](const SeriesRow& r) { return r.energies.kinetic; }, "J");
    column(sr::series_strain, [](const SeriesRow& r) { return r.energies.strain; }, "J");
    column(sr::series_contact_elastic, [](const SeriesRow& r) { return r.energies.contact_elastic; }, "J");
    column(sr::series_dissipated, [](const SeriesRow& r) { return r.energies.dissipated; }, "J");
    column(sr::series_external_work, [](const SeriesRow& r) { return r.energies.external_work; }, "J");
    column(sr::series_node_contacts, [](const SeriesRow& r) { return r.node_contacts; }, nullptr);
  }
  std::vector<double> force, position;
  for (const SeriesRow& r : rows_)
    for (std::size_t p = 0; p < P; ++p) push(force, r.platen_force[p]), push(position, r.platen_position[p]);
  file_.write(sr::series_platen_force, force.data(), {R, P, 3}, units("N"));
  file_.write(sr::series_platen_position, position.data(), {R, P, 3}, units("m"));
  if (R > 0 && rows_.front().triaxial) write_triaxial_columns();
  file_.write_strings(sr::stage_name, stage_names_);
  file_.write(sr::stage_start, stage_starts_, units("s"));
  file_.write_strings(sr::parameters, {parameters_});
  io::write_history(file_, history);
}

void ResultsWriter::write_triaxial_columns() {
  const hsize_t R = rows_.size();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const auto column = [&](const char* name, auto get, const char* unit) {
    std::vector<double> v;
    for (std::size_t i = 0; i < rows_.size(); ++i) v.push_back(get(i, rows_[i].triaxial->measure));
    file_.write(name, v.data(), {R}, units(unit));
  };
  const auto strained = [&](std::size_t i) { return reference_row_ && i >= *reference_row_; };
  column(sr::series_axial_stress, [](std::size_t, const TriaxialMeasure& m) { return m.axial_stress; }, "Pa");
  column(sr::series_lateral_stress, [](std::size_t, const TriaxialMeasure& m) { return m.lateral_stress; }, "Pa");
  // sigma_1 / sigma_3 is undefined while the lateral boundary carries nothing (the servo wall before
  // the grains reach it, the membrane held at zero pressure before its release): NaN there, never
  // an infinity (docs/formats.md).
  column(sr::series_stress_ratio, [&](std::size_t, const TriaxialMeasure& m) {
    return m.lateral_stress > 0 ? m.axial_stress / m.lateral_stress : nan;
  }, "1");
  column(sr::series_height, [](std::size_t, const TriaxialMeasure& m) { return m.height; }, "m");
  column(sr::series_volume, [](std::size_t, const TriaxialMeasure& m) { return m.volume; }, "m^3");
  column(sr::series_volume_radial, [](std::size_t, const TriaxialMeasure& m) { return m.volume_radial; }, "m^3");
  column(sr::series_axial_strain,
         [&](std::size_t i, const TriaxialMeasure& m) { return strained(i) ? std::log(reference_height_ / m.height) : nan; }, "1");
  column(sr::series_volumetric_strain,
         [&](std::size_t i, const TriaxialMeasure& m) { return strained(i) ? std::log(reference_volume_ / m.volume) : nan; }, "1");
  column(sr::series_kinetic_ratio, [&](std::size_t i, const TriaxialMeasure&) { return rows_[i].energies.kinetic_ratio(); }, "1");
  column(sr::series_inertial_number, [&](std::size_t i, const TriaxialMeasure&) { return rows_[i].triaxial->inertial_number; }, "1");
}

ResultsSeries read_results_series(const std::filesystem::path& path) {
  const io::H5File f = io::open_kind(path, schema::kind::fdem_results, "pass the output of fdemrun");
  ResultsSeries s;
  if (!f.exists(sr::series_time)) return s;  // a run shorter than one series interval
  s.time = f.read<double>(sr::series_time);
  s.step = f.read<std::uint64_t>(sr::series_step);
  s.kinetic = f.read<double>(sr::series_kinetic);
  s.strain = f.read<double>(sr::series_strain);
  s.contact_elastic = f.read<double>(sr::series_contact_elastic);
  s.dissipated = f.read<double>(sr::series_dissipated);
  s.external_work = f.read<double>(sr::series_external_work);
  s.platen_force = f.read<double>(sr::series_platen_force);
  s.platen_position = f.read<double>(sr::series_platen_position);
  if (s.step.size() != s.time.size() || s.kinetic.size() != s.time.size())
    throw DataError(path.string() + " has series columns of different lengths; rerun fdemrun");
  return s;
}

TriaxialSeries read_triaxial_series(const std::filesystem::path& path) {
  const io::H5File f = io::open_kind(path, schema::kind::fdem_results, "pass the output of fdemrun");
  TriaxialSeries s;
  for (const char* name : {sr::series_axial_strain, sr::series_volumetric_strain, sr::series_stress_ratio})
    if (!f.exists(name)) s.missing.push_back(name);
  if (!s.missing.empty()) return s;
  const auto axial = f.read<double>(sr::series_axial_strain);
  const auto volumetric = f.read<double>(sr::series_volumetric_strain);
  const auto ratio = f.read<double>(sr::series_stress_ratio);
  const auto step = f.read<std::uint64_t>(sr::series_step);
  if (volumetric.size() != axial.size() || ratio.size() != axial.size() || step.size() != axial.size())
    throw DataError(path.string() + ": the series' strains and stress ratio differ in length; rerun fdemrun");
  // fdemrun measures the strains from the start of shearing: the rows before it are NaN.
  for (std::size_t i = 0; i < axial.size(); ++i)
    if (std::isfinite(axial[i])) {
      s.axial_strain.push_back(axial[i]);
      s.volumetric_strain.push_back(volumetric[i]);
      s.stress_ratio.push_back(ratio[i]);
      s.step.push_back(step[i]);
    }
  return s;
}

void check_results_tables(const io::H5File& f) {
  const std::string fix = "rewrite it with fdemrun";
  for (const char* g : {sr::grains, sr::series, sr::stages}) io::table_rows(f, g, fix);
  io::require_finite_table(f, sr::series, {sr::series_time, sr::series_kinetic}, fix);
  if (f.exists(sr::frames))
    for (const std::string& frame : f.list(sr::frames))
      io::require_finite_table(f, std::string(sr::frames) + "/" + frame + "/" + sr::frame_grains, {sr::frame_centroid, sr::frame_rotation}, fix);
}

std::size_t results_frame_count(const std::filesystem::path& path) {
  const io::H5File f = io::open_kind(path, schema::kind::fdem_results, "pass the output of fdemrun");
  return f.list(sr::frames).size();
}

double relative_stress_difference(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  const double scale = std::max(a.norm(), b.norm());
  return scale > 0 ? (a - b).norm() / scale : std::numeric_limits<double>::quiet_NaN();
}

double median_stress_difference(std::span<const Eigen::Matrix3d> element_average, std::span<const Eigen::Matrix3d> love_weber,
                                std::span<const Grain> grains) {
  std::vector<double> differences;
  for (std::size_t g = 0; g < grains.size(); ++g)
    if (grains[g].kind != GrainKind::rigid)
      if (const double d = relative_stress_difference(element_average[g], love_weber[g]); std::isfinite(d)) differences.push_back(d);
  return differences.empty() ? std::numeric_limits<double>::quiet_NaN() : median(std::move(differences));
}

ResultsGrains read_results_grains(const std::filesystem::path& path) {
  const io::H5File f = io::open_kind(path, schema::kind::fdem_results, "pass the output of fdemrun");
  ResultsGrains r;
  r.label = f.read<std::uint32_t>(sr::grain_label);
  const auto kind = f.read<std::uint8_t>(sr::grain_kind);
  if (kind.size() != r.label.size())
    throw DataError(path.string() + ": /grains/label and /grains/kind differ in length; rerun fdemrun");
  for (std::uint8_t k : kind) {
    if (k > static_cast<std::uint8_t>(GrainKind::tet10))
      throw DataError(path.string() + ": /grains/kind holds " + std::to_string(k) + ", not a grain kind (0 rigid, 1 tet4, 2 tet10); rerun fdemrun");
    r.kind.push_back(static_cast<GrainKind>(k));
  }
  return r;
}

FrameElementStress read_frame_element_stress(const std::filesystem::path& path, std::size_t k) {
  const io::H5File f = io::open_kind(path, schema::kind::fdem_results, "pass the output of fdemrun");
  const std::string g = frame_group(k), stress = g + "/" + sr::frame_element_stress;
  if (!f.exists(g)) throw DataError(path.string() + " has no frame " + std::to_string(k) + "; it holds " +
                                    std::to_string(f.list(sr::frames).size()));
  if (!f.exists(sr::element_grain) || !f.exists(stress))
    throw DataError(path.string() + " holds no element stresses (written before they were kept); rerun fdemrun");
  FrameElementStress r;
  r.element = f.read<std::uint32_t>(sr::element_index);
  r.grain = f.read<std::uint32_t>(sr::element_grain);
  r.stress = f.read<float>(stress);
  if (r.grain.size() != r.element.size() || r.stress.size() != 9 * r.element.size())
    throw DataError(path.string() + ": frame " + std::to_string(k) + "'s element stresses do not match /elements; rerun fdemrun");
  return r;
}

ResultsFrame read_results_frame(const std::filesystem::path& path, std::size_t k) {
  const io::H5File f = io::open_kind(path, schema::kind::fdem_results, "pass the output of fdemrun");
  const std::string g = frame_group(k);
  if (!f.exists(g)) throw DataError(path.string() + " has no frame " + std::to_string(k) + "; it holds " +
                                    std::to_string(f.list(sr::frames).size()));
  ResultsFrame r;
  r.time = f.attr_double(g, sr::frame_time);
  r.step = static_cast<std::uint64_t>(f.attr_int(g, sr::frame_step).value_or(0));
  const auto at = [&](const char* member) { return g + "/" + member; };
  r.centroid = f.read<double>(at(sr::frame_centroid));
  r.rotation = f.read<double>(at(sr::frame_rotation));
  r.stress = f.read<double>(at(sr::frame_stress));
  r.velocity = f.read<double>(at(sr::frame_velocity));
  if (f.exists(at(sr::frame_spin))) r.spin = f.read<double>(at(sr::frame_spin));  // files before 2026-11-28 have none
  if (f.exists(at(sr::frame_love_weber_stress))) r.love_weber_stress = f.read<double>(at(sr::frame_love_weber_stress));
  r.pair = f.read<std::uint32_t>(at(sr::contact_pair));
  r.platen = f.read<std::int32_t>(at(sr::contact_platen));
  r.point = f.read<double>(at(sr::contact_point));
  r.normal = f.read<double>(at(sr::contact_normal));
  r.force = f.read<double>(at(sr::contact_force));
  r.overlap = f.read<double>(at(sr::contact_overlap));
  if (f.has_attr(g, sr::frame_axial_strain)) r.axial_strain = f.attr_double(g, sr::frame_axial_strain);
  if (f.exists(at(sr::frame_membrane_position))) r.membrane_position = f.read<double>(at(sr::frame_membrane_position));
  // fdemrun stops before a state goes non-finite (its health checks), so such a frame is damage.
  io::require_finite(f, at(sr::frame_centroid), r.centroid, 3, "rerun fdemrun");
  io::require_finite(f, at(sr::frame_rotation), r.rotation, 4, "rerun fdemrun");
  return r;
}

void write_checkpoint(const std::filesystem::path& path, const Solver& solver, const std::string& scene_digest,
                      const std::function<void(io::H5File&)>& also) {
  io::H5File f = io::H5File::create(path);
  io::write_root_attrs(f, schema::kind::fdem_checkpoint);
  f.set_attr(schema::path::root, ck::scene_digest, scene_digest);
  solver.save(f, ck::state);
  if (also) also(f);
}

std::filesystem::path checkpoint_part_path(const std::filesystem::path& path, int rank, char set) {
  return path.parent_path() / fmt::format("{}.rank{}-{}{}", path.stem().string(), rank, set, path.extension().string());
}

CheckpointPartFile::CheckpointPartFile(const std::filesystem::path& path, const Solver& solver, const std::string& scene_digest,
                                       const std::vector<std::uint32_t>& grains, int rank, int ranks, char set,
                                       const std::function<void(io::H5File&)>& also)
    : path_(path), rank_(rank), set_(set),
      out_(std::make_unique<io::AtomicOutput>(rank == 0 ? path : checkpoint_part_path(path, rank, set), true)) {
  io::H5File f = io::H5File::create(out_->temp_path());
  io::write_root_attrs(f, rank == 0 ? schema::kind::fdem_checkpoint : schema::kind::fdem_checkpoint_part);
  f.set_attr(schema::path::root, ck::scene_digest, scene_digest);
  f.set_attr(schema::path::root, ck::parts, static_cast<long long>(ranks));
  if (rank == 0) {
    std::vector<std::string> names;
    for (int k = 1; k < ranks; ++k) names.push_back(checkpoint_part_path(path, k, set).filename().string());
    f.write_strings(ck::part_files, names);
  } else {
    f.set_attr(schema::path::root, ck::part, static_cast<long long>(rank));
    f.set_attr(schema::path::root, ck::part_step, static_cast<long long>(solver.step_count()));
  }
  solver.save(f, ck::state, {&grains, rank == 0});
  if (rank == 0 && also) also(f);
}

CheckpointPartFile::~CheckpointPartFile() = default;

void CheckpointPartFile::place() { out_->replace_now(); }

void CheckpointPartFile::drop_other_set() const {
  if (rank_ == 0) return;
  std::error_code ignored;  // absent before a second checkpoint
  std::filesystem::remove(checkpoint_part_path(path_, rank_, set_ == 'a' ? 'b' : 'a'), ignored);
}

void check_checkpoint_parts_allowed(const std::filesystem::path& path, int ranks, bool force) {
  for (int k = 1; k < ranks; ++k)
    for (char set : {'a', 'b'}) io::check_output_allowed(checkpoint_part_path(path, k, set), force);
}

void read_checkpoint(const std::filesystem::path& path, Solver& solver, const std::string& scene_digest,
                     const std::function<void(const io::H5File&)>& also) {
  const io::H5File f = io::open_kind(path, schema::kind::fdem_checkpoint, "pass a checkpoint written by fdemrun --checkpoint (its main file, not a rank's part)");
  if (f.attr_string(schema::path::root, ck::scene_digest).value_or("") != scene_digest)
    throw UsageError("checkpoint " + path.string() + " was written for another scene or model; restart with the scene that wrote it");
  // Written by several ranks: its parts beside it, each of this checkpoint.
  std::vector<io::H5File> parts;
  const long long ranks = f.attr_int(schema::path::root, ck::parts).value_or(1);
  const std::vector<std::string> names = ranks > 1 ? f.read_strings(ck::part_files) : std::vector<std::string>();
  if (ranks < 1 || names.size() != static_cast<std::size_t>(ranks - 1))
    throw DataError(fmt::format("{}: checkpoint written by {} ranks names {} part files; write it again", path.string(), ranks, names.size()));
  const auto step = f.attr_int(ck::state, ck::step).value_or(0);
  for (std::size_t k = 0; k < names.size(); ++k) {
    const std::filesystem::path part = path.parent_path() / names[k];
    if (!std::filesystem::exists(part))
      throw UsageError(fmt::format("checkpoint {} was written by {} ranks and its part {} is missing; keep every part file "
                                   "beside the checkpoint",
                                   path.string(), ranks, part.string()));
    io::H5File p = io::open_kind(part, schema::kind::fdem_checkpoint_part, "keep the part files fdemrun wrote beside the checkpoint");
    if (p.attr_string(schema::path::root, ck::scene_digest).value_or("") != scene_digest ||
        p.attr_int(schema::path::root, ck::part).value_or(-1) != static_cast<long long>(k + 1) ||
        p.attr_int(schema::path::root, ck::parts).value_or(-1) != ranks ||
        p.attr_int(schema::path::root, ck::part_step).value_or(-1) != step)
      throw DataError(fmt::format("{} is not rank {}'s part of checkpoint {} (step {}); keep the part files fdemrun wrote with it",
                                  part.string(), k + 1, path.string(), step));
    parts.push_back(std::move(p));
    io::declare_input(part);  // no output of this run may be one of them
  }
  std::vector<const io::H5File*> files{&f};
  for (const io::H5File& p : parts) files.push_back(&p);
  solver.load(files, ck::state);
  if (also) also(f);
}

}  // namespace graintwin::fdem
