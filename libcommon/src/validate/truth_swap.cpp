#include "graintwin/validate/truth_swap.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <string>

#include "graintwin/core/error.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/segment/labels.hpp"
#include "graintwin/shape/sand_shape.hpp"
#include "graintwin/shape/sh_basis.hpp"
#include "graintwin/validate/label_match.hpp"
#include "graintwin/validate/scores.hpp"

namespace graintwin::validate {

namespace {

void require_same_shape(const Volume<std::uint32_t>& truth, const Volume<std::uint32_t>& labels, const char* what) {
  if (truth.shape() != labels.shape())
    throw DataError(std::string("the truth's label image and the ") + what +
                    " differ in shape; give the truth file of the same scan");
}

/// `json_text` (a free-form JSON object, or empty) with `key` set to `value`.
std::string with_entry(const std::string& json_text, const char* key, nlohmann::json value) {
  nlohmann::json j = nlohmann::json::parse(json_text.empty() ? std::string("{}") : json_text, nullptr, false);
  if (!j.is_object()) j = nlohmann::json::object();
  j[key] = std::move(value);
  return j.dump();
}

/// `v` with `size` entries: cut or padded with zeros.
Eigen::VectorXd resized(const Eigen::VectorXd& v, Eigen::Index size) {
  Eigen::VectorXd out = Eigen::VectorXd::Zero(size);
  const Eigen::Index n = std::min(size, v.size());
  out.head(n) = v.head(n);
  return out;
}

/// Grain `g` as measured, its surface and what depends on it replaced by true grain `t`'s.
shape::GrainShape true_shape(const synth::GroundTruth& truth, std::size_t t, const shape::GrainShape& g, int degree,
                             bool positions) {
  shape::GrainShape s = g;
  const Eigen::VectorXd coeffs = truth.sh_coeffs.row(static_cast<Eigen::Index>(t)).transpose();
  shape::set_form(s, shape::shape_stats(shape::radial_table_from_sh(coeffs, truth.sh_degree)));
  s.sh_degree = std::min(truth.sh_degree, degree);
  s.coeffs = resized(coeffs, shape::sh_count(degree));
  s.invariants = resized(truth.sh_invariants.row(static_cast<Eigen::Index>(t)).transpose(), degree + 1);
  s.rms_error = s.max_error = s.volume_error = 0.0;
  s.multi_exit_fraction = s.hidden_void_fraction = s.reentry_depth = 0.0;
  s.flags = 0;  // the surface is exact: whole, star-shaped, however small or cut by the field of view
  if (positions) s.centroid = truth.poses[t].position;
  return s;
}

}  // namespace

segment::LabelsFile labels_from_truth(const synth::GroundTruth& truth, const segment::LabelsFile& measured) {
  require_same_shape(truth.labels, measured.labels, "labels file's image");
  segment::LabelsFile out;
  out.labels = truth.labels;
  out.grains = segment::grain_table(out.labels);
  out.sample.region = measured.sample.region;
  out.sample.void_ratio = true_void_ratio(out.labels, out.sample.region);
  out.parameters_json = with_entry(measured.parameters_json, "truth_swap",
                                   {{"label_image", "the scan's ground truth (true grain i is label i + 1)"},
                                    {"sample_cylinder", "as segmented"}});
  return out;
}

ShapeSwap shapes_from_truth(const synth::GroundTruth& truth, const shape::ShapesFile& measured,
                            const Volume<std::uint32_t>& labels, const ShapeSwapOptions& options) {
  require_same_shape(truth.labels, labels, "labels the shapes were measured from");
  if (truth.sh_coeffs.rows() != static_cast<Eigen::Index>(truth.poses.size()))
    throw DataError("the truth holds no SH surface for some of its grains; remake the series with ctsynth");
  const std::vector<std::uint32_t> true_of_label = match_labels(truth.labels, labels).faithful_grain();
  ShapeSwap out;
  out.file = measured;
  out.file.degree = std::max(measured.degree, truth.sh_degree);
  for (shape::GrainShape& g : out.file.grains) {
    const std::uint32_t t = g.label < true_of_label.size() ? true_of_label[g.label] : 0;
    if (t == 0 || t > truth.poses.size()) {
      g.coeffs = resized(g.coeffs, shape::sh_count(out.file.degree));
      g.invariants = resized(g.invariants, out.file.degree + 1);
      ++out.kept;
      continue;
    }
    g = true_shape(truth, t - 1, g, out.file.degree, options.positions);
    ++out.swapped;
  }
  out.file.psd = shape::size_distribution(out.file.grains);
  out.file.parameters_json = with_entry(measured.parameters_json, "truth_swap",
                                        {{"surfaces", "the scan's ground truth where the labels reproduce a true grain (IoU >= 0.8)"},
                                         {"centroids", options.positions ? "the ground truth's" : "as measured"},
                                         {"swapped", out.swapped},
                                         {"kept", out.kept}});
  return out;
}

namespace {
std::string kind_of(const std::filesystem::path& path) { return io::file_kind(io::H5File::open(path)); }
}  // namespace

void check_truth_swap(const TruthSwapFiles& files, const ShapeSwapOptions& options) {
  io::open_kind(files.truth, schema::kind::ground_truth, "pass a truth_NNN.h5 that ctsynth wrote beside its scan");
  const std::string kind = kind_of(files.input);
  if (kind == schema::kind::labels) {
    if (options.positions)
      throw UsageError(files.input.string() + " is a labels file, which holds no centroids to swap; drop --positions or pass a shapes file");
    return;
  }
  if (kind != schema::kind::shapes)
    throw UsageError(files.input.string() + " is " + (kind.empty() ? std::string("not a GrainTwin file") : "kind=" + kind) +
                     "; pass a labels file (ct2labels) or a shapes file (labels2shapes)");
  if (files.labels.empty())
    throw UsageError("the shapes file " + files.input.string() + " needs the labels file it was measured from; give it with --labels");
  io::open_kind(files.labels, schema::kind::labels, "pass the labels file the shapes were measured from (ct2labels)");
}

TruthSwapSummary swap_truth(const TruthSwapFiles& files, const ShapeSwapOptions& options, const std::filesystem::path& output,
                            const std::vector<std::string>& history) {
  check_truth_swap(files, options);
  const synth::GroundTruth truth = synth::read_ground_truth(files.truth);
  TruthSwapSummary summary;
  try {
    if (kind_of(files.input) == schema::kind::labels) {
      const segment::LabelsFile swapped = labels_from_truth(truth, segment::read_labels_file(files.input));
      segment::write_labels_file(output, swapped, history);
      summary.kind = schema::kind::labels;
      summary.grains = summary.swapped = swapped.grains.size();
      return summary;
    }
    const ShapeSwap swapped =
        shapes_from_truth(truth, shape::read_shapes_file(files.input), segment::read_labels_file(files.labels).labels, options);
    shape::write_shapes_file(output, swapped.file, history);
    summary.kind = schema::kind::shapes;
    summary.grains = swapped.file.grains.size(), summary.swapped = swapped.swapped, summary.kept = swapped.kept;
  } catch (Error& e) {
    e.add_context("while putting the truth " + files.truth.string() + " into " + files.input.string());
    throw;
  }
  return summary;
}

}  // namespace graintwin::validate
