#pragma once
// RadialTable: a star-shaped body r(direction) tabulated on a cube map so that radius lookups in
// hot loops (packing, contact detection) cost a few multiplications, with no trigonometry and no
// allocation. Volume, centroid, surface area and inertia are integrated once at construction.
//
// Layout: a direction d is projected onto the cube face of its largest |component| k; the face
// coordinates are u = d[a]/|d[k]|, v = d[b]/|d[k]| in [-1, 1] (gnomonic projection), where (a, b)
// are chosen per face so that (e_a, e_b, sign(d[k]) e_k) is right-handed. Each face holds n x n
// nodes at u, v = -1 + 2i/(n-1) plus one ghost ring outside the face (used only for derivatives),
// so nodes on face edges are shared by value and the interpolant is continuous across faces.
#include <Eigen/Core>
#include <cstddef>
#include <functional>
#include <vector>

namespace graintwin::shape {

/// A star-shaped body described by its radius along each direction from its origin (body frame),
/// tabulated on a cube map (6 faces x n x n nodes, bilinear interpolation) so that radius() needs
/// no trig. Immutable after construction, so const use from many threads is safe.
class RadialTable {
 public:
  RadialTable() = default;

  /// Tabulates r(unit_dir) (metres, finite and > 0) with n >= 2 nodes per cube-face edge. The
  /// function receives unit vectors and is called 6 (n+2)^2 times. Throws UsageError for n < 2 and
  /// DataError if r is not finite and positive at some node.
  static RadialTable from_function(const std::function<double(const Eigen::Vector3d&)>& radius,
                                   int n = 64);

  /// The 6 (n+2)^2 unit directions at which a table with n nodes per edge samples r, in storage
  /// order; evaluate r there (e.g. in parallel) and pass the values to from_node_radii().
  static std::vector<Eigen::Vector3d> node_directions(int n);

  /// The frame of cube face f (0..5): node (i, j) of the face (padded indices 0..n+1, in
  /// node_directions() order face by face, j slowest) points along u e_a + v e_b + sign e_k,
  /// normalised, with u = -1 + (i - 1) 2 / (n - 1) and v = -1 + (j - 1) 2 / (n - 1). Lets a
  /// caller evaluate r on the nodes row by row (radial_table_from_sh does).
  struct FaceAxes {
    int k;
    double sign;
    int a;
    int b;
  };
  static FaceAxes face_axes(int face);

  /// Builds a table from radii (metres, > 0) at node_directions(n), same order and size.
  static RadialTable from_node_radii(int n, std::vector<double> radii);

  /// Radius (metres) along `unit_dir` (body frame), bilinear in the cube-face coordinates. The
  /// direction need not be normalised but must be finite and non-zero; the table must not be empty.
  double radius(const Eigen::Vector3d& unit_dir) const;

  /// Outward unit normal (body frame) of the surface at radius(dir) * dir. Uses tangential
  /// derivatives of r from central differences at the nodes, interpolated bilinearly, so the
  /// normal field is continuous (the bilinear surface itself has kinks along cell edges). Same
  /// preconditions as radius(); error O(h^2): 0.34 degree worst for a 1.5:1:0.6 ellipsoid at
  /// n = 64.
  Eigen::Vector3d surface_normal(const Eigen::Vector3d& unit_dir) const;

  /// Smallest / largest tabulated radius (metres) over the face nodes.
  double min_radius() const { return min_radius_; }
  double max_radius() const { return max_radius_; }

  /// Smallest cosine of the angle between the outward normal and the radial direction over the
  /// bilinear body (at its integration points; 1 for a sphere). A point at radial distance s
  /// from the surface is roughly at least s times this from it.
  double min_normal_cosine() const { return min_normal_cosine_; }

  /// Volume (m^3): integral of r^3/3 over the unit sphere, for the bilinear body.
  double volume() const { return volume_; }

  /// Body-frame centroid (m): integral of r^4/4 * dir over the unit sphere, divided by volume().
  Eigen::Vector3d centroid() const { return centroid_; }

  /// Surface area (m^2) of the bilinear body.
  double surface_area() const { return surface_area_; }

  /// Inertia tensor (kg m^2 for unit density 1 kg/m^3, i.e. m^5) about the centroid, body axes:
  /// J = integral over the body of (|x|^2 I - x x^T) dV.
  Eigen::Matrix3d inertia_tensor() const { return inertia_; }

  /// Uniform scale (all radii times s > 0); derived quantities are rescaled, not re-integrated.
  RadialTable scaled(double s) const;

  /// Nodes per cube-face edge (0 for an empty table).
  int nodes_per_edge() const { return n_; }

  /// True for a default-constructed table.
  bool empty() const { return n_ == 0; }

 private:
  // Face f, padded node (i, j) with i along u, j along v, both in [0, n+1]; face node (0, 0) is
  // padded (1, 1).
  std::size_t index(int face, int i, int j) const {
    return (static_cast<std::size_t>(face) * stride_ + j) * stride_ + i;
  }
  // Face, gnomonic coordinates (u, v) of a direction.
  void locate(const Eigen::Vector3d& d, int& face, double& u, double& v) const;
  // The table cell holding a direction: face, gnomonic (u, v), lower corner (i, j) in face-node
  // indices and the bilinear weights (t, w) within the cell.
  struct Cell {
    int face = 0, i = 0, j = 0;
    double u = 0.0, v = 0.0, t = 0.0, w = 0.0;
  };
  Cell cell_of(const Eigen::Vector3d& d) const;
  // Integrates volume, centroid, area and inertia from the table (2 x 2 Gauss points per cell),
  // and finds the smallest normal cosine.
  void integrate();

  int n_ = 0;
  int stride_ = 0;           // n + 2 (ghost ring)
  double inv_h_ = 0.0;       // (n - 1) / 2: face-coordinate units -> cell units
  // 6 * stride^2 radii (m). Single precision: its 6e-8 relative rounding is far below the table's
  // interpolation error (about 1e-3 of the radius), and it halves a packing's largest allocation.
  std::vector<float> r_;
  double min_radius_ = 0.0;
  double max_radius_ = 0.0;
  double min_normal_cosine_ = 1.0;
  double volume_ = 0.0;
  Eigen::Vector3d centroid_ = Eigen::Vector3d::Zero();
  double surface_area_ = 0.0;
  Eigen::Matrix3d inertia_ = Eigen::Matrix3d::Zero();
};

}  // namespace graintwin::shape
