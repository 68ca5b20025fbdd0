// Real orthonormal spherical harmonics by a trig-free Legendre recurrence: values, design
// matrices, least-squares fits, invariants and Gauss-Legendre moments. Convention in sh_basis.hpp.
#include "graintwin/shape/sh_basis.hpp"

#include <gsl/gsl_integration.h>

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <numbers>
#include <string>

#include "graintwin/core/error.hpp"
#include "graintwin/core/parallel.hpp"

namespace graintwin::shape {

namespace {

void require_coeffs(const Eigen::VectorXd& coeffs, int degree) {
  if (coeffs.size() != sh_count(degree)) {
    throw UsageError("an SH coefficient vector of degree " + std::to_string(degree) + " needs " +
                     std::to_string(sh_count(degree)) + " entries but has " +
                     std::to_string(coeffs.size()) + "; pass the degree the vector was made with");
  }
}

// Per-thread buffer of basis values, grown on demand, so hot loops do not allocate.
double* scratch_values(int degree) {
  thread_local std::vector<double> values;
  const auto k = static_cast<std::size_t>(sh_count(degree));
  if (values.size() < k) values.resize(k);
  return values.data();
}

// The orthonormal associated Legendre functions with the sin^m factor taken out,
// Nbar_n^m P_n^m(cos theta) = sin^m(theta) Q_n^m(cos theta), by the standard stable recurrence
//   Q_m^m = Q_{m-1}^{m-1} sqrt((2m + 1) / (2m)),  Q_0^0 = 1 / sqrt(4 pi),
//   Q_n^m = a z Q_{n-1}^m - b Q_{n-2}^m,  a = sqrt((4n^2 - 1) / (n^2 - m^2)),
//   b = a sqrt(((n-1)^2 - m^2) / (4(n-1)^2 - 1))            (b = 0 for n = m + 1).
// With sin^m(theta) (cos m phi, sin m phi) = Re, Im (x + i y)^m on the unit sphere the basis needs
// no trigonometry. The coefficients do not depend on the degree asked for, so one table serves
// every degree; computing them per call (as GSL's Legendre arrays do) cost most of the time.
constexpr int kMaxDegree = 100;
struct LegendreTable {
  std::vector<double> qmm;   // Q_m^m
  std::vector<double> a, b;  // at n (n + 1) / 2 + m
};
const LegendreTable& legendre_table() {
  static const LegendreTable table = [] {
    LegendreTable t;
    t.qmm.resize(kMaxDegree + 1);
    t.qmm[0] = 1.0 / std::sqrt(4.0 * std::numbers::pi);
    for (int m = 1; m <= kMaxDegree; ++m) t.qmm[m] = t.qmm[m - 1] * std::sqrt((2.0 * m + 1.0) / (2.0 * m));
    const std::size_t size = (kMaxDegree + 1) * (kMaxDegree + 2) / 2;
    t.a.assign(size, 0.0);
    t.b.assign(size, 0.0);
    for (int n = 1; n <= kMaxDegree; ++n) {
      for (int m = 0; m < n; ++m) {
        const double nn = n, mm = m;
        const double a = std::sqrt((4.0 * nn * nn - 1.0) / (nn * nn - mm * mm));
        const std::size_t k = static_cast<std::size_t>(n * (n + 1) / 2 + m);
        t.a[k] = a;
        t.b[k] = a * std::sqrt(((nn - 1.0) * (nn - 1.0) - mm * mm) / (4.0 * (nn - 1.0) * (nn - 1.0) - 1.0));
      }
    }
    return t;
  }();
  return table;
}

void require_supported(int degree) {
  if (degree < 0 || degree > kMaxDegree) {
    throw UsageError("SH degree " + std::to_string(degree) + " is outside 0.." +
                     std::to_string(kMaxDegree) + "; use a degree up to " +
                     std::to_string(kMaxDegree));
  }
}

// Basis values at the unit vector (x, y, z), index n*n + n + m.
void sh_values_unit(int degree, double x, double y, double z, double* out) {
  const LegendreTable& t = legendre_table();
  double re = 1.0, im = 0.0;  // (x + i y)^m
  for (int m = 0; m <= degree; ++m) {
    if (m > 0) {
      const double re_next = re * x - im * y;
      im = re * y + im * x;
      re = re_next;
    }
    const double scale = m > 0 ? std::numbers::sqrt2 : 1.0;
    const double cos_part = scale * re, sin_part = scale * im;
    double q_prev = 0.0, q = t.qmm[m];
    for (int n = m; n <= degree; ++n) {
      if (n > m) {
        const std::size_t k = static_cast<std::size_t>(n * (n + 1) / 2 + m);
        const double q_next = t.a[k] * z * q - t.b[k] * q_prev;
        q_prev = q;
        q = q_next;
      }
      out[n * n + n + m] = q * cos_part;
      if (m > 0) out[n * n + n - m] = q * sin_part;
    }
  }
}

// sum_k coeffs[k] Y_k at the unit vector (x, y, z): the recurrence of sh_values_unit() with the
// sums over n taken per order m, so no basis values are stored.
double sh_sum_unit(int degree, const double* coeffs, double x, double y, double z) {
  const LegendreTable& t = legendre_table();
  double re = 1.0, im = 0.0;  // (x + i y)^m
  double sum = 0.0;
  for (int m = 0; m <= degree; ++m) {
    if (m > 0) {
      const double re_next = re * x - im * y;
      im = re * y + im * x;
      re = re_next;
    }
    double q_prev = 0.0, q = t.qmm[m];
    double cos_sum = coeffs[m * m + 2 * m] * q, sin_sum = coeffs[m * m] * q;  // n = m
    for (int n = m + 1; n <= degree; ++n) {
      const std::size_t k = static_cast<std::size_t>(n * (n + 1) / 2 + m);
      const double q_next = t.a[k] * z * q - t.b[k] * q_prev;
      q_prev = q;
      q = q_next;
      cos_sum += coeffs[n * n + n + m] * q;
      sin_sum += coeffs[n * n + n - m] * q;
    }
    sum += m > 0 ? std::numbers::sqrt2 * (cos_sum * re + sin_sum * im) : cos_sum;
  }
  return sum;
}

// The Gauss-Legendre x equispaced-azimuth grid of sh_moments() for one degree, with the basis
// split into its parts: Legendre factors at each cos(theta) node (index n*n + n + m, m >= 0,
// including the sqrt(2) of m > 0) and cos, sin(m phi) at each azimuth. r on the grid is then a
// sum over m of products, far cheaper than the basis at every node.
struct MomentGrid {
  int n_theta = 0, n_phi = 0;
  std::vector<double> x, weight, legendre, cos_m, sin_m;
};
MomentGrid build_moment_grid(int degree) {
  // r^4 * dir has degree 4L+1: Gauss-Legendre with 2L+1 nodes is exact for polynomial degree
  // 4L+1 in cos(theta), and 4L+2 equispaced azimuths are exact for trig degree 4L+1.
  MomentGrid g;
  g.n_theta = 2 * degree + 1;
  g.n_phi = 4 * degree + 2;
  const int k = sh_count(degree);
  std::unique_ptr<gsl_integration_glfixed_table, decltype(&gsl_integration_glfixed_table_free)>
      table(gsl_integration_glfixed_table_alloc(static_cast<std::size_t>(g.n_theta)),
            &gsl_integration_glfixed_table_free);
  g.x.resize(g.n_theta);
  g.weight.resize(g.n_theta);
  g.legendre.resize(static_cast<std::size_t>(g.n_theta * k));
  for (int i = 0; i < g.n_theta; ++i) {
    gsl_integration_glfixed_point(-1.0, 1.0, static_cast<std::size_t>(i), &g.x[i], &g.weight[i], table.get());
    // At phi = 0 the m >= 0 entries are the Legendre factors themselves.
    const double s = std::sqrt(std::max(0.0, 1.0 - g.x[i] * g.x[i]));
    sh_values_unit(degree, s, 0.0, g.x[i], &g.legendre[static_cast<std::size_t>(i * k)]);
  }
  g.cos_m.resize(static_cast<std::size_t>(g.n_phi * (degree + 1)));
  g.sin_m.resize(g.cos_m.size());
  for (int j = 0; j < g.n_phi; ++j) {
    for (int m = 0; m <= degree; ++m) {
      const double angle = 2.0 * std::numbers::pi * m * j / g.n_phi;
      g.cos_m[static_cast<std::size_t>(j * (degree + 1) + m)] = std::cos(angle);
      g.sin_m[static_cast<std::size_t>(j * (degree + 1) + m)] = std::sin(angle);
    }
  }
  return g;
}

// Basis values along a non-zero direction (need not be unit).
void sh_values_dir(int degree, const Eigen::Vector3d& d, double* out) {
  const Eigen::Vector3d u = d / d.norm();
  sh_values_unit(degree, u.x(), u.y(), u.z(), out);
}

// A homogeneous polynomial of degree d in (x, y, z): the coefficient of x^i y^j z^(d-i-j) at
// i (d + 1) + j for i + j <= d (other entries stay zero).
struct HomPoly {
  int d = 0;
  std::vector<double> c;
  explicit HomPoly(int degree) : d(degree), c(static_cast<std::size_t>((degree + 1) * (degree + 1)), 0.0) {}
  double& at(int i, int j) { return c[static_cast<std::size_t>(i * (d + 1) + j)]; }
  double at(int i, int j) const { return c[static_cast<std::size_t>(i * (d + 1) + j)]; }
};

// a z p - b (x^2 + y^2 + z^2) q, with deg q = deg p - 1 (q may be of degree -1: absent).
HomPoly legendre_step(double a, const HomPoly& p, double b, const HomPoly* q) {
  HomPoly out(p.d + 1);
  for (int i = 0; i <= p.d; ++i) {
    for (int j = 0; i + j <= p.d; ++j) out.at(i, j) += a * p.at(i, j);
  }
  if (q) {
    for (int i = 0; i <= q->d; ++i) {
      for (int j = 0; i + j <= q->d; ++j) {
        const double v = b * q->at(i, j);
        out.at(i + 2, j) -= v;
        out.at(i, j + 2) -= v;
        out.at(i, j) -= v;
      }
    }
  }
  return out;
}

HomPoly product(const HomPoly& p, const HomPoly& q, double scale) {
  HomPoly out(p.d + q.d);
  for (int i = 0; i <= p.d; ++i) {
    for (int j = 0; i + j <= p.d; ++j) {
      if (p.at(i, j) == 0.0) continue;
      for (int k = 0; k <= q.d; ++k) {
        for (int l = 0; k + l <= q.d; ++l) out.at(i + k, j + l) += scale * p.at(i, j) * q.at(k, l);
      }
    }
  }
  return out;
}

// Tables that depend only on the SH degree, built once per degree by `build` and shared.
template <class T>
std::shared_ptr<const T> per_degree(int degree, T (*build)(int)) {
  static std::mutex mutex;
  static std::map<int, std::shared_ptr<const T>> cache;
  const std::lock_guard<std::mutex> lock(mutex);
  auto& entry = cache[degree];
  if (!entry) entry = std::make_shared<const T>(build(degree));
  return entry;
}

// The basis functions as homogeneous polynomials of their degree (the solid harmonics
// |x|^n Y_n^m(x / |x|)), index n*n + n + m, from the recurrence of legendre_table() run on
// polynomials: Q_n^m(z) becomes a polynomial in z and |x|^2, (x + i y)^m stays as it is. Built
// once per degree.
std::vector<HomPoly> build_solid_harmonics(int degree) {
  const LegendreTable& t = legendre_table();
  std::vector<HomPoly> basis(static_cast<std::size_t>(sh_count(degree)), HomPoly(0));
  for (int m = 0; m <= degree; ++m) {
    // Re and Im of (x + i y)^m = sum_k C(m, k) x^(m-k) (i y)^k.
    HomPoly re(m), im(m);
    double binom = 1.0;
    for (int k = 0; k <= m; ++k) {
      const double sign = (k / 2) % 2 == 0 ? 1.0 : -1.0;
      (k % 2 == 0 ? re : im).at(m - k, k) = sign * binom;
      binom = binom * (m - k) / (k + 1);
    }
    const double scale = m > 0 ? std::numbers::sqrt2 : 1.0;
    HomPoly q_prev(0), q(0);
    q.at(0, 0) = t.qmm[m];
    bool has_prev = false;
    for (int n = m; n <= degree; ++n) {
      if (n > m) {
        const std::size_t k = static_cast<std::size_t>(n * (n + 1) / 2 + m);
        HomPoly next = legendre_step(t.a[k], q, t.b[k], has_prev ? &q_prev : nullptr);
        q_prev = std::move(q);
        q = std::move(next);
        has_prev = true;
      }
      basis[static_cast<std::size_t>(n * n + n + m)] = product(q, re, scale);
      if (m > 0) basis[static_cast<std::size_t>(n * n + n - m)] = product(q, im, scale);
    }
  }
  return basis;
}

}  // namespace

int sh_count(int degree) {
  if (degree < 0) {
    throw UsageError("an SH degree must be >= 0 (got " + std::to_string(degree) + ")");
  }
  return (degree + 1) * (degree + 1);
}

void real_sh_values(int degree, double cos_theta, double phi, double* out) {
  require_supported(degree);
  const double z = std::clamp(cos_theta, -1.0, 1.0);
  const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
  sh_values_unit(degree, s * std::cos(phi), s * std::sin(phi), z, out);
}

Eigen::MatrixXd sh_design_matrix(int degree, const std::vector<Eigen::Vector3d>& unit_dirs) {
  const int k = sh_count(degree);
  require_supported(degree);
  const auto rows = static_cast<std::ptrdiff_t>(unit_dirs.size());
  for (const Eigen::Vector3d& d : unit_dirs) {
    if (!(d.squaredNorm() > 0.0) || !d.allFinite()) {
      throw UsageError("sh_design_matrix got a zero or non-finite direction; pass non-zero "
                       "direction vectors");
    }
  }
  Eigen::MatrixXd a(rows, k);
#pragma omp parallel for schedule(static) if (rows > 256) num_threads(useful_threads(static_cast<std::size_t>(rows)))
  for (std::ptrdiff_t i = 0; i < rows; ++i) {
    double* values = scratch_values(degree);
    sh_values_dir(degree, unit_dirs[static_cast<std::size_t>(i)], values);
    for (int j = 0; j < k; ++j) a(i, j) = values[j];
  }
  return a;
}

double sh_radius(const Eigen::VectorXd& coeffs, int degree, const Eigen::Vector3d& unit_dir) {
  require_coeffs(coeffs, degree);
  require_supported(degree);
  const Eigen::Vector3d u = unit_dir / unit_dir.norm();
  return sh_sum_unit(degree, coeffs.data(), u.x(), u.y(), u.z());
}

Eigen::VectorXd sh_invariants(const Eigen::VectorXd& coeffs, int degree) {
  require_coeffs(coeffs, degree);
  Eigen::VectorXd inv(degree + 1);
  for (int n = 0; n <= degree; ++n) inv[n] = coeffs.segment(n * n, 2 * n + 1).norm();
  return inv;
}

std::vector<Eigen::Vector3d> fibonacci_directions(int n) {
  if (n < 1) {
    throw UsageError("fibonacci_directions needs n >= 1 (got " + std::to_string(n) + ")");
  }
  const double golden_angle = std::numbers::pi * (3.0 - std::sqrt(5.0));
  std::vector<Eigen::Vector3d> dirs(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    // Equal-area bands in z (cell centres), golden-angle steps in azimuth.
    const double z = 1.0 - (2.0 * i + 1.0) / n;
    const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = golden_angle * i;
    dirs[static_cast<std::size_t>(i)] = Eigen::Vector3d(s * std::cos(phi), s * std::sin(phi), z);
  }
  return dirs;
}

Eigen::VectorXd sh_fit(const std::function<double(const Eigen::Vector3d&)>& r, int degree,
                       int n_dirs) {
  const int k = sh_count(degree);
  if (n_dirs < k) {
    throw UsageError("sh_fit of degree " + std::to_string(degree) + " needs at least " +
                     std::to_string(k) + " directions (got " + std::to_string(n_dirs) +
                     "); use about " + std::to_string(2 * k));
  }
  const std::vector<Eigen::Vector3d> dirs = fibonacci_directions(n_dirs);
  Eigen::VectorXd b(n_dirs);
  for (int i = 0; i < n_dirs; ++i) {
    b[i] = r(dirs[static_cast<std::size_t>(i)]);
    if (!std::isfinite(b[i])) {
      throw DataError("sh_fit: the sampled function is not finite along a direction; fix the "
                      "function so it is defined on the whole sphere");
    }
  }
  return sh_design_matrix(degree, dirs).householderQr().solve(b);
}

ShMoments sh_moments(const Eigen::VectorXd& coeffs, int degree) {
  require_coeffs(coeffs, degree);
  require_supported(degree);
  const std::shared_ptr<const MomentGrid> grid = per_degree(degree, &build_moment_grid);
  const int k = sh_count(degree);
  const int orders = degree + 1;
  std::vector<double> cos_part(orders), sin_part(orders);
  double vol = 0.0;
  Eigen::Vector3d first = Eigen::Vector3d::Zero();
  double r_min = std::numeric_limits<double>::infinity();
  const double w_phi = 2.0 * std::numbers::pi / grid->n_phi;
  for (int i = 0; i < grid->n_theta; ++i) {
    const double x = grid->x[i];
    const double s = std::sqrt(std::max(0.0, 1.0 - x * x));
    const double* legendre = &grid->legendre[static_cast<std::size_t>(i * k)];
    // r(theta_i, phi) = sum_m cos_part[m] cos(m phi) + sin_part[m] sin(m phi).
    for (int m = 0; m <= degree; ++m) {
      double c = 0.0, d = 0.0;
      for (int n = m; n <= degree; ++n) {
        c += coeffs[n * n + n + m] * legendre[n * n + n + m];
        if (m > 0) d += coeffs[n * n + n - m] * legendre[n * n + n + m];
      }
      cos_part[m] = c;
      sin_part[m] = d;
    }
    const double w = grid->weight[i] * w_phi;
    for (int j = 0; j < grid->n_phi; ++j) {
      const double* cm = &grid->cos_m[static_cast<std::size_t>(j * orders)];
      const double* sm = &grid->sin_m[static_cast<std::size_t>(j * orders)];
      double r = 0.0;
      for (int m = 0; m <= degree; ++m) r += cos_part[m] * cm[m] + sin_part[m] * sm[m];
      const double r3 = r * r * r;
      vol += r3 / 3.0 * w;
      const double cos_phi = degree > 0 ? cm[1] : std::cos(w_phi * j);
      const double sin_phi = degree > 0 ? sm[1] : std::sin(w_phi * j);
      first += (r3 * r / 4.0 * w) * Eigen::Vector3d(s * cos_phi, s * sin_phi, x);
      r_min = std::min(r_min, r);
    }
  }
  ShMoments m;
  m.volume = vol;
  m.centroid = first / vol;
  m.min_sampled_radius = r_min;
  return m;
}

RadialTable radial_table_from_sh(const Eigen::VectorXd& coeffs, int degree, int n) {
  require_coeffs(coeffs, degree);
  require_supported(degree);
  if (n < 2) return RadialTable::from_node_radii(n, {});  // throws the table's UsageError
  // The surface as a sum of homogeneous polynomials H_d of degree d = 0..L: at a node direction
  // q / |q| with q = u e_a + v e_b + sign e_k, r = sum_d H_d(q) |q|^-d, and on a face H_d(q) is a
  // polynomial p_d(u, v). So a row of nodes (fixed v) costs one Horner pass in u per degree plus
  // one in 1 / |q|: about a tenth of evaluating the basis at every node.
  const std::shared_ptr<const std::vector<HomPoly>> basis = per_degree(degree, &build_solid_harmonics);
  std::vector<HomPoly> h;
  for (int d = 0; d <= degree; ++d) {
    HomPoly sum(d);
    for (int k = d * d; k < (d + 1) * (d + 1); ++k) {
      for (std::size_t e = 0; e < sum.c.size(); ++e) sum.c[e] += coeffs[k] * (*basis)[static_cast<std::size_t>(k)].c[e];
    }
    h.push_back(std::move(sum));
  }
  const int stride = n + 2;
  const double step = 2.0 / (n - 1);
  const std::size_t poly_size = static_cast<std::size_t>((degree + 1) * (degree + 1));
  std::vector<double> face_poly(static_cast<std::size_t>(degree + 1) * poly_size);  // [d][alpha][beta]
  std::vector<double> row_poly(poly_size * stride);                                 // [d][alpha][row]
  std::vector<double> v_of_row(stride);
  for (int j = 0; j < stride; ++j) v_of_row[j] = -1.0 + (j - 1) * step;
  constexpr int kBlock = 8;
  std::vector<double> acc(stride);
  std::vector<double> radii(static_cast<std::size_t>(6 * stride * stride));
  for (int face = 0; face < 6; ++face) {
    const RadialTable::FaceAxes ax = RadialTable::face_axes(face);
    // p_d(u, v): the coefficient of u^alpha v^beta is that of x_a^alpha x_b^beta x_k^(d-alpha-beta),
    // times sign^(d-alpha-beta).
    for (int d = 0; d <= degree; ++d) {
      for (int alpha = 0; alpha <= d; ++alpha) {
        for (int beta = 0; alpha + beta <= d; ++beta) {
          int e[3];
          e[ax.a] = alpha;
          e[ax.b] = beta;
          e[ax.k] = d - alpha - beta;
          const double sign = ax.sign < 0.0 && e[ax.k] % 2 == 1 ? -1.0 : 1.0;
          face_poly[static_cast<std::size_t>(d) * poly_size + alpha * (degree + 1) + beta] = sign * h[d].at(e[0], e[1]);
        }
      }
    }
    // Each p_d(u, v) as a polynomial in u on every row: coefficients by Horner in v, all rows at
    // once (independent chains, so the loop over rows vectorises).
    for (int d = 0; d <= degree; ++d) {
      for (int alpha = 0; alpha <= d; ++alpha) {
        const double* c = &face_poly[static_cast<std::size_t>(d) * poly_size + alpha * (degree + 1)];
        double* g = &row_poly[static_cast<std::size_t>(d * (degree + 1) + alpha) * stride];
        std::fill(g, g + stride, 0.0);
        for (int beta = d - alpha; beta >= 0; --beta) {
          for (int j = 0; j < stride; ++j) g[j] = g[j] * v_of_row[j] + c[beta];
        }
      }
    }
    for (int j = 0; j < stride; ++j) {
      const double v = v_of_row[j];
      // Horner in 1/|q| over the degrees, each p_d by Horner in u, on blocks of kBlock nodes
      // whose partial sums stay in registers.
      for (int i0 = 0; i0 < stride; i0 += kBlock) {
        double u[kBlock], inv_norm[kBlock], r[kBlock];
        for (int b = 0; b < kBlock; ++b) {
          u[b] = -1.0 + (i0 + b - 1) * step;  // past the row's end: computed, not stored
          inv_norm[b] = 1.0 / std::sqrt(1.0 + u[b] * u[b] + v * v);
          r[b] = 0.0;
        }
        for (int d = degree; d >= 0; --d) {
          // Coefficient alpha of p_d on this row.
          const double* g = &row_poly[static_cast<std::size_t>(d * (degree + 1)) * stride + j];
          double p[kBlock];
#pragma omp simd
          for (int b = 0; b < kBlock; ++b) p[b] = g[d * stride];
          for (int alpha = d - 1; alpha >= 0; --alpha) {
            const double ga = g[alpha * stride];
#pragma omp simd
            for (int b = 0; b < kBlock; ++b) p[b] = p[b] * u[b] + ga;
          }
#pragma omp simd
          for (int b = 0; b < kBlock; ++b) r[b] = r[b] * inv_norm[b] + p[b];
        }
        for (int b = 0; b < kBlock && i0 + b < stride; ++b) acc[i0 + b] = r[b];
      }
      std::copy(acc.begin(), acc.end(), radii.begin() + (static_cast<std::ptrdiff_t>(face) * stride + j) * stride);
    }
  }
  return RadialTable::from_node_radii(n, std::move(radii));
}

}  // namespace graintwin::shape
