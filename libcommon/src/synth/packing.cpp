// Dense packing of star-shaped grains by growth with overlap relaxation: the driver. Its parts
// live beside it: the random start (packing_start.cpp), the candidate pairs (packing_pairs.cpp),
// the contact kernels (packing_geometry.cpp); the contacts of grains at given poses are in
// packing_contacts.cpp, the measures of a finished packing in packing_measures.cpp, and the
// packing in stages of smoother shapes first in packing_stages.cpp.
//
// 1. Start: all grains at a common scale s0 (0.55, or less when the bounding spheres would fill
//    more than 25 % of the container), random orientation, random position by random sequential
//    addition of the bounding spheres, largest grains first.
// 2. Sweeps. Each sweep grows s by a factor 1 + g (unless held), evaluates every candidate pair
//    (a Verlet list, rebuilt when grains have moved by half the skin) and every grain near a
//    wall, then moves the grains by one FIRE step (Bitzek et al., PRL 97, 170201, 2006) on the
//    overlap energy E = sum w e(depth + eps) (rotations in arc-length units so that an off-centre
//    contact turns the grain). The sum runs over the contact regions of every pair (a rough grain
//    can touch another at several bumps; each region seen from either grain, w = 1/2, so a convex
//    contact seen from both counts once) and over the wall contacts (w = 1). The growth rate g
//    adapts so that the mean depth of the overlapping pairs stays near 1 % of the mean grain
//    radius: the packing is compressed quasi-statically, which is what lets it become dense (a
//    fast compression jams early, loose).
// 3. At full size the FIRE steps go on until every pair and wall depth is within the tolerance;
//    the state is then checked once more with every candidate pair evaluated afresh, as precisely
//    as pair_contact() does.
// What makes the full-size relaxation end sooner (measured in docs/ctsynth.md, Limits): its
// overlaps are held by the packing's residual pressure, which falls only as the grains rearrange,
// and the test is on the deepest few of thousands. So
// - at full size the contact law e'(x) = x up to half the tolerance, slope Tune::deep_stiffness
//   beyond: the deepest contacts carry their force with less depth, and the packing ends at a
//   higher residual pressure (while growing the law stays linear: the growth control's target
//   depth was set with it);
// - each grain's inertia is its contact stiffness over Tune::unit_contacts (at least 1): a grain
//   held by stiff contacts moves at the pace of one held by a few unit ones (a Jacobi
//   preconditioner);
// - FIRE's restart is per grain: a grain whose power F.v turns negative stops, the others keep
//   their momentum. The global restart stopped every grain about every 12th sweep, so the slow
//   collective motion that lowers the pressure never gathered speed; now a negative total power
//   only halves the step;
// - a confirmation that finds the exact depths deeper than the sweep's estimate waits until the
//   estimate is below the tolerance by that difference, rather than paying for an exact
//   evaluation every sweep while the estimate hovers at the tolerance.
// A packing that stops growing (2000 sweeps without 0.1 % growth) or, at full size, stops
// relaxing (3000 sweeps without a 1 % smaller worst overlap) is jammed: DataError.
//
// Cost: a pair in contact is re-sampled every 8th sweep (or once its grains have moved 5 % of a
// radius) and otherwise warm-started from its last contact points; a pair known to be apart is
// skipped until the grains have travelled the gap.
//
// Determinism: the random start comes from a seeded mt19937_64 with our own conversion to doubles;
// parallel loops write per-pair or per-grain slots and every sum runs in a fixed order, so the
// result does not depend on the thread count.
#include "graintwin/synth/packing.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <string>

#include "graintwin/core/enum_names.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/geometry.hpp"
#include "graintwin/core/interval.hpp"
#include "graintwin/core/statistics.hpp"
#include "packing_geometry.hpp"
#include "packing_pairs.hpp"
#include "packing_start.hpp"

