#include "graintwin/report/run_data.hpp"

#include <algorithm>
#include <cmath>

#include "graintwin/contacts/contacts_file.hpp"
#include "graintwin/contacts/fabric.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/fdem/model_file.hpp"
#include "graintwin/fdem/results_file.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/series_record.hpp"
#include "graintwin/io/table_checks.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/micro/local_deformation.hpp"
#include "graintwin/micro/micro_file.hpp"
#include "graintwin/micro/simulation.hpp"
#include "graintwin/report/charts.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "graintwin/segment/sample_region.hpp"
#include "graintwin/shape/shapes_file.hpp"
#include "graintwin/track/tracks_file.hpp"
#include "graintwin/validate/validation_file.hpp"

namespace graintwin::report {

namespace {

/// `given` when set (it must be a file), else `fallback` when it exists (it must be a file too:
/// a folder of that name would otherwise pass for a stage that has not run), else empty.
fs::path given_or_found(const fs::path& given, const fs::path& fallback, const std::string& option) {
  if (!given.empty()) {
    require_file(given, option);
    return given;
  }
  std::error_code ec;
  if (fallback.empty() || !fs::exists(fallback, ec)) return {};
  require_file(fallback, "the run's file", "move it out of the run directory, or name the file with " + option);
  return fallback;
}

void require_files(const std::vector<fs::path>& given, const std::string& option) {
  for (const fs::path& p : given) require_file(p, option);
}

/// One file per scan: `given` (one per scan, each must exist) or `name` in each scan folder.
std::vector<fs::path> per_scan(const std::vector<fs::path>& given, const std::vector<fs::path>& scan_dirs, const char* name,
                               const std::string& option) {
  if (!given.empty()) {
    if (given.size() != scan_dirs.size())
      throw UsageError(option + " lists " + std::to_string(given.size()) + " files for " + std::to_string(scan_dirs.size()) +
                       " scans; give one per scan, in scan order");
    require_files(given, option);
    return given;
  }
  std::vector<fs::path> out;
  for (const fs::path& d : scan_dirs) out.push_back(given_or_found({}, d / name, option));
  return out;
}

/// A rose as the charts take it: its counts, no mean force.
micro::ForceRose counts_only(const contacts::Rose& r) { return {r.theta_edges, r.phi_edges, r.counts, {}}; }

ScanData read_scan(const RunFiles& files, std::size_t s) {
  ScanData d;
  d.name = files.scan_names[s];
  d.void_ratio = segment::read_void_ratio(files.labels[s]);
  d.coordination_mean = std::nan("");
  if (!files.shapes[s].empty()) {
    const shape::ShapesFile sh = shape::read_shapes_file(files.shapes[s]);
    d.psd = sh.psd;
    d.grains = sh.grains.size();
  }
  if (!files.contacts[s].empty()) {
    const contacts::ContactsFile c = contacts::read_contacts_file(files.contacts[s]);
    d.contacts = c.contacts.size();
    d.coordination = c.coordination.histogram;
    d.coordination_mean = c.coordination.mean;
    d.rose_normal = counts_only(c.rose_normal);
    d.rose_branch = counts_only(c.rose_branch);
  }
  return d;
}

std::string check_hint(const std::string& kind) {
  if (kind == schema::kind::labels) return "pass the output of ct2labels";
  if (kind == schema::kind::contacts) return "pass the output of labels2contacts";
  if (kind == schema::kind::shapes) return "pass the output of labels2shapes";
  if (kind == schema::kind::tracks) return "pass the output of shapes2tracks";
  if (kind == schema::kind::micro) return "pass the output of tracks2micro";
  if (kind == schema::kind::fdem_model) return "pass the output of shapes2mesh";
  if (kind == schema::kind::fdem_results) return "pass the output of fdemrun";
  if (kind == schema::kind::volume) return "pass the scan the labels were segmented from (ct2labels' input)";
  return "pass the output of fdem2forces";
}

/// A scan named by --volumes must be an image of its labels file's geometry: the sections draw
/// the labels over its grey values voxel for voxel.
void check_volume_beside_labels(const fs::path& volume, const fs::path& labels) {
  const io::ImageHeader grey = io::read_image_header(io::H5File::open(volume), "/volume");
  const io::ImageHeader label = io::read_image_header(io::H5File::open(labels), "/labels");
  if (grey.shape != label.shape || grey.voxel_size != label.voxel_size || grey.origin != label.origin)
    throw UsageError("--volumes " + volume.string() + " is not the scan of " + labels.string() +
                     " (its image has another size, voxel size or origin); pass the scans in the order of the labels files");
}

/// The tables of a run file of kind `kind` agree in length and hold only values their tool writes
/// (io/table_checks, through the checks of the kind's home module), before the report draws
/// anything from them. Columns where NaN means "not measured" (a contact not refined, a strain
/// before shearing) may hold NaN; none may hold infinity.
void check_tables(const io::H5File& f, const std::string& kind) {
  if (kind == schema::kind::labels) segment::check_labels_tables(f);
  else if (kind == schema::kind::contacts) contacts::check_contacts_tables(f);
  else if (kind == schema::kind::tracks) track::check_tracks_tables(f);
  else if (kind == schema::kind::micro) micro::check_micro_tables(f);
  else if (kind == schema::kind::fdem_results) fdem::check_results_tables(f);
  else if (kind == schema::kind::forces) micro::check_forces_tables(f);
}

}  // namespace

namespace {

/// Why `path` is not a regular file (`folder` false) or a folder (true), as a UsageError.
void require_kind(const fs::path& path, bool folder, const std::string& what, const std::string& fix) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (folder ? fs::is_directory(st) : fs::is_regular_file(st)) return;
  const std::string name = what + " " + path.string();
  if (!fs::exists(st)) throw UsageError(name + " does not exist; check the path");
  const char* is = folder ? (fs::is_regular_file(st) ? " is a file, not a folder; " : " is not a folder; ")
                          : (fs::is_directory(st) ? " is a folder, not a file; " : " is not a regular file (a device, pipe or socket); ");
  throw UsageError(name + is + fix);
}

}  // namespace

