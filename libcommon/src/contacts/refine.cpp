#include "graintwin/contacts/refine.hpp"

#include <fmt/format.h>
#include <omp.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <numbers>

#include "graintwin/core/enum_names.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/geometry.hpp"
#include "graintwin/core/parallel.hpp"
#include "graintwin/core/volume_ops.hpp"

namespace graintwin::contacts {

namespace {
constexpr std::array<EnumName<RefineStatus>, 4> kRefineStatusNames{{{RefineStatus::fitted, "fitted"},
                                                                    {RefineStatus::few_voxels, "few_voxels"},
                                                                    {RefineStatus::not_converged, "not_converged"},
                                                                    {RefineStatus::rejected, "rejected"}}};
}  // namespace

const char* status_name(RefineStatus s) { return enum_name(kRefineStatusNames, s); }

void check_grey_for_refinement(const AnyVolume& grey, const std::string& name) {
  const ValueRange r = value_range(grey);
  if (r.non_finite > 0)
    throw DataError(name + " holds " + std::to_string(r.non_finite) +
                    " NaN or infinite voxels; crop them away (volconvert --crop) or run without the volume");
  if (!(r.max > r.min))
    throw DataError(fmt::format("{} holds the grey value {:g} in every voxel, so there is no contrast between grains and "
                                "pores and the contact confidences would be undefined; pass the scan the labels were "
                                "made from, or run without the volume",
                                name, r.min));
}

ConfidenceCount count_confidences(const std::vector<Refinement>& fits, double min_confidence) {
  ConfidenceCount c;
  for (const Refinement& f : fits) {
    if (std::isnan(f.confidence))
      ++c.unknown;
    else if (f.confidence >= min_confidence)
      ++c.at_least;
    else
      ++c.below;
  }
  return c;
}

namespace {

using Vec = Eigen::Vector3d;
constexpr int kParams = 11;  // p (3), two tangent rotations of n, curvature low, high, half gap, blur, g0, g1
using ParamVec = Eigen::Matrix<double, kParams, 1>;
using ParamMat = Eigen::Matrix<double, kParams, kParams>;

/// A voxel of the window: position relative to the window centre (fit units, x y z) and grey value.
struct Sample {
  Vec x;
  double g;
};

/// The two-sphere model in fit units (lengths / h0). Grain low (A) lies on the -n side of the
/// contact point p, grain high (B) on the +n side; the surfaces are 2 * half_gap apart along n.
struct Model {
  Vec p = Vec::Zero(), n = Vec::UnitZ(), t1 = Vec::UnitX(), t2 = Vec::UnitY();
  double k_low = 0.1, k_high = 0.1;  // curvatures 1 / radius: a flat surface stays representable
  double half_gap = 0.0, blur = 1.0, g0 = 0.0, g1 = 1.0;
  void set_normal(const Vec& v) {
    n = v.normalized();
    const Vec a = std::abs(n.x()) < 0.9 ? Vec::UnitX() : Vec::UnitY();
    t1 = (a - n * n.dot(a)).normalized();
    t2 = n.cross(t1);
  }
};

constexpr double kMinCurvature = 1e-3, kMaxCurvature = 2.0, kMinBlur = 0.2;

inline double normal_cdf(double z) { return 0.5 * std::erfc(-z * std::numbers::sqrt2 / 2.0); }
inline double normal_pdf(double z) { return std::exp(-0.5 * z * z) / std::sqrt(2.0 * std::numbers::pi); }

/// Image of a ball of radius R blurred by a Gaussian of sigma s, at distance D from its centre:
/// f = Phi(z) - (s / D) phi(z), z = (R - D) / s (exact up to terms in exp(-(R + D)^2 / 2 s^2)),
/// and its partial derivatives in D, R and s.
struct BallImage {
  double f, dD, dR, ds, pdf;
};
inline BallImage blurred_ball(double D, double R, double s) {
  D = std::max(D, 1e-9);
  const double z = (R - D) / s;
  const double pdf = normal_pdf(z);
  const double q = pdf * (1.0 + s * z / D);  // df/dz
  return {normal_cdf(z) - s / D * pdf, -q / s + s * pdf / (D * D), q / s, -q * z / s - pdf / D, pdf};
}

/// Sum of squared residuals of the model; with `jtj` and `jtr`, also J^T J (lower triangle) and J^T r.
double evaluate(const std::vector<Sample>& samples, const Model& m, ParamMat* jtj, ParamVec* jtr) {
  const double ra = 1.0 / m.k_low, rb = 1.0 / m.k_high;
  const double ea = m.half_gap + ra, eb = m.half_gap + rb;  // contact point to each centre
  const double s = m.blur;
  double cost = 0.0;
  if (jtj) jtj->setZero(), jtr->setZero();
  ParamVec J;
  for (const Sample& smp : samples) {
    const Vec u = smp.x - m.p;
    const Vec da = u + m.n * ea, db = u - m.n * eb;  // from each centre to the voxel
    const double la = da.norm(), lb = db.norm();
    const BallImage a = blurred_ball(la, ra, s), b = blurred_ball(lb, rb, s);
    const double r = m.g0 + m.g1 * (a.f + b.f) - smp.g;
    cost += r * r;
    if (!jtj) continue;
    const Vec va = da / std::max(la, 1e-9), vb = db / std::max(lb, 1e-9);
    const double van = va.dot(m.n), vbn = vb.dot(m.n);
    J.segment<3>(0) = -m.g1 * (a.dD * va + b.dD * vb);
    J[3] = m.g1 * (a.dD * ea * va.dot(m.t1) - b.dD * eb * vb.dot(m.t1));
    J[4] = m.g1 * (a.dD * ea * va.dot(m.t2) - b.dD * eb * vb.dot(m.t2));
    // d f / d R through the explicit R and through the centre moving along n, written so that the
    // near-cancellation of the two at the contact (v ~ +-n) is exact: 1 - v.n = |v - n|^2 / 2.
    const double dra = a.dR * 0.5 * (va - m.n).squaredNorm() + s * a.pdf / (la * la) * van;
    const double drb = b.dR * 0.5 * (vb + m.n).squaredNorm() - s * b.pdf / (lb * lb) * vbn;
    J[5] = -m.g1 * dra * ra * ra;  // d/d curvature = -R^2 d/dR
    J[6] = -m.g1 * drb * rb * rb;
    J[7] = m.g1 * (a.dD * van - b.dD * vbn);
    J[8] = m.g1 * (a.ds + b.ds);
    J[9] = 1.0;
    J[10] = a.f + b.f;
    jtj->selfadjointView<Eigen::Lower>().rankUpdate(J);
    *jtr += r * J;
  }
  return cost;
}

/// One Levenberg-Marquardt step applied to a copy of m.
Model stepped(const Model& m, const ParamVec& d) {
  Model t = m;
  t.p += d.segment<3>(0);
  t.set_normal(m.n + d[3] * m.t1 + d[4] * m.t2);
  t.k_low = std::clamp(m.k_low + d[5], kMinCurvature, kMaxCurvature);
  t.k_high = std::clamp(m.k_high + d[6], kMinCurvature, kMaxCurvature);
  t.half_gap = m.half_gap + d[7];
  t.blur = std::max(m.blur + d[8], kMinBlur);
  t.g0 = m.g0 + d[9];
  t.g1 = m.g1 + d[10];
  return t;
}

/// Grey levels g0, g1 by linear least squares for the current geometry.
void fit_levels(const std::vector<Sample>& samples, Model& m) {
  const double ra = 1.0 / m.k_low, rb = 1.0 / m.k_high;
  double s1 = 0, sf = 0, sff = 0, sg = 0, sfg = 0;
  for (const Sample& smp : samples) {
    const Vec u = smp.x - m.p;
    const double f = blurred_ball((u + m.n * (m.half_gap + ra)).norm(), ra, m.blur).f +
                     blurred_ball((u - m.n * (m.half_gap + rb)).norm(), rb, m.blur).f;
    s1 += 1, sf += f, sff += f * f, sg += smp.g, sfg += f * smp.g;
  }
  const double det = s1 * sff - sf * sf;
  if (std::abs(det) < 1e-12 * s1 * s1) return;
  m.g1 = (s1 * sfg - sf * sg) / det;
  m.g0 = (sg - m.g1 * sf) / s1;
}

/// Result of one Levenberg-Marquardt fit.
struct Fit {
  RefineStatus status = RefineStatus::not_converged;
  Model model;
  double cost = 0.0;          ///< sum of squared residuals
  double var_half_gap = 0.0;  ///< variance of the half gap (fit units squared)
  int iterations = 0;
};

/// Fits the model from the start `m` (geometry set; grey levels are fitted first). `contrast` is
/// the measured grain - pore grey difference: a step that would flip the sign of g1 is refused, so
/// the fit cannot turn into "dark spheres in a bright background".
Fit fit_model(const std::vector<Sample>& samples, Model m, double contrast, double window, int max_iterations) {
  Fit out;
  fit_levels(samples, m);
  if (!(m.g1 * contrast > 0.0)) m.g1 = contrast, m.g0 = 0.0;
  ParamMat jtj, trial_jtj;
  ParamVec jtr, trial_jtr;
  double cost = evaluate(samples, m, &jtj, &jtr);
  double lambda = 1e-3;
  bool converged = false;
  for (int it = 0; it < max_iterations && !converged; ++it) {
    out.iterations = it + 1;
    bool accepted = false;
    while (!accepted && lambda < 1e10) {
      ParamMat a = jtj.selfadjointView<Eigen::Lower>();
      a.diagonal() += lambda * (jtj.diagonal().array() + 1e-12).matrix();
      const ParamVec d = a.ldlt().solve(-jtr);
      const Model trial = stepped(m, d);
      // The trial's derivatives come with its cost: an accepted step needs no second pass.
      const double c = trial.g1 * contrast > 0.0 ? evaluate(samples, trial, &trial_jtj, &trial_jtr) : cost;
      if (c < cost) {
        // Converged once the geometry moves by less than 1e-3 voxel and 1e-4 rad (far below the
        // accuracy the noise allows), or the cost stops falling.
        converged = (d.segment<3>(0).norm() < 1e-3 && d.segment<2>(3).norm() < 1e-4 && std::abs(d[7]) < 1e-3) ||
                    cost - c < 1e-10 * cost;
        m = trial;
        cost = c;
        jtj = trial_jtj, jtr = trial_jtr;
        lambda = std::max(lambda / 4.0, 1e-9);
        accepted = true;
      } else {
        lambda *= 4.0;
      }
    }
    if (!accepted) converged = true;  // no step lowers the cost: at a minimum to rounding
  }
  out.model = m;
  out.cost = cost;
  if (!converged) return out;
  const double dof = static_cast<double>(samples.size()) - kParams;
  const ParamMat full = jtj.selfadjointView<Eigen::Lower>();
  out.var_half_gap = (cost / dof) * full.ldlt().solve(ParamVec::Unit(7))[7];
  const bool sane = m.p.norm() <= 0.5 * window && m.blur < 3.0 && std::abs(m.g1) > 0.3 * std::abs(contrast) &&
                    std::abs(m.half_gap) < 0.5 * window && m.k_low > kMinCurvature && m.k_high > kMinCurvature &&
                    m.k_low < kMaxCurvature && m.k_high < kMaxCurvature && std::isfinite(out.var_half_gap) &&
                    out.var_half_gap >= 0.0;
  out.status = sane ? RefineStatus::fitted : RefineStatus::rejected;
  return out;
}

}  // namespace

template <class T>
Refinement refine_contact(const Volume<T>& grey, const Volume<std::uint32_t>& labels, const Contact& contact,
                          double radius_low, double radius_high, const RefineParams& params) {
  Refinement out;
  const Shape3& shape = labels.shape();
  const Vec3& vs = labels.voxel_size();
  const Vec3& origin = labels.origin();
  const double h0 = std::cbrt(vs[0] * vs[1] * vs[2]);  // fit length unit
  const double r_low = radius_low / h0, r_high = radius_high / h0;
  const double window = params.window_vox > 0.0 ? params.window_vox
                                                : std::clamp(0.6 * std::min(r_low, r_high), 3.0, 7.0);

  // The window: voxels within `window` of the contact centroid whose label is low, high or pore
  // and that lie farther than exclusion_vox from any third grain.
  const double centre_idx[3] = {(contact.centroid[2] - origin[0]) / vs[0], (contact.centroid[1] - origin[1]) / vs[1],
                                (contact.centroid[0] - origin[2]) / vs[2]};  // (z, y, x)
  const int ex = std::max(params.exclusion_vox, 0);
  long lo[3], hi[3], n[3];
  for (int a = 0; a < 3; ++a) {
    const long half = static_cast<long>(std::ceil(window * h0 / vs[a])) + ex;
    const long c = std::lround(centre_idx[a]);
    lo[a] = std::max(0L, c - half);
    hi[a] = std::min(static_cast<long>(shape[a]) - 1, c + half);
    if (lo[a] > hi[a]) return out;
    n[a] = hi[a] - lo[a] + 1;
  }
  const auto box = [&](long z, long y, long x) { return static_cast<std::size_t>(((z - lo[0]) * n[1] + (y - lo[1])) * n[2] + (x - lo[2])); };
  std::vector<std::uint8_t> foreign(static_cast<std::size_t>(n[0] * n[1] * n[2]), 0);
  for (long z = lo[0]; z <= hi[0]; ++z)
    for (long y = lo[1]; y <= hi[1]; ++y)
      for (long x = lo[2]; x <= hi[2]; ++x) {
        const std::uint32_t l = labels(z, y, x);
        foreign[box(z, y, x)] = l != 0 && l != contact.low && l != contact.high;
      }
  // Chessboard dilation by ex: a running maximum along each axis in turn.
  for (int a = 0; a < 3 && ex > 0; ++a) {
    const std::vector<std::uint8_t> src = foreign;
    const long stride = a == 0 ? n[1] * n[2] : a == 1 ? n[2] : 1;
    for (std::size_t i = 0; i < foreign.size(); ++i) {
      const long pos = (static_cast<long>(i) / stride) % n[a];
      for (long d = -ex; d <= ex && !foreign[i]; ++d)
        if (pos + d >= 0 && pos + d < n[a] && src[static_cast<std::size_t>(static_cast<long>(i) + d * stride)]) foreign[i] = 1;
    }
  }
  std::vector<Sample> samples;
  std::size_t count[3] = {0, 0, 0};  // pore, low, high
  double grey_sum[3] = {0, 0, 0};
  const double w2 = window * window;
  for (long z = lo[0]; z <= hi[0]; ++z)
    for (long y = lo[1]; y <= hi[1]; ++y)
      for (long x = lo[2]; x <= hi[2]; ++x) {
        if (foreign[box(z, y, x)]) continue;
        const Vec pos{(x - centre_idx[2]) * vs[2] / h0, (y - centre_idx[1]) * vs[1] / h0, (z - centre_idx[0]) * vs[0] / h0};
        if (pos.squaredNorm() > w2) continue;
        const double g = static_cast<double>(grey(z, y, x));
        if (!std::isfinite(g)) continue;
        samples.push_back({pos, g});
        const std::uint32_t l = labels(z, y, x);
        const int k = l == 0 ? 0 : l == contact.low ? 1 : 2;
        ++count[k];
        grey_sum[k] += g;
      }
  out.voxels = samples.size();
  if (count[0] < 8 || count[1] < 8 || count[2] < 8) return out;
  const double contrast = 0.5 * (grey_sum[1] / count[1] + grey_sum[2] / count[2]) - grey_sum[0] / count[0];

  // Starts, in order of how close they usually are: the vector-area normal, the PCA normal, the
  // branch direction; the first start whose fit converges to a sane solution wins.
  const Vec starts[3] = {Vec(contact.vector_area[0], contact.vector_area[1], contact.vector_area[2]),
                         Vec(contact.normal[0], contact.normal[1], contact.normal[2]),
                         Vec(contact.branch[0], contact.branch[1], contact.branch[2])};
  Fit fit;
  for (const Vec& start : starts) {
    if (!(start.norm() > 0.0)) continue;
    Model m;
    m.set_normal(start);
    m.k_low = std::clamp(1.0 / r_low, kMinCurvature, kMaxCurvature);
    m.k_high = std::clamp(1.0 / r_high, kMinCurvature, kMaxCurvature);
    fit = fit_model(samples, m, contrast, window, params.max_iterations);
    out.iterations += fit.iterations;
    if (fit.status == RefineStatus::fitted) break;
  }
  out.status = fit.status;
  if (!out.ok()) return out;
  const Model& m = fit.model;
  out.normal = {m.n.x(), m.n.y(), m.n.z()};
  for (int i = 0; i < 3; ++i) out.point[i] = contact.centroid[i] + m.p[i] * h0;
  out.gap = 2.0 * m.half_gap * h0;
  out.gap_sd = 2.0 * std::sqrt(fit.var_half_gap) * h0;
  out.confidence = normal_cdf((params.gap_tolerance_vox * h0 - out.gap) / std::max(out.gap_sd, 1e-6 * h0));
  out.radius = {h0 / m.k_low, h0 / m.k_high};
  out.blur = m.blur * h0;
  out.rms = std::sqrt(fit.cost / static_cast<double>(samples.size())) / std::abs(m.g1);
  return out;
}

template <class T>
std::vector<Refinement> refine_contacts(const Volume<T>& grey, const Volume<std::uint32_t>& labels,
                                        const std::vector<Contact>& contacts,
                                        const std::vector<segment::GrainRecord>& grains, const RefineParams& params,
                                        const std::function<void(double)>& progress) {
  if (grey.shape() != labels.shape())
    throw UsageError("the grey volume and the labels differ in shape; pass the scan the labels were made from");
  const auto radius_of = [&](std::uint32_t label) {
    const auto it = std::lower_bound(grains.begin(), grains.end(), label,
                                     [](const segment::GrainRecord& g, std::uint32_t l) { return g.label < l; });
    if (it == grains.end() || it->label != label)
      throw DataError("label " + std::to_string(label) + " has a contact but no row in the grain table");
    return equivalent_radius(it->volume_m3);
  };
  std::vector<std::array<double, 2>> radii(contacts.size());
  for (std::size_t k = 0; k < contacts.size(); ++k) radii[k] = {radius_of(contacts[k].low), radius_of(contacts[k].high)};
  std::vector<Refinement> out(contacts.size());
  std::atomic<std::size_t> done{0};
#pragma omp parallel for schedule(dynamic, 4) num_threads(useful_threads(contacts.size()))
  for (std::size_t k = 0; k < contacts.size(); ++k) {
    out[k] = refine_contact(grey, labels, contacts[k], radii[k][0], radii[k][1], params);
    const std::size_t d = ++done;
    if (progress && omp_get_thread_num() == 0 && d % 64 == 0)
      progress(static_cast<double>(d) / static_cast<double>(contacts.size()));
  }
  if (progress) progress(1.0);
  return out;
}

#define GRAINTWIN_REFINE(T)                                                                                        \
  template Refinement refine_contact<T>(const Volume<T>&, const Volume<std::uint32_t>&, const Contact&, double,  \
                                        double, const RefineParams&);                                            \
  template std::vector<Refinement> refine_contacts<T>(const Volume<T>&, const Volume<std::uint32_t>&,            \
                                                      const std::vector<Contact>&,                               \
                                                      const std::vector<segment::GrainRecord>&,                  \
                                                      const RefineParams&, const std::function<void(double)>&);
GRAINTWIN_REFINE(std::uint8_t)
GRAINTWIN_REFINE(std::uint16_t)
GRAINTWIN_REFINE(std::uint32_t)
GRAINTWIN_REFINE(float)
#undef GRAINTWIN_REFINE

}  // namespace graintwin::contacts
