#include "graintwin/contacts/detect.hpp"

#include <omp.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <atomic>
#include <string>

#include "graintwin/core/error.hpp"
#include "graintwin/core/parallel.hpp"
#include "graintwin/segment/connectivity.hpp"

namespace graintwin::contacts {
namespace {

/// Pair sums of one thread, found by an open-addressing hash of the pair key (low << 32 | high).
/// Neighbouring contact voxels usually belong to the same pair, so the last key is cached.
class PairTable {
 public:
  PairTable() : keys_(std::size_t{1} << kInitialBits, 0), slots_(keys_.size()), bits_(kInitialBits) {}

  PairSums& at(std::uint32_t a, std::uint32_t b) {
    const std::uint32_t lo = std::min(a, b), hi = std::max(a, b);
    const std::uint64_t key = std::uint64_t{lo} << 32 | hi;
    if (key == last_key_) return rows[last_];
    if (2 * (rows.size() + 1) > keys_.size()) grow();
    std::size_t i = home(key);
    while (keys_[i] != 0 && keys_[i] != key) i = (i + 1) & (keys_.size() - 1);
    if (keys_[i] == 0) {
      keys_[i] = key;
      slots_[i] = static_cast<std::uint32_t>(rows.size());
      PairSums& r = rows.emplace_back();
      r.low = lo;
      r.high = hi;
    }
    last_key_ = key;
    last_ = slots_[i];
    return rows[last_];
  }

  std::vector<PairSums> rows;

 private:
  static constexpr int kInitialBits = 10;
  std::size_t home(std::uint64_t key) const { return (key * 0x9E3779B97F4A7C15ull) >> (64 - bits_); }
  void grow() {
    ++bits_;
    keys_.assign(std::size_t{1} << bits_, 0);
    slots_.assign(keys_.size(), 0);
    for (std::uint32_t k = 0; k < rows.size(); ++k) {
      const std::uint64_t key = std::uint64_t{rows[k].low} << 32 | rows[k].high;
      std::size_t i = home(key);
      while (keys_[i] != 0) i = (i + 1) & (keys_.size() - 1);
      keys_[i] = key;
      slots_[i] = k;
    }
  }
  std::vector<std::uint64_t> keys_;  // 0 = empty (labels are >= 1, so no real key is 0)
  std::vector<std::uint32_t> slots_;
  int bits_;
  std::uint64_t last_key_ = 0;
  std::uint32_t last_ = 0;
};

/// Block extrema over the 3 x 3 x 3 neighbourhood, from which a voxel of label a != 0 is a contact
/// candidate exactly when max > a or min_nz < a - 1: the block then holds a non-zero label other
/// than a. min_nz is the minimum of (label - 1) in uint32 arithmetic, which maps 0 to the largest
/// value so that background never wins. Both filters are separable (x, then y, then z over a ring
/// of three filtered slices), about 12 min/max per voxel instead of 26 comparisons; this is the
/// only part of the pass that touches every voxel.
class BlockExtrema {
 public:
  BlockExtrema(const Volume<std::uint32_t>& labels)
      : l_(labels.data()), s_(labels.shape()), plane_(s_[1] * s_[2]), tmax_(plane_), tmin_(plane_),
        max_(3, std::vector<std::uint32_t>(plane_)), min_(3, std::vector<std::uint32_t>(plane_)) {}

  /// Fills flag (one row of nx) for row (z, y); rows must come in raster order within a z range,
  /// and z - 1, z, z + 1 are filtered as needed.
  void flag_row(std::size_t z, std::size_t y, std::uint32_t* flag) {
    for (std::size_t k = z == 0 ? 0 : z - 1; k <= std::min(z + 1, s_[0] - 1); ++k)
      if (!ready(k)) filter_slice(k);
    const std::size_t nx = s_[2];
    const std::size_t zl = z == 0 ? z : z - 1, zh = z + 1 == s_[0] ? z : z + 1;
    const std::uint32_t *mx0 = &max_[zl % 3][y * nx], *mx1 = &max_[z % 3][y * nx], *mx2 = &max_[zh % 3][y * nx];
    const std::uint32_t *mn0 = &min_[zl % 3][y * nx], *mn1 = &min_[z % 3][y * nx], *mn2 = &min_[zh % 3][y * nx];
    const std::uint32_t* r = l_ + z * plane_ + y * nx;
    for (std::size_t x = 0; x < nx; ++x) {
      const std::uint32_t hi = std::max(std::max(mx0[x], mx1[x]), mx2[x]);
      const std::uint32_t lo = std::min(std::min(mn0[x], mn1[x]), mn2[x]);
      flag[x] = static_cast<std::uint32_t>((r[x] != 0) & ((hi > r[x]) | (lo < r[x] - 1)));
    }
  }