namespace graintwin::synth {

double Container::volume() const {
  if (kind == Kind::cylinder) return M_PI * radius * radius * height;
  return box_size.x() * box_size.y() * box_size.z();
}

namespace {
constexpr std::array<EnumName<Container::Kind>, 2> kContainerKindNames{
    {{Container::Kind::cylinder, "cylinder"}, {Container::Kind::box, "box"}}};
}  // namespace

const char* container_kind_name(Container::Kind kind) { return enum_name(kContainerKindNames, kind); }

Container::Kind parse_container_kind(const std::string& name) { return parse_enum(kContainerKindNames, name, "--container"); }

namespace {

using detail::Frame;
using detail::PairSlot;
using detail::ShapeData;
using detail::SurfaceView;
using detail::WallHit;
using detail::kParallelGrains;
using detail::kParallelPairs;

// Constants of the method (dimensionless), chosen on packings of spheres and of 1.3:1 ellipsoids
// with an Ottawa-sand size spread (tests/libcommon/packing_test.cpp).
struct Tune {
  double max_fill = kDensestPacking;  // refuse anything denser
  double rotation_gain = 0.5;       // weight of torques against forces (0: grains never turn)
  double max_rotation = 0.05;       // rad per sweep
  double max_step = 0.2;            // of the grain's equivalent radius per sweep
  double fire_dt_start = 0.1;       // FIRE time step (unit stiffness and masses) ...
  double fire_dt_max = 0.5;         // ... its cap (stable for ~12 contacts per grain) ...
  double fire_dt_min = 0.01;        // ... and floor
  double fire_alpha_start = 0.1;    // FIRE's velocity mixing at the start
  double deep_knee = 0.5;           // contact law: slope 1 up to this depth (in tolerances) ...
  double deep_stiffness = 4.0;      // ... and this slope beyond
  double unit_contacts = 12.0;      // a grain's inertia: its contact stiffness over this, >= 1
  double target_gap = 0.2;          // contacts push until this gap, in tolerances
  double growth_overlap = 0.01;     // mean overlap while growing, of the mean equivalent radius
  double growth_first = 0.02;       // first relative growth per sweep
  double growth_max = 0.05;
  double growth_min = 1e-6;
  double skin = 0.3;                // Verlet skin, of the mean bounding radius
  double refine_step = 0.008;       // final angular step of the deepest-point search (rad):
                                    // depth error ~ r h^2 / 100, far below the tolerance
                                    // (detail::kExactRefineStep in the final check)
  int full_every = 8;               // pairs in contact are sampled afresh every so many sweeps ...
  double warm_motion = 0.05;        // ... or once both grains moved this much (of the smaller
                                    // bounding radius); in between the last contact seeds them
  int stall_sweeps = 2000;          // sweeps without 0.1 % growth: jammed before full size
  int settle_sweeps = 3000;         // sweeps at full size without 1 % less overlap: jammed
};
constexpr Tune kTune{};

std::string fmt_num(double v, int digits = 2) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

std::string fmt_um(double metres) { return fmt_num(metres * 1e6, 2) + " um"; }

class Packer {
 public:
  Packer(const std::vector<const shape::RadialTable*>& shapes, const Container& c,
         const PackingParams& p)
      : c_(c), p_(p), n_(shapes.size()), shapes_(shapes) {
    validate(shapes);
    detail::index_shapes(shapes, shape_data_, grain_shape_);
    rmax_.resize(n_);
    vol_.resize(n_);
    req_.resize(n_);
    double vsum = 0.0, rmin_eq = HUGE_VAL, req_sum = 0.0, rmax_sum = 0.0;
    for (std::size_t i = 0; i < n_; ++i) {
      const ShapeData& d = shape_data_[grain_shape_[i]];
      rmax_[i] = d.max_radius;
      vol_[i] = d.volume;
      req_[i] = equivalent_radius(d.volume);
      vsum += d.volume;
      rmin_eq = std::min(rmin_eq, req_[i]);
      req_sum += req_[i];
      rmax_sum += rmax_[i];
    }
    rmax_max_ = *std::max_element(rmax_.begin(), rmax_.end());
    req_mean_ = req_sum / n_;
    rmax_mean_ = rmax_sum / n_;
    tol_ = p.contact_tolerance * rmin_eq;
    fill_ = vsum / c.volume();
    check_fit();
  }

