#include "graintwin/segment/labels.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <set>
#include <string>
#include <unordered_map>

#include "graintwin/core/error.hpp"
#include "graintwin/core/parallel.hpp"

namespace graintwin::segment {
namespace {

std::uint32_t max_label(const Volume<std::uint32_t>& labels) {
  const std::uint32_t* l = labels.data();
  const std::size_t n = labels.size();
  std::uint32_t m = 0;
#pragma omp parallel for schedule(static) reduction(max : m)
  for (std::size_t i = 0; i < n; ++i) m = std::max(m, l[i]);
  return m;
}

/// The largest label, refused if the per-label tables would outgrow the image itself.
std::uint32_t checked_max_label(const Volume<std::uint32_t>& labels) {
  const std::uint32_t m = max_label(labels);
  if (m > labels.size())
    throw UsageError("labels go up to " + std::to_string(m) + ", more than the number of voxels; call relabel_sequential first");
  return m;
}

/// Replaces every label l by map[l] (map[0] must be 0), in parallel.
void apply_map(Volume<std::uint32_t>& labels, const std::vector<std::uint32_t>& map) {
  std::uint32_t* l = labels.data();
  const std::size_t n = labels.size();
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < n; ++i) l[i] = map[l[i]];
}

/// Voxel count per label 0..max, summed over per-thread counts.
std::vector<std::uint64_t> voxel_counts(const Volume<std::uint32_t>& labels, std::uint32_t max) {
  std::vector<std::uint64_t> total(std::size_t{max} + 1, 0);
  const std::uint32_t* l = labels.data();
  const std::size_t n = labels.size();
  // A table per thread: no more threads than processors (integer sums: the same for any team).
#pragma omp parallel num_threads(useful_threads(n))
  {
    std::vector<std::uint64_t> c(std::size_t{max} + 1, 0);
#pragma omp for schedule(static) nowait
    for (std::size_t i = 0; i < n; ++i) ++c[l[i]];
#pragma omp critical
    for (std::size_t k = 0; k <= max; ++k) total[k] += c[k];
  }
  return total;
}

}  // namespace

std::uint32_t relabel_sequential(Volume<std::uint32_t>& labels) {
  const std::uint32_t m = max_label(labels);
  std::uint32_t* l = labels.data();
  const std::size_t n = labels.size();
  std::uint32_t k = 0;
  if (m <= n) {
    std::vector<std::uint32_t> map(std::size_t{m} + 1, 0);
    for (std::size_t i = 0; i < n; ++i)
      if (l[i] != 0 && map[l[i]] == 0) map[l[i]] = ++k;
    apply_map(labels, map);
  } else {
    // Sparse label values: a hash map instead of a table as long as the label range.
    std::unordered_map<std::uint32_t, std::uint32_t> map;
    for (std::size_t i = 0; i < n; ++i) {
      if (l[i] == 0) continue;
      const auto [it, inserted] = map.try_emplace(l[i], k + 1);
      if (inserted) ++k;
      l[i] = it->second;
    }
  }
  return k;
}

