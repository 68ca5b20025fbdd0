#pragma once
// The whole micro-mechanics analysis of a series of states (docs/methods.md, micro-mechanics), as tracks2micro
// runs it: per increment (a pair of states) every grain's D2min, local strain and eps_q, their
// log-binned PDFs, the clusters of the highest D2min and the incremental displacement
// distributions; per state g(r), the coordination-number distribution and the PSD.
#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <vector>

#include "graintwin/micro/clusters.hpp"
#include "graintwin/micro/distributions.hpp"
#include "graintwin/micro/local_deformation.hpp"
#include "graintwin/micro/structure.hpp"
#include "graintwin/shape/grain_measure.hpp"

namespace graintwin::micro {

/// N grains followed through T states (grain-major: index i * T + t). A grain absent from a state
/// has a non-finite position there.
struct SeriesStates {
  std::size_t grains = 0, states = 0;
  std::vector<Eigen::Vector3d> position;  ///< m
  std::vector<double> volume;             ///< m^3 (NaN where absent)
  std::vector<double> d50;                ///< m, per state
  /// Per state: every grain's coordination number from a contact list; empty = use the distance
  /// criterion on the positions (MicroOptions::contact_factor).
  std::vector<std::vector<std::uint32_t>> coordination;
  std::vector<shape::SizeDistribution> psd;  ///< per state (may be empty: no PSD output)
};

struct MicroOptions {
  double radius_d50 = 1.5;          ///< D2min neighbourhood (the paper's 1.5 d50)
  std::size_t min_neighbours = 3;
  double min_conditioning = 1e-6;
  ClusterOptions clusters;          ///< top fraction 10 %, contact-distance links
  double contact_factor = 1.1;      ///< coordination by distance: |r_i - r_j| <= factor (r_i + r_j)
  double pdf_per_decade = 5.0;      ///< log bins of the D2min and eps_q PDFs
  double rdf_max_d50 = 5.0;         ///< g(r) up to this distance
  std::size_t rdf_bins = 100;
  Region::Kind region = Region::Kind::cylinder;
  std::size_t displacement_bins = 50;
  double displacement_range_d50 = 0.0;  ///< 0: the largest |component| of the increment
};

struct IncrementResult {
  std::size_t from = 0, to = 0;        ///< states
  std::vector<LocalDeformation> grains;  ///< N
  Histogram pdf_d2min, pdf_eps_q;      ///< log bins over the defined grains
  ClusterStatistics clusters;
  DisplacementDistributions displacement;  ///< increments over d50 of the first state
  double d50 = 0.0;                    ///< m, of the first state
};

struct StateResult {
  Region region;                       ///< enclosing the state's grain centres
  PairCorrelation rdf;
  std::vector<std::uint32_t> coordination;  ///< N (0 where absent)
  CoordinationDistribution coordination_distribution;
  bool coordination_from_contacts = false;
};

struct MicroResult {
  std::vector<IncrementResult> increments;
  std::vector<StateResult> states;
};

/// The increments (from, to) between consecutive states.
std::vector<std::pair<std::size_t, std::size_t>> consecutive_increments(std::size_t states);

/// Runs everything. UsageError on inconsistent sizes or increments naming missing states.
/// `progress` (may be empty) gets the fraction done.
MicroResult analyse_series(const SeriesStates& series, const std::vector<std::pair<std::size_t, std::size_t>>& increments,
                           const MicroOptions& options, const std::function<void(double)>& progress = {});

}  // namespace graintwin::micro
