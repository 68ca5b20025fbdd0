#pragma once
// Chart specifications of the report page: what to draw (series of points, rose outlines), never
// how. The report tool turns the run's files into these, writes them as JSON and has
// pipelines/plots/report_charts.py draw each one as a PNG with matplotlib. Also the small
// conversions from stored tables to series: log-binned PDFs, complementary CDFs, the fitted
// curves of the force PDF and of the cluster statistics, rose profiles.
#include <nlohmann/json_fwd.hpp>

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "graintwin/micro/distributions.hpp"
#include "graintwin/micro/forces.hpp"

namespace graintwin::report {

/// How a series is drawn: "line", "dashed", "points", "linepoints", or "vline" (one vertical
/// line per x; y unused).
struct Series {
  std::string name;
  std::string style = "line";
  std::vector<double> x, y;
  std::string group = {};  ///< series of one non-empty group share a colour (data and its fit)
};

/// One picture of a section plane through the sample (report/sections.hpp): a slice of a label
/// image (the experiment) or the outlines where the plane cuts the twin's grains (the simulation),
/// grains filled with one colour per grain identity, or painted with one value each.
struct SectionView {
  std::string title;
  std::string plane = "xz";          ///< "xz": vertical, y = offset; "xy": horizontal, z = offset
  double offset = 0.0;               ///< m
  std::array<double, 4> extent{};    ///< u0, u1, v0, v1 (m): the frame drawn, shared by both sides
  std::string labels_file;           ///< kind=labels: the slice `index` of /labels across the plane's normal
  std::string volume_file;           ///< kind=volume of the same geometry: grey under the labels (may be empty)
  std::size_t index = 0;
  std::vector<std::uint32_t> outline_label;   ///< the twin: the grain of each outline
  std::vector<std::vector<double>> outline;   ///< the twin: closed outlines u0, v0, u1, v1, ... (m)
  /// A grain's colour follows its identity: label identity_label[i] takes the colour of
  /// identity[i] (its label in the reference scan, through the tracks); others their own label's.
  std::vector<std::uint32_t> identity_label, identity;
  std::string quantity;              ///< empty: identity colours; else the colour bar's label
  std::vector<std::uint32_t> value_label;  ///< the grains painted, by label
  std::vector<double> value;               ///< their values; NaN = not defined (drawn grey)
  double colour_min = 0.0, colour_max = 0.0;
  bool colour_log = false;
};

/// A 3D picture of the force-chain network at one frame (drawn with VTK): one tube per
/// grain-grain contact from centroid to centroid, its radius and colour proportional to the
/// contact's normal force, seen by a fixed camera.
struct NetworkView {
  std::vector<double> segments;    ///< x0, y0, z0, x1, y1, z1 per contact (m)
  std::vector<double> force;       ///< N, the normal force of each contact (> 0, compressive)
  double force_max = 0.0;          ///< N, top of the colour scale (bottom 0) and the force of the thickest tube
  double radius_max = 0.0;         ///< m, tube radius at force_max
  std::array<double, 6> bounds{};  ///< x0, x1, y0, y1, z0, z1 (m): the box the camera frames
};

/// A 3D picture of the grains at one state (drawn with VTK), each a sphere of its volume-equivalent
/// diameter at its centroid: the highlighted ones (the high-D2min clusters) opaque and painted with
/// their value, the others as grey points that show the sample's shape, the membrane's balls (a
/// triaxial twin) as pale points.
struct GrainsView {
  std::vector<double> centre;              ///< x, y, z per grain (m)
  std::vector<double> radius;              ///< m
  std::vector<double> value;               ///< NaN = not defined
  std::vector<std::uint8_t> highlighted;   ///< 1: a painted sphere; 0: a grey point
  std::vector<double> membrane;            ///< x, y, z per ball (m); empty without one
  std::string quantity;                    ///< the colour bar's label
  double colour_min = 0.0, colour_max = 0.0;
  bool colour_log = false;
  std::array<double, 6> bounds{};          ///< x0, x1, y0, y1, z0, z1 (m): the box the camera frames
};

/// A 3D picture of the grains' own surfaces at one state (drawn with VTK): triangles coloured by
/// their grain's label (the sections' identity colours), the membrane's balls as spheres, a front
/// quarter cut away, seen by a fixed camera. The triangles go to the chart script through a binary
/// file in the image folder (`mesh_file`, written by write_surface_mesh, removed once drawn):
/// millions of them would not fit in charts.json.
struct SurfacesView {
  std::vector<float> vertices;             ///< x, y, z per vertex (m); not in the JSON
  std::vector<std::uint32_t> triangles;    ///< three vertex indices per triangle; not in the JSON
  std::vector<std::uint32_t> label;        ///< per triangle, its grain's label (its colour); not in the JSON
  std::string mesh_file;                   ///< the file holding them, in the image folder
  std::size_t grains = 0;                  ///< grains drawn
  std::size_t grains_cut = 0;              ///< grains left out by the cutaway
  std::size_t source_triangles = 0;        ///< triangles of the drawn grains before decimation
  std::vector<double> membrane;            ///< x, y, z per ball (m), those outside the cutaway; empty without one
  double membrane_radius = 0.0;            ///< m; 0 draws the balls as points
  std::array<double, 2> cut{};             ///< x, y (m): the corner of the front quarter cut away (x > cut x, y < cut y)
  std::array<double, 6> bounds{};          ///< x0, x1, y0, y1, z0, z1 (m): the box the camera frames
};

/// One PNG. kind "xy": series on Cartesian axes (log axes drop points that are not positive);
/// kind "rose": each series is a rose profile, x = the polar-angle bin edges in degrees from the
/// loading axis z (n + 1), y = the value per bin (n), drawn as a closed outline in the x-z plane,
/// mirrored about both axes (the directions are axes, folded onto the upper hemisphere); kind
/// "section": `sections` side by side, no series; kinds "network", "grains" and "surfaces": the 3D
/// `network`, `grains` or `surfaces`.
struct Chart {
  std::string file;   ///< PNG name inside the report's image folder
  std::string panel;  ///< charts of one panel share their axis limits
  std::string kind = "xy";
  std::string title, x_label, y_label;
  bool x_log = false, y_log = false;
  std::vector<Series> series;
  std::vector<SectionView> sections;  ///< kind "section": drawn side by side in one PNG
  std::optional<NetworkView> network;  ///< kind "network"
  std::optional<GrainsView> grains;    ///< kind "grains"
  std::optional<SurfacesView> surfaces;  ///< kind "surfaces"