FragmentReport remove_small_fragments(Volume<std::uint32_t>& labels, std::size_t min_voxels, FragmentPolicy policy,
                                      Connectivity c) {
  FragmentReport report;
  const std::uint32_t m = checked_max_label(labels);
  std::vector<std::uint64_t> size = voxel_counts(labels, m);
  std::vector<std::uint8_t> small(std::size_t{m} + 1, 0);
  std::size_t n_small = 0;
  for (std::uint32_t k = 1; k <= m; ++k)
    if (size[k] > 0 && size[k] < min_voxels) small[k] = 1, ++n_small;
  if (n_small == 0) return report;
  std::vector<std::uint32_t> map(std::size_t{m} + 1);
  std::iota(map.begin(), map.end(), 0u);
  if (policy == FragmentPolicy::remove) {
    for (std::uint32_t k = 1; k <= m; ++k)
      if (small[k]) map[k] = 0;
    report.removed = n_small;
    apply_map(labels, map);
    return report;
  }

  // Boundary sizes between a small fragment and any other label: neighbouring voxel pairs, each
  // unordered pair counted once through the steps that follow a voxel in raster order.
  const Shape3& s = labels.shape();
  const std::vector<NeighbourStep> all = neighbour_steps(c, s);
  const std::vector<NeighbourStep> after(all.begin() + static_cast<std::ptrdiff_t>(all.size() / 2), all.end());
  const std::uint32_t* l = labels.data();
  std::unordered_map<std::uint64_t, std::uint64_t> pairs;
#pragma omp parallel
  {
    std::unordered_map<std::uint64_t, std::uint64_t> local;
#pragma omp for schedule(static) nowait
    for (std::size_t z = 0; z < s[0]; ++z)
      for (std::size_t y = 0; y < s[1]; ++y) {
        std::size_t p = labels.index(z, y, 0);
        for (std::size_t x = 0; x < s[2]; ++x, ++p) {
          const std::uint32_t a = l[p];
          if (a == 0) continue;
          for_each_neighbour(after, s, z, y, x, p, [&](std::size_t q) {
            const std::uint32_t b = l[q];
            if (b == 0 || b == a || !(small[a] || small[b])) return;
            ++local[std::uint64_t{std::min(a, b)} << 32 | std::max(a, b)];
          });
        }
      }
#pragma omp critical
    for (const auto& [key, count] : local) pairs[key] += count;
  }
  struct Edge {
    std::uint32_t other;
    std::uint64_t count;
  };
  std::vector<std::vector<Edge>> adj(std::size_t{m} + 1);
  for (const auto& [key, count] : pairs) {
    const auto a = static_cast<std::uint32_t>(key >> 32), b = static_cast<std::uint32_t>(key & 0xFFFFFFFFu);
    if (small[a]) adj[a].push_back({b, count});
    if (small[b]) adj[b].push_back({a, count});
  }

  std::vector<std::uint32_t> parent(std::size_t{m} + 1);
  std::iota(parent.begin(), parent.end(), 0u);
  std::vector<std::uint8_t> removed(std::size_t{m} + 1, 0);
  const auto find = [&](std::uint32_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  std::set<std::pair<std::uint64_t, std::uint32_t>> pending;
  for (std::uint32_t k = 1; k <= m; ++k)
    if (small[k]) pending.insert({size[k], k});
  std::vector<Edge> sums;
  while (!pending.empty()) {
    const auto [sz, x] = *pending.begin();
    pending.erase(pending.begin());
    // The boundary of x with each current neighbour root; the list order does not matter because
    // the sums are sorted before the choice.
    sums.clear();
    for (const Edge& e : adj[x]) {
      const std::uint32_t r = find(e.other);
      if (r != x && !removed[r]) sums.push_back({r, e.count});
    }
    std::sort(sums.begin(), sums.end(), [](const Edge& a, const Edge& b) { return a.other < b.other; });
    std::uint32_t best = 0;
    std::uint64_t best_count = 0, run = 0;
    for (std::size_t i = 0; i < sums.size(); ++i) {
      run += sums[i].count;
      if (i + 1 == sums.size() || sums[i + 1].other != sums[i].other) {
        if (run > best_count) best = sums[i].other, best_count = run;
        run = 0;
      }
    }
    if (best == 0) {
      removed[x] = 1;
      ++report.removed;
      continue;
    }
    parent[x] = best;
    pending.erase({size[best], best});  // queued under its old size if it was a fragment too
    size[best] += sz;
    ++report.merged;
    if (size[best] < min_voxels) {
      // Still a fragment: it inherits x's boundary and comes back with its new size.
      adj[best].insert(adj[best].end(), adj[x].begin(), adj[x].end());
      pending.insert({size[best], best});
    }
    std::vector<Edge>().swap(adj[x]);
  }
  for (std::uint32_t k = 1; k <= m; ++k) {
    const std::uint32_t r = find(k);
    map[k] = removed[r] ? 0 : r;
  }
  apply_map(labels, map);
  return report;
}

std::size_t remove_edge_grains(Volume<std::uint32_t>& labels) {
  const std::uint32_t m = checked_max_label(labels);
  const Shape3& s = labels.shape();
  std::vector<std::uint8_t> edge(std::size_t{m} + 1, 0);
  for (std::size_t z = 0; z < s[0]; ++z)
    for (std::size_t y = 0; y < s[1]; ++y) {
      const bool face = z == 0 || y == 0 || z + 1 == s[0] || y + 1 == s[1];
      const std::size_t step = face ? 1 : std::max<std::size_t>(1, s[2] - 1);  // interior rows: ends only
      for (std::size_t x = 0; x < s[2]; x += step) edge[labels(z, y, x)] = 1;
    }
  std::vector<std::uint32_t> map(std::size_t{m} + 1);
  std::iota(map.begin(), map.end(), 0u);
  std::size_t removed = 0;
  for (std::uint32_t k = 1; k <= m; ++k)
    if (edge[k]) map[k] = 0, ++removed;
  apply_map(labels, map);
  return removed;
}

std::vector<GrainRecord> grain_table(const Volume<std::uint32_t>& labels) {
  const std::uint32_t m = checked_max_label(labels);
  const Shape3& s = labels.shape();
  struct Acc {
    std::uint64_t count = 0, sz = 0, sy = 0, sx = 0;
    std::array<std::size_t, 6> box{std::numeric_limits<std::size_t>::max(), std::numeric_limits<std::size_t>::max(),
                                   std::numeric_limits<std::size_t>::max(), 0, 0, 0};
    void merge(const Acc& o) {
      count += o.count, sz += o.sz, sy += o.sy, sx += o.sx;
      for (int a = 0; a < 3; ++a) box[a] = std::min(box[a], o.box[a]), box[a + 3] = std::max(box[a + 3], o.box[a + 3]);
    }
  };
  std::vector<Acc> total(std::size_t{m} + 1);
  const std::uint32_t* l = labels.data();
  // A table per thread: no more threads than processors (integer sums: the same for any team).
#pragma omp parallel num_threads(useful_threads(s[0]))
  {
    std::vector<Acc> acc(std::size_t{m} + 1);
#pragma omp for schedule(static) nowait
    for (std::size_t z = 0; z < s[0]; ++z)
      for (std::size_t y = 0; y < s[1]; ++y) {
        const std::uint32_t* row = l + labels.index(z, y, 0);
        for (std::size_t x = 0; x < s[2]; ++x) {
          if (row[x] == 0) continue;
          Acc& a = acc[row[x]];
          ++a.count, a.sz += z, a.sy += y, a.sx += x;
          a.box[0] = std::min(a.box[0], z), a.box[1] = std::min(a.box[1], y), a.box[2] = std::min(a.box[2], x);
          a.box[3] = std::max(a.box[3], z + 1), a.box[4] = std::max(a.box[4], y + 1), a.box[5] = std::max(a.box[5], x + 1);
        }
      }
#pragma omp critical
    for (std::size_t k = 1; k <= m; ++k)
      if (acc[k].count) total[k].merge(acc[k]);
  }
  const Vec3& vs = labels.voxel_size();
  const Vec3& o = labels.origin();
  std::vector<GrainRecord> table;
  for (std::uint32_t k = 1; k <= m; ++k) {
    const Acc& a = total[k];
    if (a.count == 0) continue;
    GrainRecord r;
    r.label = k;
    r.voxels = a.count;
    r.volume_m3 = static_cast<double>(a.count) * vs[0] * vs[1] * vs[2];
    const double n = static_cast<double>(a.count);
    r.centroid_xyz = {o[2] + static_cast<double>(a.sx) / n * vs[2], o[1] + static_cast<double>(a.sy) / n * vs[1],
                      o[0] + static_cast<double>(a.sz) / n * vs[0]};
    r.bbox = a.box;
    r.touches_edge = a.box[0] == 0 || a.box[1] == 0 || a.box[2] == 0 || a.box[3] == s[0] || a.box[4] == s[1] ||
                     a.box[5] == s[2];
    table.push_back(r);
  }
  return table;
}

std::string grain_table_mismatch(const Volume<std::uint32_t>& labels, const std::vector<GrainRecord>& table) {
  for (std::size_t i = 0; i < table.size(); ++i) {
    if (table[i].label == 0) return "it has a row for label 0, which is background";
    if (i > 0 && table[i].label <= table[i - 1].label)
      return "its rows are not in increasing label order (label " + std::to_string(table[i].label) + " follows " +
             std::to_string(table[i - 1].label) + ")";
  }
  const std::uint32_t m = max_label(labels);
  if (m > labels.size())
    return "the label image holds label " + std::to_string(m) + ", more than its " + std::to_string(labels.size()) +
           " voxels, so its grains are not numbered 1 to N";
  const std::vector<GrainRecord> image = grain_table(labels);
  const Vec3& vs = labels.voxel_size();
  const double centroid_tol = 1e-6 * std::min({vs[0], vs[1], vs[2]});
  // One walk over both tables, in label order.
  std::size_t missing = 0, extra = 0, differ = 0;
  std::uint32_t missing_lo = 0, missing_hi = 0, extra_first = 0;
  std::string first_difference;
  for (std::size_t i = 0, j = 0; i < image.size() || j < table.size();) {
    if (j == table.size() || (i < image.size() && image[i].label < table[j].label)) {
      if (missing++ == 0) missing_lo = image[i].label;
      missing_hi = image[i++].label;
      continue;
    }
    if (i == image.size() || table[j].label < image[i].label) {
      if (extra++ == 0) extra_first = table[j].label;
      ++j;
      continue;
    }
    const GrainRecord &a = image[i++], &b = table[j++];
    const std::string label = "label " + std::to_string(a.label);
    std::string what;
    if (a.voxels != b.voxels)
      what = label + " has " + std::to_string(b.voxels) + " voxels in the table but " + std::to_string(a.voxels) + " in the image";
    else if (a.bbox != b.bbox)
      what = label + "'s bounding box is not the one of its voxels";
    else if (a.touches_edge != b.touches_edge)
      what = label + "'s volume-edge flag is wrong";
    else if (!(std::abs(a.centroid_xyz[0] - b.centroid_xyz[0]) <= centroid_tol &&
               std::abs(a.centroid_xyz[1] - b.centroid_xyz[1]) <= centroid_tol &&
               std::abs(a.centroid_xyz[2] - b.centroid_xyz[2]) <= centroid_tol))
      what = label + "'s centroid is not the mean of its voxels";
    else if (!(std::abs(a.volume_m3 - b.volume_m3) <= 1e-9 * a.volume_m3))
      what = label + "'s volume is not its voxel count times the voxel volume";
    if (!what.empty() && differ++ == 0) first_difference = what;
  }
  std::vector<std::string> parts;
  const auto grains = [](std::size_t n) { return std::to_string(n) + (n == 1 ? " grain" : " grains"); };
  if (missing > 0)
    parts.push_back(grains(missing) + " of the label image " + (missing == 1 ? "has" : "have") + " no row in the grain table (" +
                    (missing == 1 ? "label " + std::to_string(missing_lo)
                                  : "labels " + std::to_string(missing_lo) + " to " + std::to_string(missing_hi)) +
                    ")");
  if (extra > 0)
    parts.push_back(std::to_string(extra) + (extra == 1 ? " row names a label" : " rows name labels") +
                    " absent from the label image (first: label " + std::to_string(extra_first) + ")");
  if (differ > 0)
    parts.push_back(std::to_string(differ) + (differ == 1 ? " row disagrees" : " rows disagree") +
                    " with the image (first: " + first_difference + ")");
  std::string out;
  for (std::size_t k = 0; k < parts.size(); ++k) out += (k == 0 ? "" : k + 1 == parts.size() ? " and " : ", ") + parts[k];
  return out;
}

}  // namespace graintwin::segment