void require_file(const fs::path& path, const std::string& what, const std::string& fix) { require_kind(path, false, what, fix); }

void require_folder(const fs::path& path, const std::string& what, const std::string& fix) { require_kind(path, true, what, fix); }

RunFiles locate_run_files(const fs::path& run_dir, const RunFiles& given) {
  std::error_code ec;
  if (!fs::exists(run_dir, ec))
    throw UsageError("the run directory " + run_dir.string() +
                     " does not exist; run the pipeline first (make -f Makefile.pipeline) or check the path");
  require_folder(run_dir, "the run directory",
                 "pass the folder Makefile.pipeline writes a series into (runs/<series>, holding scan_*/labels.h5)");
  RunFiles f;
  std::vector<fs::path> scan_dirs;
  if (!given.labels.empty()) {
    require_files(given.labels, "--labels");
    f.labels = given.labels;
    for (const fs::path& p : f.labels) {
      scan_dirs.push_back(p.parent_path());
      f.scan_names.push_back(p.parent_path().filename().string());
    }
  } else {
    for (const auto& e : fs::directory_iterator(run_dir, ec)) {
      const std::string name = e.path().filename().string();
      if (!e.is_directory(ec) || name.rfind(layout::scan_prefix, 0) != 0 || !fs::exists(e.path() / layout::labels, ec)) continue;
      require_file(e.path() / layout::labels, "the scan's labels file", "move it out of the run directory, or name the files with --labels");
      scan_dirs.push_back(e.path());
    }
    std::sort(scan_dirs.begin(), scan_dirs.end());
    if (scan_dirs.empty())
      throw UsageError("the run directory " + run_dir.string() + " holds no scan_*/" + layout::labels +
                       "; run the segment stage first (make -f Makefile.pipeline segment) or name the files with --labels");
    for (const fs::path& d : scan_dirs) {
      f.labels.push_back(d / layout::labels);
      f.scan_names.push_back(d.filename().string());
    }
  }
  f.contacts = per_scan(given.contacts, scan_dirs, layout::contacts, "--contacts");
  f.shapes = per_scan(given.shapes, scan_dirs, layout::shapes, "--shapes");
  if (!given.volumes.empty()) f.volumes = per_scan(given.volumes, scan_dirs, "", "--volumes");
  f.tracks = given_or_found(given.tracks, run_dir / layout::tracks, "--tracks");
  f.micro = given_or_found(given.micro, run_dir / layout::micro, "--micro");
  f.model = given_or_found(given.model, run_dir / layout::model, "--model");
  f.simulation = given_or_found(given.simulation, run_dir / layout::simulation, "--simulation");
  f.forces = given_or_found(given.forces, run_dir / layout::forces, "--forces");
  f.simulation_micro = given_or_found(given.simulation_micro, run_dir / layout::simulation_micro, "--simulation-micro");
  f.scan_strains = given_or_found(given.scan_strains, fs::path(), "--scan-strains");
  f.validation = given_or_found(given.validation, run_dir / layout::validation, "--validation");
  return f;
}

