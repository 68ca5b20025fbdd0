#include "graintwin/synth/ground_truth.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>

#include "graintwin/io/h5file.hpp"
#include "graintwin/io/provenance.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"

namespace graintwin::synth {

namespace {

// Surface points (world) of a grain's table within `reach` of the world point p: its face nodes,
// where the table holds the exact radius (a vertex or edge of an angular grain is sharpest
// there; between nodes the table is bilinear).
std::vector<Eigen::Vector3d> surface_patch(const shape::RadialTable& t, const PackedGrain& g, const Eigen::Vector3d& p,
                                           double reach) {
  const Eigen::Matrix3d rot = g.orientation.toRotationMatrix();
  const Eigen::Vector3d q = rot.transpose() * (p - g.position);
  const int n = t.nodes_per_edge();
  const double step = 2.0 / (n - 1);
  std::vector<Eigen::Vector3d> out;
  for (int face = 0; face < 6; ++face) {
    const shape::RadialTable::FaceAxes ax = shape::RadialTable::face_axes(face);
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        Eigen::Vector3d d = Eigen::Vector3d::Zero();
        d[ax.a] = -1.0 + i * step;
        d[ax.b] = -1.0 + j * step;
        d[ax.k] = ax.sign;
        d.normalize();
        // Cheap screen: a node whose direction is far from q's cannot be within reach.
        if (d.dot(q) < q.norm() - reach - t.max_radius()) continue;
        const Eigen::Vector3d x = t.radius(d) * d;
        if ((x - q).norm() <= reach) out.push_back(g.position + rot * x);
      }
    }
  }
  return out;
}

// Pattern search on the sphere for the minimum of g from `start`, within the hemisphere n.c > 0:
// 8 directions in the tangent plane, the step halved when none improves (g is piecewise linear
// for polyhedra, so diagonals help along its ridges).
template <class G>
Eigen::Vector3d minimise_on_sphere(const G& g, Eigen::Vector3d n, const Eigen::Vector3d& c, double& best) {
  best = g(n);
  for (double step = 0.2; step > 1e-5;) {
    const Eigen::Vector3d t1 = n.unitOrthogonal(), t2 = n.cross(t1);
    bool moved = false;
    for (int k = 0; k < 8 && !moved; ++k) {
      const double phi = k * std::numbers::pi / 4.0;
      const Eigen::Vector3d trial = (n + step * (std::cos(phi) * t1 + std::sin(phi) * t2)).normalized();
      if (trial.dot(c) <= 0.0) continue;
      const double v = g(trial);
      if (v < best) {
        best = v;
        n = trial;
        moved = true;
      }
    }
    if (!moved) step *= 0.5;
  }
  return n;
}

}  // namespace

PairContact separating_contact(const shape::RadialTable& a, const PackedGrain& ga, const shape::RadialTable& b,
                               const PackedGrain& gb, const PairContact& first, double reach) {
  const std::vector<Eigen::Vector3d> pa = surface_patch(a, ga, first.point, reach);
  const std::vector<Eigen::Vector3d> pb = surface_patch(b, gb, first.point, reach);
  const Eigen::Vector3d centre_line = gb.position - ga.position;
  if (pa.empty() || pb.empty() || !(first.normal.norm() > 0.0) || !(centre_line.norm() > 0.0)) return first;
  auto g = [&](const Eigen::Vector3d& n) {
    double ha = -HUGE_VAL, lb = HUGE_VAL;
    for (const auto& x : pa) ha = std::max(ha, n.dot(x));
    for (const auto& y : pb) lb = std::min(lb, n.dot(y));
    return ha - lb;
  };
  // Two starts: the kernel's normal and the centre line; the smaller minimum wins.
  const Eigen::Vector3d c = centre_line.normalized();
  PairContact out = first;
  out.overlap = HUGE_VAL;
  for (const Eigen::Vector3d& start : {Eigen::Vector3d(first.normal.normalized()), c}) {
    if (start.dot(c) <= 0.0) continue;
    double value = 0.0;
    const Eigen::Vector3d n = minimise_on_sphere(g, start, c, value);
    if (value < out.overlap) {
      out.overlap = value;
      out.normal = n;
    }
  }
  return out.overlap < HUGE_VAL ? out : first;
}

std::vector<TrueContact> true_contacts(const std::vector<const shape::RadialTable*>& shapes,
                                       const std::vector<PackedGrain>& poses, double search_gap, double tolerance,
                                       bool separating) {
  const std::vector<GrainContact> found = find_contacts(shapes, poses, search_gap);
  std::vector<TrueContact> out(found.size());
#pragma omp parallel for schedule(dynamic)
  for (std::size_t k = 0; k < found.size(); ++k) {
    const GrainContact& c = found[k];
    const auto radius = [](const shape::RadialTable* t) { return std::cbrt(3.0 * t->volume() / (4.0 * std::numbers::pi)); };
    const double reach = 0.25 * std::min(radius(shapes[c.a]), radius(shapes[c.b]));
    const PairContact pc =
        separating ? separating_contact(*shapes[c.a], poses[c.a], *shapes[c.b], poses[c.b], c.contact, reach) : c.contact;
    TrueContact& t = out[k];
    t.low = static_cast<std::uint32_t>(c.a + 1);
    t.high = static_cast<std::uint32_t>(c.b + 1);
    // Each measure overstates in its own failure mode: the kernel's at sharp edges and corners,
    // the separating one where the patches are not convex (a bump in a dent, roughness), whose
    // convex hulls overlap more than the grains. Neither understates, so the smaller is kept;
    // the normal is the separating one (on a rough patch, that of the local hulls' contact plane).
    t.overlap = std::min(c.contact.overlap, pc.overlap);
    t.point = pc.point;
    t.normal = pc.normal;
    t.touching = std::abs(t.overlap) <= tolerance;
  }
  return out;
}

