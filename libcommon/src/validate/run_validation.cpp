#include "graintwin/validate/run_validation.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>

#include "graintwin/contacts/contacts_file.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/fdem/results_file.hpp"
#include "graintwin/io/run_layout.hpp"
#include "graintwin/micro/micro_file.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "graintwin/shape/shapes_file.hpp"
#include "graintwin/track/tracks_file.hpp"

namespace graintwin::validate {

namespace layout = io::run_layout;

namespace {
fs::path if_exists(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec) ? p : fs::path();
}
}  // namespace

std::vector<fs::path> ValidationFiles::all() const {
  std::vector<fs::path> out;
  for (std::size_t k = 0; k < scan_names.size(); ++k)
    for (const fs::path* p : {&truth[k], &labels[k], &contacts[k], &shapes[k]})
      if (!p->empty()) out.push_back(*p);
  for (const fs::path* p : {&tracks, &micro, &simulation})
    if (!p->empty()) out.push_back(*p);
  return out;
}

ValidationFiles locate_validation_files(const fs::path& run_dir, const fs::path& series_dir) {
  std::error_code ec;
  if (!fs::is_directory(run_dir, ec))
    throw UsageError("the run directory " + run_dir.string() + " is not a folder; pass the folder Makefile.pipeline writes a series into (runs/<series>)");
  if (!fs::is_directory(series_dir, ec))
    throw UsageError("the series folder " + series_dir.string() + " is not a folder; pass the ctsynth series the run was made from (sample_volumes/<series>)");
  ValidationFiles f;
  f.run_dir = run_dir, f.series_dir = series_dir;
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(run_dir)) {
    const std::string name = e.path().filename().string();
    if (e.is_directory(ec) && name.rfind(layout::scan_prefix, 0) == 0 && fs::is_regular_file(e.path() / layout::labels, ec))
      names.push_back(name);
  }
  std::sort(names.begin(), names.end());
  if (names.empty())
    throw UsageError("the run directory " + run_dir.string() + " holds no " + layout::scan_prefix + "*/" + layout::labels +
                     "; run the segment stage of Makefile.pipeline first");
  for (const std::string& name : names) {
    const fs::path truth = series_dir / (layout::truth_prefix + name.substr(std::string(layout::scan_prefix).size()) + ".h5");
    if (!fs::is_regular_file(truth, ec))
      throw UsageError(series_dir.string() + " has no " + truth.filename().string() + " for " + name +
                       "; validate needs the ground truth of a ctsynth series, so pass the series the run was made from");
    f.scan_names.push_back(name);
    f.truth.push_back(truth);
    f.labels.push_back(run_dir / name / layout::labels);
    f.contacts.push_back(if_exists(run_dir / name / layout::contacts));
    f.shapes.push_back(if_exists(run_dir / name / layout::shapes));
  }
  f.tracks = if_exists(run_dir / layout::tracks);
  f.micro = if_exists(run_dir / layout::micro);
  f.simulation = if_exists(run_dir / layout::simulation);
  return f;
}

Validation validate_run(const ValidationFiles& files, const ValidationOptions& options, const std::function<void(double)>& progress) {
  const std::size_t scans = files.scan_names.size();
  const double steps = static_cast<double>(scans + 2);
  const auto done = [&](double step) {
    if (progress) progress(step / steps);
  };
  Validation v;
  v.run = files.run_dir.string(), v.series = files.series_dir.string();
  std::vector<synth::GroundTruth> truths(scans);
  std::vector<std::vector<std::uint32_t>> true_of_label(scans);
  for (std::size_t k = 0; k < scans; ++k) {
    ScanValidation sc;
    sc.name = files.scan_names[k];
    truths[k] = synth::read_ground_truth(files.truth[k]);
    {
      const segment::LabelsFile labels = segment::read_labels_file(files.labels[k]);
      if (labels.labels.shape() != truths[k].labels.shape())
        throw DataError(files.labels[k].string() + " is not a segmentation of the scan " + files.truth[k].string() +
                        " describes (their images differ in shape); pass the series the run was made from");
      const MatchResult match = match_labels(truths[k].labels, labels.labels);
      true_of_label[k] = match.faithful_grain();
      sc.segmentation = score_segmentation(match, labels.sample.void_ratio.e, true_void_ratio(truths[k].labels, labels.sample.region).e);
    }
    truths[k].labels = Volume<std::uint32_t>();  // the label image is done with; keep the tables
    if (!files.contacts[k].empty()) {
      sc.has_contacts = true;
      sc.contacts = score_contacts(truths[k].contacts, contacts::read_contacts_file(files.contacts[k]).contacts, true_of_label[k],
                                   options.all_contacts);
    }
    if (!files.shapes[k].empty()) {
      sc.has_shapes = true;
      sc.shapes = score_shapes(truths[k], shape::read_shapes_file(files.shapes[k]).grains, true_of_label[k]);
    }
    spdlog::info("{}: {} of {} true grains right, {} contacts found of {}, {} faithful grains' shapes", sc.name,
                 sc.segmentation.right, sc.segmentation.true_grains, sc.contacts.found, sc.contacts.true_touching, sc.shapes.grains);
    v.scans.push_back(std::move(sc));
    done(static_cast<double>(k + 1));
  }
  if (!files.tracks.empty()) {
    const track::TracksTable tracks = track::read_tracks_file(files.tracks);
    if (tracks.scans != scans)
      throw DataError(files.tracks.string() + " tracks " + std::to_string(tracks.scans) + " scans, the run has " + std::to_string(scans) +
                      "; run the track stage again");
    for (std::size_t t = 1; t < scans; ++t)
      v.tracking.push_back(score_tracking(tracks, t - 1, t, true_of_label[t - 1], true_of_label[t], truths[t - 1], truths[t]));
  }
  if (!files.micro.empty()) {
    const micro::MicroTables run = micro::read_micro_tables(files.micro);
    if (run.states.size() != scans)
      throw DataError(files.micro.string() + " holds " + std::to_string(run.states.size()) + " states, the run has " + std::to_string(scans) +
                      " scans; run the micro stage again");
    const MicroParameters parameters = micro_parameters(run.parameters_json, files.micro.string());
    for (std::size_t k = 0; k < run.increments.size(); ++k) {
      const auto [from, to] = std::pair{run.increments[k].from, run.increments[k].to};
      if (from >= scans || to >= scans)
        throw DataError(files.micro.string() + ": increment " + std::to_string(k) + " names a state the run does not have; run the micro stage again");
      const TrueDeformation truth = true_deformation(truths[from], truths[to], parameters);
      v.deformation.push_back(score_deformation(run, k, truth, true_of_label[from], true_of_label[to]));
    }
  }
  done(static_cast<double>(scans + 1));
  v.has_simulation = !files.simulation.empty();
  if (v.has_simulation) v.twin = score_twin(truths[0].loading_curve, fdem::read_triaxial_series(files.simulation));
  else v.twin.simulated = truths[0].simulated;
  done(steps);
  return v;
}

}  // namespace graintwin::validate