std::vector<std::pair<std::string, std::vector<std::string>>> check_run_files(const RunFiles& files) {
  std::vector<std::pair<std::string, std::vector<std::string>>> history;
  const auto check = [&](const fs::path& p, const char* kind) {
    if (p.empty()) return;
    const io::H5File f = io::open_kind(p, kind, check_hint(kind));
    check_tables(f, kind);
    history.emplace_back(p.string(), io::read_history(f));
  };
  for (std::size_t s = 0; s < files.labels.size(); ++s) {
    check(files.labels[s], schema::kind::labels);
    check(files.contacts[s], schema::kind::contacts);
    check(files.shapes[s], schema::kind::shapes);
    if (!files.volumes.empty()) {
      check(files.volumes[s], schema::kind::volume);
      check_volume_beside_labels(files.volumes[s], files.labels[s]);
    }
  }
  check(files.tracks, schema::kind::tracks);
  check(files.micro, schema::kind::micro);
  check(files.model, schema::kind::fdem_model);
  // The report shows only the model's provenance, but a model it vouches for must be one fdemrun would run.
  if (!files.model.empty()) fdem::read_model_file(files.model);
  check(files.simulation, schema::kind::fdem_results);
  check(files.simulation_micro, schema::kind::micro);
  check(files.forces, schema::kind::forces);
  if (!files.validation.empty()) history.emplace_back(files.validation.string(), validate::read_validation(files.validation).history);
  return history;
}

ExperimentData read_experiment(const RunFiles& files) {
  ExperimentData e;
  for (std::size_t s = 0; s < files.labels.size(); ++s) e.scans.push_back(read_scan(files, s));
  const std::size_t scans = e.scans.size();
  if (std::isfinite(e.scans[0].void_ratio))
    for (const ScanData& s : e.scans)
      e.void_ratio_volumetric_strain.push_back(segment::void_ratio_volumetric_strain(e.scans[0].void_ratio, s.void_ratio));
  if (!files.tracks.empty()) {
    const track::TrackedCentroids tracked_centroids = track::read_tracked_centroids(files.tracks);
    if (tracked_centroids.scans != scans)
      throw UsageError(files.tracks.string() + " follows " + std::to_string(tracked_centroids.scans) + " scans but the run has " +
                       std::to_string(scans) + "; rerun the track stage or name the scans' files explicitly");
    e.tracks = tracked_centroids.tracks;
    const micro::TrackedStrains tracked = micro::tracked_strains(tracked_centroids.centroid, tracked_centroids.tracks, scans);
    e.tracked_axial_strain = tracked.axial, e.tracked_volumetric_strain = tracked.volumetric;
  }
  if (!files.scan_strains.empty()) {
    try {
      e.applied_axial_strain = io::read_series_axial_strains(files.scan_strains);
    } catch (Error& error) {
      error.add_context("reading --scan-strains");
      throw;
    }
    if (e.applied_axial_strain.size() != scans)
      throw UsageError("--scan-strains " + files.scan_strains.string() + " lists " + std::to_string(e.applied_axial_strain.size()) +
                       " scans but the run has " + std::to_string(scans) + "; pass the series.json of the scans this run segmented");
  }
  if (!files.micro.empty()) e.micro = micro::read_micro_tables(files.micro);
  return e;
}

SimulationData read_simulation(const RunFiles& files, std::size_t frames_shown, int theta_bins) {
  SimulationData s;
  if (!files.simulation.empty()) {
    s.present = true;
    const micro::SimulationGrains grains = micro::read_simulation_grains(files.simulation);
    s.grains = grains.label.size();
    s.psd = grains.psd;
    s.frames = fdem::results_frame_count(files.simulation);
    s.series = fdem::read_triaxial_series(files.simulation);
    s.rose_frames = pick_evenly(s.frames, frames_shown);
    for (const contacts::Rose& r : micro::simulation_branch_roses(files.simulation, s.rose_frames, theta_bins, 36))
      s.branch_roses.push_back(counts_only(r));
  }
  if (!files.simulation_micro.empty()) s.micro = micro::read_micro_tables(files.simulation_micro);
  if (!files.forces.empty()) s.forces = micro::read_forces_tables(files.forces);
  return s;
}

}  // namespace graintwin::report