namespace {
// N x k row-major copy of per-grain vectors.
template <class F>
std::vector<double> rows(std::size_t n, int k, F&& get) {
  std::vector<double> out(n * static_cast<std::size_t>(k));
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < k; ++c) out[i * k + c] = get(i, c);
  return out;
}
}  // namespace

void write_ground_truth(const std::filesystem::path& path, const GroundTruth& t,
                        const std::vector<std::string>& history) {
  using io::DatasetOptions;
  auto with_units = [](const char* u) {
    DatasetOptions o;
    o.units = u;
    return o;
  };
  io::H5File f = io::H5File::create(path);
  io::write_root_attrs(f, schema::kind::ground_truth);
  f.set_attr("/", "scan_index", static_cast<long long>(t.scan_index));
  f.set_attr("/", "axial_strain", t.axial_strain);
  f.set_attr("/", "sample_height", t.sample_height);
  f.set_attr("/", "sample_radius", t.sample_radius);
  f.set_attr("/", "solid_fraction", t.solid_fraction);
  f.set_attr("/", "void_ratio", t.void_ratio);
  f.set_attr("/", "contact_tolerance", t.contact_tolerance);
  io::write_image(f, schema::path::labels, t.labels, "1");

  const std::size_t n = t.poses.size();
  std::vector<std::uint32_t> label(n);
  for (std::size_t i = 0; i < n; ++i) label[i] = static_cast<std::uint32_t>(i + 1);
  f.write("/grains/label", label);
  const auto& P = t.poses;
  f.write("/grains/centroid", rows(n, 3, [&](std::size_t i, int c) { return P[i].position[c]; }).data(), {n, 3},
          with_units("m"));
  f.write("/grains/orientation",
          rows(n, 4, [&](std::size_t i, int c) { return c == 0 ? P[i].orientation.w() : P[i].orientation.vec()[c - 1]; })
              .data(),
          {n, 4}, with_units("1"));
  f.set_attr("/grains/orientation", "convention", std::string("unit quaternion (w, x, y, z), body to world"));
  f.write("/grains/volume", t.volume, with_units("m^3"));
  f.write("/grains/equivalent_diameter", t.equivalent_diameter, with_units("m"));
  f.write("/grains/sphericity", t.sphericity, with_units("1"));
  f.write("/grains/aspect_ratio", t.aspect_ratio, with_units("1"));
  const hsize_t ncoef = static_cast<hsize_t>(t.sh_coeffs.cols());
  const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> cw = t.sh_coeffs, cb = t.sh_coeffs_body,
                                                                               inv = t.sh_invariants;
  f.write("/sh/coeffs", cw.data(), {n, ncoef}, with_units("m"));
  f.write("/sh/coeffs_body", cb.data(), {n, ncoef}, with_units("m"));
  f.write("/sh/invariants", inv.data(), {n, static_cast<hsize_t>(inv.cols())}, with_units("m"));
  f.set_attr("/sh/coeffs", "degree", static_cast<long long>(t.sh_degree));
  f.set_attr("/sh/coeffs", "basis",
             std::string("real orthonormal, index n*n+n+m, no Condon-Shortley phase (graintwin/shape/sh_basis.hpp)"));

  const std::size_t m = t.contacts.size();
  std::vector<std::uint32_t> pair(2 * m);
  std::vector<std::uint8_t> touching(m);
  std::vector<double> overlap(m);
  for (std::size_t k = 0; k < m; ++k) {
    pair[2 * k] = t.contacts[k].low;
    pair[2 * k + 1] = t.contacts[k].high;
    touching[k] = t.contacts[k].touching;
    overlap[k] = t.contacts[k].overlap;
  }
  f.write("/contacts/pair", pair.data(), {m, 2});
  f.write("/contacts/normal", rows(m, 3, [&](std::size_t k, int c) { return t.contacts[k].normal[c]; }).data(), {m, 3},
          with_units("1"));
  f.write("/contacts/point", rows(m, 3, [&](std::size_t k, int c) { return t.contacts[k].point[c]; }).data(), {m, 3},
          with_units("m"));
  f.write("/contacts/overlap", overlap, with_units("m"));
  f.write("/contacts/touching", touching);
  io::write_history(f, history);
}

}  // namespace graintwin::synth