  /// Adds a series, keeping only points with finite coordinates (and positive ones on log axes;
  /// vertical lines keep every finite x). Returns false, adding nothing, when no point is left.
  /// A rose series is kept whole (n + 1 edges, n values; a non-finite value becomes 0, an empty band).
  bool add(Series s);
};

nlohmann::json to_json(const Chart& chart);

/// Up to `max_count` indices of 0..count-1, evenly spread, always the first and the last.
std::vector<std::size_t> pick_evenly(std::size_t count, std::size_t max_count);

/// The PDF of a stored histogram: one point per non-empty bin at the bin's centre (geometric
/// centre when `log_bins`), density as stored, x multiplied by `x_scale`.
Series pdf_series(const micro::Histogram& h, bool log_bins, std::string name, double x_scale = 1.0);

/// P(S >= s) of a sample of positive sizes: one point per distinct size, ascending.
Series ccdf_series(const std::vector<double>& sizes, std::string name);

/// The discrete power law P(s) ~ s^-alpha for s >= s_min as a complementary CDF over the sample:
/// P(S >= s) = (tail / n) zeta(alpha, s) / zeta(alpha, s_min) for integer s in [s_min, s_max].
Series power_law_ccdf(double alpha, double s_min, double s_max, std::size_t tail, std::size_t n, std::string name);

/// The line log10 y = a + slope log10 x fitted by least squares to the points (x, y) with both
/// positive (the fit passes through their mean in log space), drawn over their x range;
/// `slope` is the fitted slope (1 / d_f for R_g against s). Empty when no point is positive.
Series log_line_through_mean(const std::vector<double>& x, const std::vector<double>& y, double slope, std::string name);

/// The force PDF's two fits on the density scale of the whole sample (f = f_n / <f_n>):
/// strong_share x exp(-(f - 1) / scale) / scale for f in [1, f_max] and
/// (1 - strong_share) x (theta + 1) f^theta for f in [f_min, 1].
Series strong_force_fit(double scale, double strong_share, double f_max, std::string name);
Series weak_force_fit(double theta, double strong_share, double f_min, std::string name);

/// Share of the histogram's counted values in bins at or above `x` (exact when x is a bin edge,
/// as f = 1 is for log bins aligned to decades).
double share_at_or_above(const micro::Histogram& h, double x);

/// Which per-bin value a rose profile shows.
enum class RoseValue {
  density,     ///< directions per steradian over the whole sphere (isotropic: 1 / (4 pi))
  mean_force,  ///< mean normal force of the contacts in the polar band, N
};
/// The rose profile over the polar angle (azimuths summed): x = band edges in degrees, y = per band.
Series rose_profile(const micro::ForceRose& rose, RoseValue value, std::string name);

}  // namespace graintwin::report
