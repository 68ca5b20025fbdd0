#pragma once
// The report's 3D pictures of D2min and its clusters (docs/report.md, "D2min clusters in 3D"), and
// of eps_q (every grain painted, a front quarter cut away; "eps_q in 3D"):
// for each increment shown, the grains at the increment's first state as spheres of their
// volume-equivalent diameter at their centroids, the members of the high-D2min clusters
// (tracks2micro's /grains/cluster) opaque and painted with their D2min, the others as grey points;
// scans beside the twin (with its membrane), one colour scale, one fixed camera.
#include <array>
#include <vector>

#include "graintwin/report/panels.hpp"
#include "graintwin/report/run_data.hpp"
#include "graintwin/report/surfaces_3d.hpp"

namespace graintwin::report {

/// The box holding every sphere (centre +- radius) of `centre` (x, y, z per sphere) and `radius`,
/// grown by `more` (x0, x1, y0, y1, z0, z1); `more` as it is when there are no spheres.
std::array<double, 6> sphere_bounds(const std::vector<double>& centre, const std::vector<double>& radius, std::array<double, 6> more);

/// One panel per increment shown (pick_evenly, at most options.max_series, over the longer side).
/// The experiment's grains are the tracks (micro.h5's rows) at their centroid in the increment's
/// first scan (tracks.h5), sized by that scan's shapes file (else the increment's d50); the
/// simulation's are its grains at the increment's first frame, sized by their volumes, with the
/// frame's membrane balls. A side without its files says which stage makes them.
std::vector<Panel> cluster_3d_panels(const RunFiles& files, const ExperimentData& experiment, const SimulationData& simulation,
                                     const PanelOptions& options);

/// Removes from `view` its grains (centres) and membrane balls in `cut`.
void cut_front_quarter(GrainsView& view, const FrontQuarter& cut);

/// As cluster_3d_panels, with every grain painted with its eps_q (/grains/eps_q, linear scale) and
/// the quarter in front of the middle of the grains shown (the camera box) cut away.
std::vector<Panel> eps_q_3d_panels(const RunFiles& files, const ExperimentData& experiment, const SimulationData& simulation,
                                   const PanelOptions& options);

}  // namespace graintwin::report
