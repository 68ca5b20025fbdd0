#include "graintwin/track/tracks.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "graintwin/core/error.hpp"

namespace graintwin::track {
namespace {

constexpr double nan = std::numeric_limits<double>::quiet_NaN();

}  // namespace

Tracks chain_tracks(const std::vector<ScanGrains>& scans, const ChainOptions& o, const std::function<void(double)>& progress) {
  if (scans.size() < 2) throw UsageError("tracking needs at least two scans");
  if (o.max_gap < 0) throw UsageError("the largest gap must be 0 or more scans");
  const std::size_t n_scans = scans.size();
  Tracks tr;
  tr.scans = n_scans;
  tr.steps.resize(n_scans);
  // track_of[t][i]: the track holding grain i of scan t, or -1.
  std::vector<std::vector<int>> track_of(n_scans);
  for (std::size_t t = 0; t < n_scans; ++t) track_of[t].assign(scans[t].size(), -1);
  const auto start_track = [&](std::size_t t, std::size_t i) {
    track_of[t][i] = static_cast<int>(tr.size());
    tr.grain.emplace_back(n_scans, -1);
    tr.confidence.emplace_back(n_scans, nan);
    tr.grain.back()[t] = static_cast<int>(i);
    ++tr.steps[t].started;
  };
  const auto extend = [&](int track, std::size_t t, std::size_t j, double confidence) {
    track_of[t][j] = track;
    tr.grain[static_cast<std::size_t>(track)][t] = static_cast<int>(j);
    tr.confidence[static_cast<std::size_t>(track)][t] = confidence;
  };
  for (std::size_t i = 0; i < scans[0].size(); ++i) start_track(0, i);
  tr.steps[0].grains = scans[0].size();

  for (std::size_t t = 1; t < n_scans; ++t) {
    StepCounts& st = tr.steps[t];
    st.grains = scans[t].size();
    double confidence_sum = 0.0;
    const Matching m = match_grains(scans[t - 1], scans[t], o.match);
    tr.diagnostics.push_back(m.diagnostics);
    for (std::size_t i = 0; i < scans[t - 1].size(); ++i) {
      const int track = track_of[t - 1][i];
      if (m.partner[i] < 0) {
        ++st.lost;
        continue;
      }
      extend(track, t, static_cast<std::size_t>(m.partner[i]), m.confidence[i]);
      ++st.matched;
      confidence_sum += m.confidence[i];
    }
    // Lost and found: tracks last seen in scan s = t - g, offered the grains of scan t nobody claimed.
    for (int g = 2; g <= o.max_gap + 1 && static_cast<int>(t) - g >= 0; ++g) {
      const std::size_t s = t - static_cast<std::size_t>(g);
      std::vector<std::size_t> lost_grains, free_grains;
      std::vector<int> lost_tracks;
      KnownPairs known;
      for (std::size_t k = 0; k < tr.size(); ++k) {
        const auto& row = tr.grain[k];
        if (row[s] < 0) continue;
        if (row[t] >= 0) {
          known.ref.push_back(static_cast<std::size_t>(row[s]));
          known.def.push_back(static_cast<std::size_t>(row[t]));
        } else if (std::all_of(row.begin() + static_cast<std::ptrdiff_t>(s) + 1, row.begin() + static_cast<std::ptrdiff_t>(t),
                               [](int x) { return x < 0; })) {
          lost_grains.push_back(static_cast<std::size_t>(row[s]));
          lost_tracks.push_back(static_cast<int>(k));
        }
      }
      for (std::size_t j = 0; j < scans[t].size(); ++j)
        if (track_of[t][j] < 0) free_grains.push_back(j);
      if (lost_grains.empty() || free_grains.empty()) continue;
      const Matching f = match_grains(subset(scans[s], lost_grains), subset(scans[t], free_grains), o.match, scans[s],
                                      scans[t], known);
      for (std::size_t k = 0; k < lost_grains.size(); ++k) {
        if (f.partner[k] < 0) continue;
        extend(lost_tracks[k], t, free_grains[static_cast<std::size_t>(f.partner[k])], f.confidence[k]);
        ++st.found;
        confidence_sum += f.confidence[k];
      }
    }
    for (std::size_t j = 0; j < scans[t].size(); ++j)
      if (track_of[t][j] < 0) start_track(t, j);
    st.mean_confidence = st.matched + st.found ? confidence_sum / static_cast<double>(st.matched + st.found) : nan;
    if (progress) progress(static_cast<double>(t) / static_cast<double>(n_scans - 1));
  }
  return tr;
}

Kinematics track_kinematics(const Tracks& tr, const std::vector<const shape::ShapesFile*>& shapes,
                            const RotationOptions& options, const std::function<void(double)>& progress) {
  if (shapes.size() != tr.scans) throw UsageError("track_kinematics: one shapes file per scan is needed");
  int degree = std::numeric_limits<int>::max();
  for (const auto* s : shapes) degree = std::min(degree, s->degree);
  std::optional<RotationEstimator> estimator;
  if (options.method != RotationMethod::none) estimator.emplace(degree, options);
  Kinematics k;
  k.tracks = tr.size();
  k.scans = tr.scans;
  const std::size_t cells = k.tracks * k.scans;
  k.centroid.assign(3 * cells, nan);
  k.displacement.assign(3 * cells, nan);
  k.increment.assign(3 * cells, nan);
  k.rotation.assign(4 * cells, nan);
  k.rotation_step.assign(4 * cells, nan);
  k.rotation_misfit.assign(cells, nan);
  k.rotation_defined.assign(cells, 0);
  std::size_t done = 0;
#pragma omp parallel for schedule(dynamic, 16)
  for (std::size_t n = 0; n < k.tracks; ++n) {
    int first = -1, previous = -1;
    bool cumulative_defined = true;
    Eigen::Quaterniond cumulative = Eigen::Quaterniond::Identity();
    for (std::size_t t = 0; t < k.scans; ++t) {
      const int gi = tr.grain[n][t];
      if (gi < 0) continue;
      const std::size_t c = n * k.scans + t;
      const shape::GrainShape& g = shapes[t]->grains[static_cast<std::size_t>(gi)];
      for (int d = 0; d < 3; ++d) k.centroid[3 * c + d] = g.centroid[d];
      if (first < 0) {
        first = static_cast<int>(t);
        for (int d = 0; d < 3; ++d) k.displacement[3 * c + d] = 0.0;
        for (int d = 0; d < 4; ++d) k.rotation[4 * c + d] = d == 0 ? 1.0 : 0.0;
        previous = static_cast<int>(t);
        continue;
      }
      const std::size_t p = static_cast<std::size_t>(previous);
      const shape::GrainShape& gp = shapes[p]->grains[static_cast<std::size_t>(tr.grain[n][p])];
      const std::size_t c0 = n * k.scans + static_cast<std::size_t>(first);
      for (int d = 0; d < 3; ++d) {
        k.displacement[3 * c + d] = g.centroid[d] - k.centroid[3 * c0 + d];
        k.increment[3 * c + d] = g.centroid[d] - gp.centroid[d];
      }
      if (estimator) {
        const RotationEstimate r = estimator->estimate(gp, g);
        k.rotation_misfit[c] = r.misfit;
        k.rotation_defined[c] = r.defined;
        if (r.defined) {
          const Eigen::Vector4d q(r.rotation.w(), r.rotation.x(), r.rotation.y(), r.rotation.z());
          for (int d = 0; d < 4; ++d) k.rotation_step[4 * c + d] = q[d];
          cumulative = (r.rotation * cumulative).normalized();
        }
        cumulative_defined = cumulative_defined && r.defined;
        if (cumulative_defined) {
          Eigen::Quaterniond q = cumulative;
          if (q.w() < 0.0) q.coeffs() = -q.coeffs();
          const Eigen::Vector4d v(q.w(), q.x(), q.y(), q.z());
          for (int d = 0; d < 4; ++d) k.rotation[4 * c + d] = v[d];
        }
      }
      previous = static_cast<int>(t);
    }
    if (progress) {
#pragma omp critical(track_kinematics_progress)
      {
        ++done;
        if (done % 64 == 0 || done == k.tracks) progress(static_cast<double>(done) / static_cast<double>(k.tracks));
      }
    }
  }
  return k;
}

}  // namespace graintwin::track