  // pack_grains(): random start at a reduced scale, growth, relaxation.
  std::vector<PackedGrain> pack(PackingReport* report, const PackingObserver& observe) {
    const auto t0 = std::chrono::steady_clock::now();
    place_initial();
    relax(observe);
    return finish_run(report, t0);
  }

  // relax_grains(): the given poses at full size, relaxation only.
  std::vector<PackedGrain> relax_from(const std::vector<PackedGrain>& poses, PackingReport* report,
                                      const PackingObserver& observe) {
    const auto t0 = std::chrono::steady_clock::now();
    x_.resize(n_);
    q_.resize(n_);
    R_.resize(n_);
    for (std::size_t i = 0; i < n_; ++i) {
      if (!poses[i].position.allFinite() || !poses[i].orientation.coeffs().allFinite() ||
          poses[i].orientation.norm() == 0.0) {
        throw UsageError("relax_grains: pose " + std::to_string(i) +
                         " is not finite or has a zero quaternion");
      }
      x_[i] = poses[i].position;
      q_[i] = poses[i].orientation.normalized();
      R_[i] = q_[i].toRotationMatrix();
    }
    // Grains shrunk about their centres first (initial_scale > 0) regrow quasi-statically.
    s_ = s0_ = p_.initial_scale > 0.0 ? p_.initial_scale : 1.0;
    relax(observe);
    return finish_run(report, t0);
  }