 private:
  bool ready(std::size_t k) const { return slice_[k % 3] == k; }
  void filter_slice(std::size_t k) {
    const std::size_t ny = s_[1], nx = s_[2];
    const std::uint32_t* src = l_ + k * plane_;
    for (std::size_t y = 0; y < ny; ++y) {
      const std::uint32_t* r = src + y * nx;
      std::uint32_t *tx = &tmax_[y * nx], *tn = &tmin_[y * nx];
      if (nx == 1) {
        tx[0] = r[0], tn[0] = r[0] - 1;
        continue;
      }
      tx[0] = std::max(r[0], r[1]), tn[0] = std::min(r[0] - 1, r[1] - 1);
      for (std::size_t x = 1; x + 1 < nx; ++x) {
        tx[x] = std::max(std::max(r[x - 1], r[x]), r[x + 1]);
        tn[x] = std::min(std::min(r[x - 1] - 1, r[x] - 1), r[x + 1] - 1);
      }
      tx[nx - 1] = std::max(r[nx - 2], r[nx - 1]), tn[nx - 1] = std::min(r[nx - 2] - 1, r[nx - 1] - 1);
    }
    std::uint32_t *mx = max_[k % 3].data(), *mn = min_[k % 3].data();
    for (std::size_t y = 0; y < ny; ++y) {
      const std::size_t a = (y == 0 ? y : y - 1) * nx, b = y * nx, c = (y + 1 == ny ? y : y + 1) * nx;
      for (std::size_t x = 0; x < nx; ++x) {
        mx[b + x] = std::max(std::max(tmax_[a + x], tmax_[b + x]), tmax_[c + x]);
        mn[b + x] = std::min(std::min(tmin_[a + x], tmin_[b + x]), tmin_[c + x]);
      }
    }
    slice_[k % 3] = k;
  }

