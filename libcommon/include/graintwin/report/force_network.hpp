#pragma once
// The report's 3D pictures of the simulated force-chain network (docs/report.md, "Force-chain
// network"): at each frame shown, the strong network (every grain-grain contact pushing its grains
// apart with at least the mean force) as tubes between the grains' centroids, radius and colour proportional to its normal force, one scale and one
// fixed camera for every frame so the network's growth and collapse compare frame to frame.
#include <Eigen/Core>

#include <vector>

#include "graintwin/micro/simulation.hpp"
#include "graintwin/report/panels.hpp"
#include "graintwin/report/run_data.hpp"

namespace graintwin::report {

/// The contacts of a frame that carry a compressive normal force (> 0), each from its first
/// grain's centroid to its second's, with that force (N).
struct ForceNetwork {
  std::vector<Eigen::Vector3d> from, to;
  std::vector<double> force;
};
ForceNetwork force_network(const std::vector<Eigen::Vector3d>& centroid, const micro::FrameContacts& contacts);
/// The strong network (Radjai et al. 1998): the contacts whose force is at least the mean of the
/// network's, the chains that carry the deviatoric load; the weak rest would hide them in 3D.
ForceNetwork strong_network(const ForceNetwork& network);

/// One panel per frame shown (pick_evenly, at most options.max_series): the experiment's side says
/// CT measures no forces, the simulation's shows the frame's strong network. The colour scale and the thickest
/// tube are the 99th percentile of the forces of every frame shown; the tube radius at it is 0.15
/// d50; the camera frames the union of the networks. A run without simulation gets one panel
/// saying so.
std::vector<Panel> force_network_panels(const RunFiles& files, const SimulationData& simulation, const PanelOptions& options);

}  // namespace graintwin::report