 private:
  std::vector<PackedGrain> finish_run(PackingReport* report, std::chrono::steady_clock::time_point t0) {
    std::vector<PackedGrain> out(n_);
    for (std::size_t i = 0; i < n_; ++i) {
      out[i].position = x_[i];
      out[i].orientation = q_[i];
    }
    if (report) {
      *report = final_report_;
      report->core_margin = d50_of_volumes(vol_);
      report->core_solid_fraction = core_solid_fraction(shapes_, out, c_, report->core_margin);
      report->seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    return out;
  }

  void validate(const std::vector<const shape::RadialTable*>& shapes) const {
    for (std::size_t i = 0; i < shapes.size(); ++i) {
      if (shapes[i] == nullptr || shapes[i]->empty()) {
        throw UsageError("pack_grains: shape " + std::to_string(i) +
                         " is null or empty; pass one tabulated shape per grain");
      }
    }
    const bool cyl = c_.kind == Container::Kind::cylinder;
    const bool ok = cyl ? (std::isfinite(c_.radius) && std::isfinite(c_.height) &&
                           c_.radius > 0.0 && c_.height > 0.0)
                        : (c_.box_size.allFinite() && c_.box_size.minCoeff() > 0.0);
    if (!ok) {
      throw UsageError(std::string("pack_grains: the ") + container_kind_name(c_.kind) +
                       " needs finite, positive dimensions (metres)");
    }
    if (!std::isfinite(p_.contact_tolerance) || p_.contact_tolerance <= 0.0 ||
        p_.contact_tolerance >= 0.5) {
      throw UsageError("pack_grains: contact_tolerance must be in (0, 0.5) (a fraction of the "
                       "smallest grain radius), got " + std::to_string(p_.contact_tolerance));
    }
    if (p_.max_sweeps < 1) throw UsageError("pack_grains: max_sweeps must be at least 1");
    if (!(p_.initial_scale >= 0.0 && p_.initial_scale < 1.0)) {
      throw UsageError("pack_grains: initial_scale must be in [0, 1) (0 = automatic)");
    }
  }

  void check_fit() const {
    if (fill_ > kTune.max_fill) {
      throw DataError("scene: grains fill " + fmt_num(fill_) + " of the " + container_kind_name(c_.kind) +
                      ", above the " + fmt_num(kDensestPacking) + " that any packing allows; enlarge the container or lower "
                      "the grain count");
    }
    const double room = c_.kind == Container::Kind::cylinder
                            ? std::min(2.0 * c_.radius, c_.height)
                            : c_.box_size.minCoeff();
    for (std::size_t i = 0; i < n_; ++i) {
      const double rmin = shape_data_[grain_shape_[i]].table->min_radius();
      if (2.0 * rmin >= room) {
        throw DataError("scene: grain " + std::to_string(i) + " is at least " +
                        fmt_num(2e3 * rmin, 3) + " mm wide but the " + container_kind_name(c_.kind) +
                        " is only " + fmt_num(1e3 * room, 3) +
                        " mm across; enlarge the container or use smaller grains");
      }
    }
  }

  Frame frame(std::size_t i) const {
    Frame f;
    f.x = x_[i];
    f.R = R_[i];
    f.s = s_;
    return f;
  }
  SurfaceView view(std::size_t i) const { return shape_data_[grain_shape_[i]].view(); }

  void place_initial() {
    const detail::RandomStart start = detail::random_start(c_, rmax_, p_.initial_scale, p_.seed, x_, q_);
    if (!start.placed) {
      throw DataError("scene: could not place the grains even at " + fmt_num(start.scale) +
                      " of their size in the " + container_kind_name(c_.kind) +
                      "; enlarge the container or lower the grain count");
    }
    s_ = s0_ = start.scale;
    R_.resize(n_);
    for (std::size_t i = 0; i < n_; ++i) R_[i] = q_[i].toRotationMatrix();
  }

  void build_pairs() { pairs_.build(x_, rmax_, s_, kTune.skin * s_ * rmax_mean_); }

  // Evaluates every candidate pair (skipping, unless `all`, those whose last gap bound still
  // exceeds `gap` after the distance both grains have travelled since) and every grain's walls;
  // h_min: final angular step of the deepest-point search.
  void evaluate(double gap, bool all, double h_min) {
    std::vector<PairSlot>& pairs = pairs_.slots();
#pragma omp parallel for schedule(dynamic, 32) if (pairs.size() > kParallelPairs)
    for (std::size_t k = 0; k < pairs.size(); ++k) {
      PairSlot& pr = pairs[k];
      if (!all && pr.bound - (travel_[pr.a] - pr.travel_a) - (travel_[pr.b] - pr.travel_b) > gap) {
        pr.eval.found = false;
        continue;
      }
      // Warm start from the last result while both grains have moved little since, except on
      // every full_every-th sweep (staggered over the pairs) and in the final check.
      const double moved = (travel_[pr.a] - pr.travel_a) + (travel_[pr.b] - pr.travel_b);
      const bool warm = !all && (pr.eval.ab.peaks > 0 || pr.eval.ba.peaks > 0) &&
                        (k + sweep_) % kTune.full_every != 0 &&
                        moved < kTune.warm_motion * s_ * std::min(rmax_[pr.a], rmax_[pr.b]);
      const detail::PairEval last = pr.eval;
      pr.eval = detail::evaluate_pair(view(pr.a), frame(pr.a), view(pr.b), frame(pr.b), gap, h_min,
                                      warm ? &last : nullptr);
      pr.bound = pr.eval.found ? -HUGE_VAL : pr.eval.gap_bound;  // -inf after a warm start
      pr.travel_a = travel_[pr.a];
      pr.travel_b = travel_[pr.b];
    }
#pragma omp parallel for schedule(dynamic, 64) if (n_ > kParallelGrains)
    for (std::size_t i = 0; i < n_; ++i) {
      wall_count_[i] =
          detail::evaluate_walls(view(i), frame(i), c_, gap, h_min, &walls_[detail::kMaxWallHits * i]);
    }
  }

  struct Stats {
    double max_pair = 0.0, max_wall = 0.0, sum_pair = 0.0;
    std::size_t overlapping = 0, touching = 0, wall_touching = 0;
    double worst() const { return std::max(max_pair, max_wall); }
    double mean() const { return overlapping ? sum_pair / overlapping : 0.0; }
  };
  Stats stats() const {
    Stats st;
    for (const PairSlot& pr : pairs_.slots()) {
      if (!pr.eval.found) continue;
      const double d = pr.eval.side.depth;
      if (d > 0.0) {
        st.max_pair = std::max(st.max_pair, d);
        st.sum_pair += d;
        ++st.overlapping;
      }
      if (std::abs(d) <= tol_) ++st.touching;
    }
    for (std::size_t i = 0; i < n_; ++i) {
      for (int w = 0; w < wall_count_[i]; ++w) {
        const double d = walls_[detail::kMaxWallHits * i + w].depth;
        st.max_wall = std::max(st.max_wall, d);
        if (std::abs(d) <= tol_) ++st.wall_touching;
      }
    }
    return st;
  }

  // Force of one contact of the overlap energy at x = depth + eps (metres): slope 1, then
  // kTune.deep_stiffness beyond the knee; contact_stiffness is its slope.
  double contact_force(double x) const {
    return x + (deep_stiffness() - 1.0) * std::max(0.0, x - kTune.deep_knee * tol_);
  }
  double contact_stiffness(double x) const { return x > kTune.deep_knee * tol_ ? deep_stiffness() : 1.0; }
  double deep_stiffness() const { return s_ >= 1.0 ? kTune.deep_stiffness : 1.0; }

  // Contact forces of the overlap energy (metres): F_i sums w f(depth + eps) n over the grain's
  // contacts, G_i sums arm x F / L_i, the generalised force of the arc-length rotation coordinate
  // phi = theta L_i (L_i = s r_eq,i); pairs in the grain's list order, then walls. The grain's
  // inverse inertia follows from the sum of w f' (see the head of this file).
  void compute_forces() {
    const double eps = kTune.target_gap * tol_;
#pragma omp parallel for schedule(static) if (n_ > 4 * kParallelGrains)
    for (std::size_t i = 0; i < n_; ++i) {
      Eigen::Vector3d f = Eigen::Vector3d::Zero(), tq = Eigen::Vector3d::Zero();
      double stiffness = 0.0;
      auto add = [&](double weight, double x, const Eigen::Vector3d& normal, const Eigen::Vector3d& at) {
        const Eigen::Vector3d force = (weight * contact_force(x)) * normal;
        stiffness += std::abs(weight) * contact_stiffness(x);
        f += force;
        tq += (at - x_[i]).cross(force);
      };
      for (int k : pairs_.of(i)) {
        const PairSlot& pr = pairs_.slots()[k];
        if (!pr.eval.found) continue;
        // Every contact region, seen from either grain, with half weight: a convex pair's single
        // contact (seen from both sides) gets full weight, and rough grains touching at several
        // bumps feel all of them, so the force does not jump when the deepest bump changes.
        const double sign = pr.a == static_cast<int>(i) ? -0.5 : 0.5;
        for (const detail::SideSet* set : {&pr.eval.ab, &pr.eval.ba}) {
          for (int r = 0; r < set->n; ++r) {
            const detail::Side& sd = set->side[r];
            if (sd.depth <= -eps) continue;
            add(sign, sd.depth + eps, sd.normal, sd.point);
          }
        }
      }
      for (int k = 0; k < wall_count_[i]; ++k) {
        const WallHit& h = walls_[detail::kMaxWallHits * i + k];
        if (h.depth <= -eps) continue;
        add(1.0, h.depth + eps, h.normal, h.point);
      }
      force_[i] = f;
      torque_[i] = kTune.rotation_gain * tq / (s_ * req_[i]);
      inverse_inertia_[i] = 1.0 / std::max(1.0, stiffness / kTune.unit_contacts);
    }
  }

  // One FIRE step with per-grain restarts: a grain whose power F.v is negative stops, the others
  // mix their velocity toward their force; the time step grows while the total power stays
  // non-negative and halves when it turns negative; semi-implicit Euler update.
  void fire_step() {
    compute_forces();
    double power = 0.0, fnorm2 = 0.0;
    for (std::size_t i = 0; i < n_; ++i) {
      power += force_[i].dot(vel_[i]) + torque_[i].dot(spin_[i]);
      fnorm2 += force_[i].squaredNorm() + torque_[i].squaredNorm();
    }
    if (fnorm2 == 0.0) {  // nothing touches: nothing moves, and the step keeps its size
      std::fill(vel_.begin(), vel_.end(), Eigen::Vector3d::Zero());
      std::fill(spin_.begin(), spin_.end(), Eigen::Vector3d::Zero());
      return;
    }
    for (std::size_t i = 0; i < n_; ++i) {
      const double f2 = force_[i].squaredNorm() + torque_[i].squaredNorm();
      if (force_[i].dot(vel_[i]) + torque_[i].dot(spin_[i]) < 0.0 || f2 == 0.0) {
        vel_[i].setZero();
        spin_[i].setZero();
        continue;
      }
      const double mix = fire_alpha_ * std::sqrt((vel_[i].squaredNorm() + spin_[i].squaredNorm()) / f2);
      vel_[i] = (1.0 - fire_alpha_) * vel_[i] + mix * force_[i];
      spin_[i] = (1.0 - fire_alpha_) * spin_[i] + mix * torque_[i];
    }
    if (power < 0.0) {
      fire_dt_ = std::max(0.5 * fire_dt_, kTune.fire_dt_min);
      fire_positive_ = 0;
    } else if (++fire_positive_ > 5) {
      fire_dt_ = std::min(fire_dt_ * 1.1, kTune.fire_dt_max);
      fire_alpha_ *= 0.99;
    }
    const double dt = fire_dt_;
#pragma omp parallel for schedule(static) if (n_ > 4 * kParallelGrains)
    for (std::size_t i = 0; i < n_; ++i) {
      if (force_[i].squaredNorm() == 0.0 && torque_[i].squaredNorm() == 0.0) {
        // No contact, no motion (zeroed above): a grain does not fly on through free space on
        // its momentum (that would turn a local relaxation into a rearrangement).
        continue;
      }
      vel_[i] += (dt * inverse_inertia_[i]) * force_[i];
      spin_[i] += (dt * inverse_inertia_[i]) * torque_[i];
      Eigen::Vector3d dx = dt * vel_[i];
      const double max_dx = kTune.max_step * s_ * req_[i];
      const double ndx = dx.norm();
      if (ndx > max_dx) dx *= max_dx / ndx;
      Eigen::Vector3d th = dt * spin_[i] / (s_ * req_[i]);
      double nth = th.norm();
      if (nth > kTune.max_rotation) {
        th *= kTune.max_rotation / nth;
        nth = kTune.max_rotation;
      }
      x_[i] += dx;
      if (nth > 0.0) {
        q_[i] = Eigen::Quaterniond(Eigen::AngleAxisd(nth, th / nth)) * q_[i];
        q_[i].normalize();
        R_[i] = q_[i].toRotationMatrix();
      }
      travel_[i] += dx.norm() + nth * s_ * rmax_[i];
    }
  }

  void grow(double s_new) {
    const double ds = s_new - s_;
    for (std::size_t i = 0; i < n_; ++i) travel_[i] += ds * rmax_[i];
    s_ = s_new;
  }

  void relax(const PackingObserver& observe) {
    travel_.assign(n_, 0.0);
    vel_.assign(n_, Eigen::Vector3d::Zero());
    spin_.assign(n_, Eigen::Vector3d::Zero());
    force_.assign(n_, Eigen::Vector3d::Zero());
    torque_.assign(n_, Eigen::Vector3d::Zero());
    inverse_inertia_.assign(n_, 1.0);
    walls_.assign(detail::kMaxWallHits * n_, WallHit{});
    wall_count_.assign(n_, 0);
    fire_dt_ = kTune.fire_dt_start;
    fire_alpha_ = kTune.fire_alpha_start;
    fire_positive_ = 0;
    double confirm_margin = 0.0;  // exact depth - estimate, at the last failed confirmation
    build_pairs();
    const double allow_growing = kTune.growth_overlap * req_mean_;
    double g = kTune.growth_first;
    bool hold = false;
    int sweep = 0;
    int last_growth = 0;          // sweep of the last 0.1 % growth
    double s_mark = s_;
    int last_settle = 0;          // sweep of the last 1 % drop of the worst overlap at full size
    double worst_mark = HUGE_VAL;
    for (;;) {
      if (sweep >= p_.max_sweeps) fail_converge(sweep);
      sweep_ = ++sweep;
      if (s_ < 1.0 && !hold) grow(std::min(1.0, s_ * (1.0 + g)));
      if (s_ >= s_mark * 1.001 || s_ >= 1.0) {
        s_mark = s_;
        last_growth = sweep;
      }
      if (s_ < 1.0 && sweep - last_growth > kTune.stall_sweeps) fail_jammed();
      if (pairs_.stale(x_, s_, rmax_max_)) build_pairs();
      const bool full = s_ >= 1.0;
      evaluate(tol_, false, kTune.refine_step);
      Stats st = stats();
      last_worst_ = st.worst();
      if (full) {
        if (st.worst() <= tol_ - confirm_margin) {
          // Confirm with every candidate pair evaluated afresh, as precisely as pair_contact()
          // and wall_penetration() do, so that the report agrees with find_contacts().
          const double estimate = st.worst();
          evaluate(tol_, true, detail::kExactRefineStep);
          st = stats();
          if (st.worst() <= tol_) {
            finish(st, sweep);
            return;
          }
          confirm_margin = std::max(confirm_margin, st.worst() - estimate);
        }
        if (st.worst() < 0.99 * worst_mark) {
          worst_mark = st.worst();
          last_settle = sweep;
        } else if (sweep - last_settle > kTune.settle_sweeps) {
          fail_jammed();
        }
      } else {
        hold = st.mean() > allow_growing;
        if (hold) {
          g = std::max(g * 0.7, kTune.growth_min);
        } else if (st.mean() < 0.5 * allow_growing) {
          g = std::min(g * 1.15, kTune.growth_max);
        }
      }
      fire_step();
      if (observe) observe({0, 1, sweep, p_.max_sweeps, s_, st.worst(), tol_});
    }
  }

  void finish(const Stats& st, int sweep) {
    PackingReport& r = final_report_;
    r.solid_fraction = fill_;
    r.max_overlap = st.max_pair;
    r.mean_overlap = st.mean();
    r.sweeps = sweep;
    r.touching_pairs = st.touching;
    r.max_wall_overlap = st.max_wall;
    r.wall_contacts = st.wall_touching;
    r.tolerance = tol_;
    r.initial_scale = s0_;
  }

  [[noreturn]] void fail_jammed() const {
    if (s_ < 1.0) {
      throw DataError("scene: the grains jam at solid fraction " + fmt_num(fill_ * s_ * s_ * s_, 3) +
                      " (" + fmt_num(100.0 * s_, 1) + " % of full size), below the requested " +
                      fmt_num(fill_, 3) + " in the " + container_kind_name(c_.kind) +
                      "; enlarge the container or lower the grain count");
    }
    throw DataError("scene: the grains jam at full size: overlaps stop decreasing at " +
                    fmt_um(last_worst_) + " (tolerance " + fmt_um(tol_) +
                    ") at solid fraction " + fmt_num(fill_, 3) + " in the " + container_kind_name(c_.kind) +
                    "; enlarge the container, lower the grain count or raise contact_tolerance");
  }

  [[noreturn]] void fail_converge(int sweeps) const {
    if (s_ < 1.0) {
      throw DataError("scene: after " + std::to_string(sweeps) + " sweeps the grains are at " +
                      fmt_num(100.0 * s_, 1) + " % of full size (solid fraction " +
                      fmt_num(fill_ * s_ * s_ * s_, 3) + " of the requested " + fmt_num(fill_, 3) +
                      "); enlarge the container, lower the grain count or raise max_sweeps");
    }
    throw DataError("scene: overlaps still reach " + fmt_um(last_worst_) + " (tolerance " +
                    fmt_um(tol_) + ") after " + std::to_string(sweeps) +
                    " sweeps at solid fraction " + fmt_num(fill_, 3) +
                    "; raise max_sweeps or contact_tolerance, or enlarge the container");
  }

  const Container c_;
  const PackingParams p_;
  const std::size_t n_;
  const std::vector<const shape::RadialTable*>& shapes_;
  std::vector<ShapeData> shape_data_;
  std::vector<int> grain_shape_;
  std::vector<double> rmax_, vol_, req_;
  double rmax_max_ = 0.0, rmax_mean_ = 0.0, req_mean_ = 0.0;
  double tol_ = 0.0, fill_ = 0.0;
  double s_ = 1.0, s0_ = 1.0;
  double last_worst_ = 0.0;
  int sweep_ = 0;
  // Grain state: position, orientation (and its matrix), FIRE velocities, forces, travel counters.
  std::vector<Eigen::Vector3d> x_;
  std::vector<Eigen::Quaterniond> q_;
  std::vector<Eigen::Matrix3d> R_;
  std::vector<Eigen::Vector3d> vel_, spin_, force_, torque_;
  std::vector<double> travel_, inverse_inertia_;
  double fire_dt_ = 0.1, fire_alpha_ = 0.1;
  int fire_positive_ = 0;
  // Candidate pairs, wall hits (kMaxWallHits slots per grain).
  detail::CandidatePairs pairs_;
  std::vector<WallHit> walls_;
  std::vector<int> wall_count_;
  PackingReport final_report_;
};

}  // namespace

std::vector<PackedGrain> pack_grains(const std::vector<const shape::RadialTable*>& shapes,
                                     const Container& c, const PackingParams& p,
                                     PackingReport* report, const PackingObserver& observe) {
  if (shapes.empty()) {
    if (report) *report = PackingReport{};
    return {};
  }
  Packer packer(shapes, c, p);
  return packer.pack(report, observe);
}

std::string packing_status_text(const PackingStatus& s) {
  std::string text = s.stages > 1 ? fmt::format("stage {} of {}, ", s.stage + 1, s.stages) : std::string();
  text += fmt::format("sweep {} of at most {}: ", s.sweep, s.max_sweeps);
  if (s.scale < 1.0)  // rounded down: a growing packing never reads 100 %
    return text + fmt::format("growing, {:.1f} % of full size, deepest overlap {:.2f} um",
                              std::floor(1000.0 * s.scale) / 10.0, 1e6 * s.worst_overlap);
  return text + fmt::format("at full size, deepest overlap {:.2f} um, to end within {:.2f} um", 1e6 * s.worst_overlap,
                            1e6 * s.tolerance);
}

PackingObserver log_packing_status(const std::string& what) {
  return [what, every = Interval(kStatusLineSeconds),
          stage = std::numeric_limits<std::size_t>::max()](const PackingStatus& s) mutable {
    const bool begins = s.stage != stage;
    stage = s.stage;
    if (every.due() || begins)
      spdlog::info("{}, {} in: {}", what, format_duration(every.elapsed()), packing_status_text(s));
  };
}

PackingReport relax_grains(const std::vector<const shape::RadialTable*>& shapes,
                           std::vector<PackedGrain>& poses, const Container& c,
                           const PackingParams& p, const PackingObserver& observe) {
  if (shapes.size() != poses.size()) {
    throw UsageError("relax_grains: " + std::to_string(shapes.size()) + " shapes but " +
                     std::to_string(poses.size()) + " poses; pass one pose per grain");
  }
  PackingReport report;
  if (shapes.empty()) return report;
  Packer packer(shapes, c, p);
  poses = packer.relax_from(poses, &report, observe);
  return report;
}

}  // namespace graintwin::synth