  const std::uint32_t* l_;
  Shape3 s_;
  std::size_t plane_;
  std::vector<std::uint32_t> tmax_, tmin_;           // x-filtered rows of the slice being filtered
  std::vector<std::vector<std::uint32_t>> max_, min_;  // xy-filtered slices, ring of three
  std::size_t slice_[3] = {~std::size_t{0}, ~std::size_t{0}, ~std::size_t{0}};  // slice held by each ring entry
};

/// Adds voxel p = (z, y, x) of label a to every pair it belongs to as a contact voxel, and every
/// neighbouring voxel pair it starts (the 13 neighbours after it in raster order, so each pair is
/// seen once) with the faces among them.
void add_voxel(PairTable& table, const std::uint32_t* l, const Shape3& s, const std::vector<segment::NeighbourStep>& steps,
               std::size_t z, std::size_t y, std::size_t x, std::size_t p) {
  const std::uint32_t a = l[p];
  std::uint32_t others[26];
  int n = 0;
  segment::for_each_neighbour(steps, s, z, y, x, p, [&](std::size_t q) {
    const std::uint32_t b = l[q];
    if (b == 0 || b == a) return;
    for (int k = 0; k < n; ++k)
      if (others[k] == b) return;
    others[n++] = b;
  });
  const std::int64_t at[3] = {static_cast<std::int64_t>(z), static_cast<std::int64_t>(y), static_cast<std::int64_t>(x)};
  for (int k = 0; k < n; ++k) {
    PairSums& ps = table.at(a, others[k]);
    const int side = a < others[k] ? 0 : 1;
    ++ps.voxels[side];
    for (int i = 0; i < 3; ++i) ps.sum[side][i] += at[i];
  }
  const bool interior = segment::is_interior(s, z, y, x);
  const std::int64_t size[3] = {static_cast<std::int64_t>(s[0]), static_cast<std::int64_t>(s[1]), static_cast<std::int64_t>(s[2])};
  for (std::size_t i = steps.size() / 2; i < steps.size(); ++i) {
    const segment::NeighbourStep& st = steps[i];
    const std::int64_t m[3] = {2 * at[0] + st.dz, 2 * at[1] + st.dy, 2 * at[2] + st.dx};  // p + q
    if (!interior && (m[0] - at[0] >= size[0] || m[1] - at[1] < 0 || m[1] - at[1] >= size[1] ||
                      m[2] - at[2] < 0 || m[2] - at[2] >= size[2]))
      continue;
    const std::uint32_t b = l[p + st.offset];
    if (b == 0 || b == a) continue;
    PairSums& ps = table.at(a, b);
    ++ps.pairs;
    for (int k = 0; k < 3; ++k) ps.pair_sum[k] += m[k];
    ps.pair_moment[0] += m[0] * m[0], ps.pair_moment[1] += m[1] * m[1], ps.pair_moment[2] += m[2] * m[2];
    ps.pair_moment[3] += m[0] * m[1], ps.pair_moment[4] += m[0] * m[2], ps.pair_moment[5] += m[1] * m[2];
    if (std::abs(st.dz) + std::abs(st.dy) + std::abs(st.dx) == 1) ps.faces[st.dz ? 0 : st.dy ? 1 : 2] += a < b ? 1 : -1;
  }
}

void merge_into(PairSums& to, const PairSums& from) {
  for (int side = 0; side < 2; ++side) {
    to.voxels[side] += from.voxels[side];
    for (int k = 0; k < 3; ++k) to.sum[side][k] += from.sum[side][k];
  }
  to.pairs += from.pairs;
  for (int k = 0; k < 3; ++k) to.pair_sum[k] += from.pair_sum[k], to.faces[k] += from.faces[k];
  for (int k = 0; k < 6; ++k) to.pair_moment[k] += from.pair_moment[k];
}

}  // namespace

std::vector<PairSums> contact_sums(const Volume<std::uint32_t>& labels, const std::function<void(double)>& progress) {
  const Shape3& s = labels.shape();
  const std::uint32_t* l = labels.data();
  const auto steps = segment::neighbour_steps(segment::Connectivity::corners, s);
  PairTable total;
  std::atomic<std::size_t> slabs_done{0};
  // A pair table and three filtered slices per thread: no more threads than processors or slabs
  // (integer sums: the same for any team).
#pragma omp parallel num_threads(useful_threads(s[0]))
  {
    // Contiguous z ranges per thread, so that each filtered slice is reused by three slabs.
    const auto nt = static_cast<std::size_t>(omp_get_num_threads()), t = static_cast<std::size_t>(omp_get_thread_num());
    const std::size_t z0 = s[0] * t / nt, z1 = s[0] * (t + 1) / nt;
    PairTable table;
    std::vector<std::uint32_t> flag(s[2]);
    if (z0 < z1) {
      BlockExtrema extrema(labels);
      for (std::size_t z = z0; z < z1; ++z) {
        for (std::size_t y = 0; y < s[1]; ++y) {
          extrema.flag_row(z, y, flag.data());
          const std::size_t row = labels.index(z, y, 0);
          for (std::size_t x = 0; x < s[2]; ++x)
            if (flag[x]) add_voxel(table, l, s, steps, z, y, x, row + x);
        }
        const std::size_t done = ++slabs_done;
        if (progress && t == 0) progress(static_cast<double>(done) / static_cast<double>(s[0]));
      }
    }
    // Integer sums: the merge order does not change the result.
#pragma omp critical
    for (const PairSums& r : table.rows) merge_into(total.at(r.low, r.high), r);
  }
  std::vector<PairSums> out = std::move(total.rows);
  std::sort(out.begin(), out.end(),
            [](const PairSums& a, const PairSums& b) { return a.low != b.low ? a.low < b.low : a.high < b.high; });
  if (progress) progress(1.0);
  return out;
}

std::vector<Contact> contacts_from_sums(const std::vector<PairSums>& sums, const Volume<std::uint32_t>& like,
                                        const std::vector<segment::GrainRecord>& grains, const DetectParams& params) {
  const auto by_label = [](const segment::GrainRecord& a, const segment::GrainRecord& b) { return a.label < b.label; };
  if (!std::is_sorted(grains.begin(), grains.end(), by_label))
    throw UsageError("contacts_from_sums: the grain table must be sorted by label");
  const auto centroid_of = [&](std::uint32_t label) {
    segment::GrainRecord key;
    key.label = label;
    const auto it = std::lower_bound(grains.begin(), grains.end(), key, by_label);
    if (it == grains.end() || it->label != label)
      throw DataError("label " + std::to_string(label) + " touches another grain but has no row in the grain table");
    return Eigen::Vector3d(it->centroid_xyz[0], it->centroid_xyz[1], it->centroid_xyz[2]);
  };
  const Vec3& vs = like.voxel_size();
  // Index axis (z, y, x) of each physical axis (x, y, z), and its voxel size.
  const int axis_of[3] = {2, 1, 0};
  const double h[3] = {vs[2], vs[1], vs[0]};

  std::vector<Contact> out;
  for (const PairSums& ps : sums) {
    if (ps.voxels[0] < params.min_voxels || ps.voxels[1] < params.min_voxels) continue;
    Contact c;
    c.low = ps.low;
    c.high = ps.high;
    c.voxels_low = ps.voxels[0];
    c.voxels_high = ps.voxels[1];
    const double n = static_cast<double>(ps.voxels[0] + ps.voxels[1]);
    c.centroid = like.position_xyz(static_cast<double>(ps.sum[0][0] + ps.sum[1][0]) / n,
                                   static_cast<double>(ps.sum[0][1] + ps.sum[1][1]) / n,
                                   static_cast<double>(ps.sum[0][2] + ps.sum[1][2]) / n);
    // Covariance of the pair midpoints in index units from the exact sums (of twice the midpoint,
    // hence the 1/4), then scaled to metres in (x, y, z) order.
    const int slot[3][3] = {{0, 3, 4}, {3, 1, 5}, {4, 5, 2}};  // pair_moment slot of index axes (a, b)
    const double np = static_cast<double>(ps.pairs);
    Eigen::Matrix3d cov;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        const int a = axis_of[i], b = axis_of[j];
        const double mean_a = static_cast<double>(ps.pair_sum[a]) / np, mean_b = static_cast<double>(ps.pair_sum[b]) / np;
        cov(i, j) = 0.25 * (static_cast<double>(ps.pair_moment[slot[a][b]]) / np - mean_a * mean_b) * h[i] * h[j];
      }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
    Eigen::Vector3d normal = eig.eigenvectors().col(0);
    const Eigen::Vector3d branch = centroid_of(c.high) - centroid_of(c.low);
    double side = normal.dot(branch);
    if (side == 0.0) {
      Eigen::Vector3d between;
      for (int i = 0; i < 3; ++i) {
        const int a = axis_of[i];
        between[i] = (static_cast<double>(ps.sum[1][a]) / static_cast<double>(ps.voxels[1]) -
                      static_cast<double>(ps.sum[0][a]) / static_cast<double>(ps.voxels[0])) * h[i];
      }
      side = normal.dot(between);
    }
    if (side < 0.0) normal = -normal;
    c.normal = {normal[0], normal[1], normal[2]};
    for (int i = 0; i < 3; ++i) {
      const int a = axis_of[i];
      // A face normal to index axis a has the area of the other two voxel edges.
      c.vector_area[i] = static_cast<double>(ps.faces[a]) * h[(i + 1) % 3] * h[(i + 2) % 3];
      c.branch[i] = branch[i];
    }
    c.area = std::sqrt(c.vector_area[0] * c.vector_area[0] + c.vector_area[1] * c.vector_area[1] +
                       c.vector_area[2] * c.vector_area[2]);
    out.push_back(c);
  }
  return out;
}

std::vector<Contact> find_contacts(const Volume<std::uint32_t>& labels, const std::vector<segment::GrainRecord>& grains,
                                   const DetectParams& params, const std::function<void(double)>& progress) {
  return contacts_from_sums(contact_sums(labels, progress), labels, grains, params);
}

}  // namespace graintwin::contacts
