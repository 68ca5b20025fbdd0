// Contacts between labelled grains against exact answers: touching boxes with known normals and
// areas, random label images against a brute-force count, fabric tensors and anisotropy of known
// direction sets, rose counts, coordination numbers, the VTK network, and the grey-level
// refinement of normals and gaps on scanned touching spheres (the spam protocol); labels2contacts'
// stage as one call.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <random>
#include <set>

#include "graintwin/contacts/detect.hpp"
#include "graintwin/contacts/fabric.hpp"
#include "graintwin/contacts/network.hpp"
#include "graintwin/contacts/refine.hpp"
#include "graintwin/contacts/scan_contacts.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/segment/edt.hpp"
#include "graintwin/segment/labels.hpp"
#include "graintwin/segment/markers.hpp"
#include "graintwin/segment/threshold.hpp"
#include "graintwin/segment/watershed.hpp"
#include "support/phantoms.hpp"

using namespace graintwin;
using namespace graintwin::contacts;

namespace {

/// Sets the box [z0, z1) x [y0, y1) x [x0, x1) to `label`.
void paint(Volume<std::uint32_t>& v, std::array<std::size_t, 6> box, std::uint32_t label) {
  for (std::size_t z = box[0]; z < box[3]; ++z)
    for (std::size_t y = box[1]; y < box[4]; ++y)
      for (std::size_t x = box[2]; x < box[5]; ++x) v(z, y, x) = label;
}

double angle_deg(const Vec3& a, const Vec3& b) {
  const double d = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) /
                   std::sqrt((a[0] * a[0] + a[1] * a[1] + a[2] * a[2]) * (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]));
  return std::acos(std::min(1.0, std::abs(d))) * 180.0 / std::numbers::pi;
}

/// Unit vector at polar angle theta from +z and azimuth phi from +x.
Vec3 direction(double theta, double phi) {
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

}  // namespace

TEST(ContactsDetect, TwoBoxesSharingAFaceGiveTheExactNormalAreaAndBranch) {
  // Anisotropic voxels (dz, dy, dx) so that every axis scales differently.
  const Vec3 vs{2e-5, 1e-5, 1.5e-5};
  Volume<std::uint32_t> v({12, 9, 10}, vs, {1e-3, 2e-3, 3e-3});
  paint(v, {2, 2, 3, 6, 6, 8}, 5);   // 4 x 4 x 5 voxels below z = 6
  paint(v, {6, 2, 3, 10, 6, 8}, 9);  // the same above
  const auto grains = segment::grain_table(v);
  const auto cs = find_contacts(v, grains);
  ASSERT_EQ(cs.size(), 1u);
  const Contact& c = cs[0];
  EXPECT_EQ(c.low, 5u);
  EXPECT_EQ(c.high, 9u);
  EXPECT_EQ(c.voxels_low, 20u);  // the whole 4 x 5 layer at z = 5, and at z = 6
  EXPECT_EQ(c.voxels_high, 20u);
  EXPECT_NEAR(c.normal[0], 0.0, 1e-12);
  EXPECT_NEAR(c.normal[1], 0.0, 1e-12);
  EXPECT_NEAR(c.normal[2], 1.0, 1e-12);  // (x, y, z): from low (below) to high (above)
  EXPECT_NEAR(c.area, 20 * vs[1] * vs[2], 1e-18);
  EXPECT_NEAR(c.vector_area[2], c.area, 1e-18);
  const Vec3 expect_centroid = v.position_xyz(5.5, 3.5, 5.0);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(c.centroid[i], expect_centroid[i], 1e-15);
  EXPECT_NEAR(c.branch[2], 4 * vs[0], 1e-15);  // the box centroids are 4 voxels apart in z
  EXPECT_NEAR(c.branch[0], 0.0, 1e-15);

  // Swapping the labels flips the normal: it always points from the lower label to the higher.
  paint(v, {2, 2, 3, 6, 6, 8}, 9);
  paint(v, {6, 2, 3, 10, 6, 8}, 5);
  const auto flipped = find_contacts(v, segment::grain_table(v));
  ASSERT_EQ(flipped.size(), 1u);
  EXPECT_NEAR(flipped[0].normal[2], -1.0, 1e-12);
  EXPECT_NEAR(flipped[0].vector_area[2], -c.area, 1e-18);
}

TEST(ContactsDetect, DiagonalInterfaceGivesTheDiagonalNormal) {
  // A 10^3 cube split by the plane x + y = 9.5: the voxel staircase is symmetric about it, so the
  // PCA of the pair midpoints and the vector area both point exactly along (1, 1, 0) / sqrt 2.
  Volume<std::uint32_t> v({10, 10, 10});
  for (std::size_t z = 0; z < 10; ++z)
    for (std::size_t y = 0; y < 10; ++y)
      for (std::size_t x = 0; x < 10; ++x) v(z, y, x) = x + y < 10 ? 1 : 2;
  const auto cs = find_contacts(v, segment::grain_table(v));
  ASSERT_EQ(cs.size(), 1u);
  const double r = 1.0 / std::sqrt(2.0);
  EXPECT_NEAR(cs[0].normal[0], r, 1e-12);
  EXPECT_NEAR(cs[0].normal[1], r, 1e-12);
  EXPECT_NEAR(cs[0].normal[2], 0.0, 1e-12);
  EXPECT_NEAR(angle_deg(cs[0].vector_area, {r, r, 0.0}), 0.0, 1e-9);
  // 9 faces normal to x and 9 normal to y per z slice: |(90, 90, 0)| face units.
  EXPECT_NEAR(cs[0].area, std::hypot(90.0, 90.0), 1e-9);
}

TEST(ContactsDetect, SizeThresholdAndSeparateRegionsOfOnePair) {
  Volume<std::uint32_t> v({8, 8, 12});
  paint(v, {1, 1, 1, 3, 3, 3}, 1);
  paint(v, {3, 3, 3, 5, 5, 5}, 2);  // meets grain 1 at one corner only: one contact voxel each
  const auto grains = segment::grain_table(v);
  EXPECT_TRUE(find_contacts(v, grains).empty()) << "a single voxel each is below the default size";
  const auto corner = find_contacts(v, grains, DetectParams{1});
  ASSERT_EQ(corner.size(), 1u);
  EXPECT_EQ(corner[0].voxels_low, 1u);
  EXPECT_EQ(corner[0].area, 0.0) << "no shared face";

  // Grain 3 is a U (two ends joined by a bar at y = 1); grain 4 lies in the slot and touches both
  // ends but not the bar: two separate contact regions, one contact.
  Volume<std::uint32_t> u({6, 6, 14});
  paint(u, {1, 1, 1, 5, 5, 13}, 3);
  paint(u, {1, 2, 4, 5, 5, 10}, 0);  // the slot
  paint(u, {2, 3, 4, 4, 5, 10}, 4);  // 2 x 2 x 6 bar from end to end, 2 voxels above the U's bar
  const auto cs = find_contacts(u, segment::grain_table(u));
  ASSERT_EQ(cs.size(), 1u);
  EXPECT_EQ(cs[0].low, 3u);
  // Contact voxels of 3: at x = 3 and x = 10, z in 1..4 and y in 2..4 (the 26-rim of the bar's end).
  EXPECT_EQ(cs[0].voxels_low, 2u * 12u);
  EXPECT_EQ(cs[0].voxels_high, 2u * 4u);  // the bar's two end squares
}

TEST(ContactsDetect, RandomLabelImagesMatchABruteForceCountForAnyThreadCount) {
  // Voronoi cells of 40 seeds with a quarter of the voxels cleared: contacts of every shape,
  // touching the volume faces too. Reference: sets of contact voxels and pairs built the slow way.
  std::mt19937 rng(11);
  const Shape3 s{17, 23, 19};
  Volume<std::uint32_t> v(s);
  std::uniform_real_distribution<double> uz(0, s[0]), uy(0, s[1]), ux(0, s[2]), u01(0, 1);
  std::vector<std::array<double, 3>> seeds(40);
  for (auto& p : seeds) p = {uz(rng), uy(rng), ux(rng)};
  for (std::size_t z = 0; z < s[0]; ++z)
    for (std::size_t y = 0; y < s[1]; ++y)
      for (std::size_t x = 0; x < s[2]; ++x) {
        if (u01(rng) < 0.25) continue;
        std::size_t best = 0;
        double bd = 1e30;
        for (std::size_t k = 0; k < seeds.size(); ++k) {
          const double d = std::pow(z - seeds[k][0], 2) + std::pow(y - seeds[k][1], 2) + std::pow(x - seeds[k][2], 2);
          if (d < bd) bd = d, best = k;
        }
        v(z, y, x) = static_cast<std::uint32_t>(best + 1);
      }
  struct Ref {
    std::set<std::size_t> side[2];
    std::uint64_t pairs = 0;
    std::array<std::int64_t, 3> pair_sum{}, faces{};
  };
  std::map<std::pair<std::uint32_t, std::uint32_t>, Ref> ref;
  for (long z = 0; z < static_cast<long>(s[0]); ++z)
    for (long y = 0; y < static_cast<long>(s[1]); ++y)
      for (long x = 0; x < static_cast<long>(s[2]); ++x)
        for (long dz = -1; dz <= 1; ++dz)
          for (long dy = -1; dy <= 1; ++dy)
            for (long dx = -1; dx <= 1; ++dx) {
              const long qz = z + dz, qy = y + dy, qx = x + dx;
              if (qz < 0 || qy < 0 || qx < 0 || qz >= static_cast<long>(s[0]) || qy >= static_cast<long>(s[1]) ||
                  qx >= static_cast<long>(s[2]))
                continue;
              const std::uint32_t a = v(z, y, x), b = v(qz, qy, qx);
              if (a == 0 || b == 0 || a == b) continue;
              Ref& r = ref[{std::min(a, b), std::max(a, b)}];
              r.side[a < b ? 0 : 1].insert(v.index(z, y, x));
              if (a < b) {  // each unordered pair once, from its lower label
                ++r.pairs;
                r.pair_sum[0] += z + qz, r.pair_sum[1] += y + qy, r.pair_sum[2] += x + qx;
                if (std::abs(dz) + std::abs(dy) + std::abs(dx) == 1) {
                  const int axis = dz ? 0 : dy ? 1 : 2;
                  r.faces[axis] += (dz + dy + dx) > 0 ? 1 : -1;  // low below high along the axis: +1
                }
              }
            }
  ASSERT_GT(ref.size(), 60u);
  omp_set_num_threads(1);
  const auto one = contact_sums(v);
  omp_set_num_threads(2);
  const auto two = contact_sums(v);
  ASSERT_EQ(one.size(), ref.size());
  std::size_t k = 0;
  for (const auto& [key, r] : ref) {
    for (const auto* sums : {&one, &two}) {
      const PairSums& ps = (*sums)[k];
      ASSERT_EQ(ps.low, key.first);
      ASSERT_EQ(ps.high, key.second);
      EXPECT_EQ(ps.voxels[0], r.side[0].size());
      EXPECT_EQ(ps.voxels[1], r.side[1].size());
      EXPECT_EQ(ps.pairs, r.pairs);
      EXPECT_EQ(ps.pair_sum, r.pair_sum);
      EXPECT_EQ(ps.faces, r.faces);
      std::array<std::int64_t, 3> side_sum{};
      for (std::size_t p : r.side[0]) {
        const auto zz = static_cast<std::int64_t>(p / (s[1] * s[2]));
        side_sum[0] += zz, side_sum[1] += static_cast<std::int64_t>((p / s[2]) % s[1]),
            side_sum[2] += static_cast<std::int64_t>(p % s[2]);
      }
      EXPECT_EQ(ps.sum[0], side_sum);
    }
    EXPECT_EQ(one[k].pair_moment, two[k].pair_moment);
    ++k;
  }
}

TEST(ContactsDetect, MissingGrainRowIsADataError) {
  Volume<std::uint32_t> v({4, 4, 8});
  paint(v, {0, 0, 0, 4, 4, 4}, 1);
  paint(v, {0, 0, 4, 4, 4, 8}, 2);
  auto grains = segment::grain_table(v);
  grains.pop_back();
  EXPECT_THROW(find_contacts(v, grains), DataError);
}

TEST(ScanContacts, TheStageIsDetectionThenTheFileContentAndNamesTheLabelsFile) {
  segment::LabelsFile labels;
  labels.labels = Volume<std::uint32_t>({4, 4, 8});
  paint(labels.labels, {0, 0, 0, 4, 4, 4}, 1);
  paint(labels.labels, {0, 0, 4, 4, 4, 8}, 2);
  labels.grains = segment::grain_table(labels.labels);
  const ContactsSettings settings;
  const ScanContacts scan = scan_contacts(labels, nullptr, settings, "l.h5");
  EXPECT_TRUE(scan.fits.empty());
  const ContactsFile direct = contacts_content(find_contacts(labels.labels, labels.grains), {}, labels.grains, settings);
  ASSERT_EQ(scan.content.contacts.size(), 1u);
  EXPECT_EQ(scan.content.contacts.normal, direct.contacts.normal);
  EXPECT_EQ(scan.content.coordination.per_grain, direct.coordination.per_grain);
  ContactsSettings refined = settings;
  refined.refined = true;
  EXPECT_THROW(scan_contacts(labels, nullptr, refined, "l.h5"), UsageError);
  labels.grains.pop_back();
  try {
    scan_contacts(labels, nullptr, settings, "l.h5");
    ADD_FAILURE() << "a grain table without a label's row must be refused";
  } catch (const DataError& e) {
    EXPECT_EQ(e.context(), std::vector<std::string>{"in l.h5; its grain table does not match its label image"});
  }
}

TEST(ContactsFabric, AnisotropyOfTheSpecChecks) {
  EXPECT_NEAR(anisotropy(Eigen::Matrix3d::Identity() / 3.0), 0.0, 1e-15);
  EXPECT_NEAR(anisotropy(Eigen::Vector3d(0.28, 0.28, 0.44).asDiagonal()), 0.5, 1e-12);
}

TEST(ContactsFabric, TensorOfKnownDirectionSets) {
  // The six axis directions: isotropic, a = 0.
  const Fabric iso = fabric_tensor({{1, 0, 0}, {-2, 0, 0}, {0, 3, 0}, {0, -1, 0}, {0, 0, 5}, {0, 0, -1}, {0, 0, 0}});
  EXPECT_EQ(iso.count, 6u) << "the zero vector is skipped, lengths do not matter";
  EXPECT_TRUE(iso.tensor.isApprox(Eigen::Matrix3d::Identity() / 3.0, 1e-14));
  EXPECT_NEAR(iso.anisotropy, 0.0, 1e-14);
  // Four directions at cos^2(theta) = 0.44 around z: phi = diag(0.28, 0.28, 0.44), a = 0.5.
  const double theta = std::acos(std::sqrt(0.44));
  std::vector<Vec3> dirs;
  for (int k = 0; k < 4; ++k) dirs.push_back(direction(theta, k * std::numbers::pi / 2 + 0.3));
  const Fabric f = fabric_tensor(dirs);
  EXPECT_NEAR(f.tensor(0, 0), 0.28, 1e-12);
  EXPECT_NEAR(f.tensor(2, 2), 0.44, 1e-12);
  EXPECT_NEAR(f.tensor(0, 1), 0.0, 1e-12);
  EXPECT_NEAR(f.anisotropy, 0.5, 1e-12);
  EXPECT_NEAR(f.principal_values[0], 0.44, 1e-12);
  EXPECT_NEAR(f.principal_values[2], 0.28, 1e-12);
  EXPECT_NEAR(f.principal_directions(2, 0), 1.0, 1e-12) << "phi_1 along +z";
  // Many random directions, uniform on the sphere: close to isotropic.
  std::mt19937 rng(5);
  std::normal_distribution<double> g;
  std::vector<Vec3> many(200000);
  for (auto& d : many) d = {g(rng), g(rng), g(rng)};
  const Fabric r = fabric_tensor(many);
  EXPECT_NEAR(r.anisotropy, 0.0, 0.02);
  EXPECT_NEAR(r.principal_values[0], 1.0 / 3.0, 0.005);
  EXPECT_EQ(fabric_tensor({}).count, 0u);
  EXPECT_TRUE(std::isnan(fabric_tensor({}).anisotropy));
}

TEST(ContactsFabric, RoseCountsFoldAxesAndNormaliseByTheSolidAngle) {
  const Rose one = rose({{0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {0.0, -1.0, 1e-9}}, 3, 4);
  ASSERT_EQ(one.counts.size(), 12u);
  EXPECT_EQ(one.counts[0], 2u);            // +z and -z: first polar bin, azimuth 0
  EXPECT_EQ(one.counts[2 * 4 + 0], 1u);    // +x: last polar bin, azimuth bin 0
  EXPECT_EQ(one.counts[2 * 4 + 3], 1u);    // -y (z just above 0): azimuth 270 degrees, last bin
  EXPECT_THROW(rose({}, 0, 4), UsageError);
  // Uniform directions: density 1 / (4 pi) per steradian in every bin, within sampling noise.
  std::mt19937 rng(9);
  std::normal_distribution<double> g;
  std::vector<Vec3> many(400000);
  for (auto& d : many) d = {g(rng), g(rng), g(rng)};
  const Rose r = rose(many, 6, 12);
  std::uint64_t total = 0;
  for (std::size_t i = 0; i < r.counts.size(); ++i) {
    total += r.counts[i];
    EXPECT_NEAR(r.density[i] * 4 * std::numbers::pi, 1.0, 0.06) << "bin " << i;
  }
  EXPECT_EQ(total, many.size());
}

TEST(ContactsFabric, CoordinationNumbersSkipGrainsCutByTheEdge) {
  std::vector<segment::GrainRecord> grains(5);
  for (std::uint32_t k = 0; k < 5; ++k) grains[k].label = k + 1;
  grains[3].touches_edge = true;
  std::vector<Contact> cs(4);
  const std::uint32_t pairs[4][2] = {{1, 2}, {1, 3}, {2, 3}, {3, 4}};
  for (int k = 0; k < 4; ++k) cs[k].low = pairs[k][0], cs[k].high = pairs[k][1];
  const Coordination c = coordination(grains, cs);
  EXPECT_EQ(c.per_grain, (std::vector<std::uint32_t>{2, 2, 3, 1, 0}));
  EXPECT_EQ(c.counted, 4u);
  EXPECT_EQ(c.histogram, (std::vector<std::uint64_t>{1, 0, 2, 1}));  // Z = 0 (grain 5), 2, 2, 3
  EXPECT_DOUBLE_EQ(c.mean, 7.0 / 4.0);
  EXPECT_DOUBLE_EQ(coordination(grains, cs, true).mean, 8.0 / 5.0);
  cs[0].high = 9;
  EXPECT_THROW(coordination(grains, cs), DataError);
}

TEST(ContactsNetwork, VerticesAtContactsAndLinesBetweenCentroids) {
  ContactNetwork net;
  net.pairs = {{1, 2}, {2, 5}};
  net.points = {{1, 1, 1}, {2, 2, 2}};
  net.normals = {{0, 0, 1}, {1, 0, 0}};
  net.centroids = {{Vec3{0, 0, 0}, Vec3{0, 0, 2}}, {Vec3{0, 0, 2}, Vec3{4, 0, 2}}};
  net.values = {{"area", {0.5, 0.25}}};
  const io::VtkPolyData d = network_polydata(net);
  EXPECT_EQ(d.point_count(), 5u);  // 2 contact points and 3 grain centroids
  EXPECT_EQ(d.vert_offsets.size(), 2u);
  EXPECT_EQ(d.line_offsets.size(), 2u);
  EXPECT_EQ(d.line_connectivity, (std::vector<std::int64_t>{2, 3, 3, 4}));  // labels 1, 2, 5 in order
  ASSERT_EQ(d.cell_data.size(), 4u);
  EXPECT_EQ(d.cell_data[0].name, "pair");
  EXPECT_EQ(d.cell_data[0].values, (std::vector<double>{1, 2, 2, 5, 1, 2, 2, 5}));
  EXPECT_EQ(d.cell_data[3].values, (std::vector<double>{0.5, 0.25, 0.5, 0.25}));
  EXPECT_EQ(d.point_data[1].values, (std::vector<double>{0, 0, 1, 2, 5}));  // labels at centroids
  net.values[0].second.pop_back();
  EXPECT_THROW(network_polydata(net), UsageError);
}

namespace {

/// Two spheres of `diameter` voxels along a random direction, `gap` voxels apart, scanned by the
/// spam protocol (grey 0.25 / 0.75, blur 0.8 voxel, noise 0.03 = 6 % of the contrast), thresholded
/// at 0.5 and split by the marker watershed of the EDT, as ct2labels does.
struct PairScan {
  Volume<float> grey;
  Volume<std::uint32_t> labels;
  std::vector<segment::GrainRecord> grains;
  Vec3 normal;  ///< true normal (x, y, z), up to its sign
};

PairScan scan_pair(double diameter, double gap, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> jitter(-0.5, 0.5);
  Eigen::Vector3d dir(g(rng), g(rng), g(rng));  // (z, y, x)
  dir.normalize();
  const double r = diameter / 2;
  const auto n = static_cast<std::size_t>(std::ceil(2 * diameter + gap + 8));
  const Eigen::Vector3d c(n / 2.0 + jitter(rng), n / 2.0 + jitter(rng), n / 2.0 + jitter(rng));
  const Eigen::Vector3d a = c - dir * (r + gap / 2), b = c + dir * (r + gap / 2);
  PairScan p;
  p.grey = test::scan_balls({n, n, n}, {{a[0], a[1], a[2], r}, {b[0], b[1], b[2], r}}, seed, 0.03);
  const auto edt = segment::distance_transform(segment::binarise(p.grey, 0.5));
  p.labels = segment::watershed(edt, segment::h_maxima_markers(edt, 1.0));
  p.grains = segment::grain_table(p.labels);
  p.normal = {dir[2], dir[1], dir[0]};
  return p;
}

struct NormalStats {
  double pca = 0, refined = 0, gap = 0, gap_abs_max = 0;
  int fitted = 0, cases = 0;
  double min_confidence = 1.0;
};

NormalStats normal_errors(double diameter, int cases) {
  NormalStats s;
  for (int k = 0; k < cases; ++k) {
    const PairScan p = scan_pair(diameter, 0.0, 100 + k);
    const auto cs = find_contacts(p.labels, p.grains);
    if (p.grains.size() != 2 || cs.size() != 1) continue;  // the watershed did not give two grains
    const auto fits = refine_contacts(p.grey, p.labels, cs, p.grains);
    ++s.cases;
    s.pca += angle_deg(cs[0].normal, p.normal);
    if (!fits[0].ok()) continue;
    ++s.fitted;
    s.refined += angle_deg(fits[0].normal, p.normal);
    const double gap_vox = fits[0].gap / p.labels.voxel_size()[0];
    s.gap += gap_vox;
    s.gap_abs_max = std::max(s.gap_abs_max, std::abs(gap_vox));
    s.min_confidence = std::min(s.min_confidence, fits[0].confidence);
    // The refined normal points from low to high like the PCA one.
    EXPECT_GT(fits[0].normal[0] * cs[0].normal[0] + fits[0].normal[1] * cs[0].normal[1] + fits[0].normal[2] * cs[0].normal[2], 0.0);
  }
  s.pca /= s.cases;
  s.refined /= s.fitted;
  s.gap /= s.fitted;
  return s;
}

/// Every pair fitted, mean error within `target_deg` and under half the PCA error, fitted gaps near
/// zero, every contact confident.
void expect_refined_normals(double diameter, int cases, double target_deg) {
  const NormalStats s = normal_errors(diameter, cases);
  ASSERT_GE(s.cases, cases * 3 / 4) << "the watershed should split most pairs in two";
  EXPECT_EQ(s.fitted, s.cases);
  EXPECT_LE(s.refined, target_deg) << "PCA " << s.pca;
  EXPECT_LT(s.refined, 0.5 * s.pca);
  EXPECT_NEAR(s.gap, 0.0, 0.1) << "mean fitted gap in voxels";
  EXPECT_LT(s.gap_abs_max, 0.25);
  EXPECT_GE(s.min_confidence, 0.5);
}

}  // namespace

TEST(ContactsRefine, NormalsOfTouchingSpheresAt8VoxelsPerDiameter) {
  expect_refined_normals(8.0, 16, 4.0);  // the target; plain PCA about 13, spam's random walker 4.6
}

TEST(ContactsRefine, NormalsOfTouchingSpheresAt20VoxelsPerDiameter) {
  expect_refined_normals(20.0, 10, 1.5);  // the target; plain PCA about 5, spam's random walker 1.9
}

TEST(ContactsRefine, SpheresAVoxelApartThatTheThresholdMergesGetLowConfidence) {
  // At 16 voxels per diameter a global threshold merges most pairs 1 voxel apart (the partial-
  // volume effect); the fitted gap finds the separation.
  int merged = 0;
  for (int k = 0; k < 10; ++k) {
    const PairScan p = scan_pair(16.0, 1.0, 300 + k);
    const auto cs = find_contacts(p.labels, p.grains);
    if (cs.size() != 1) continue;
    ++merged;
    const Refinement f = refine_contacts(p.grey, p.labels, cs, p.grains)[0];
    ASSERT_TRUE(f.ok());
    EXPECT_NEAR(f.gap / p.labels.voxel_size()[0], 1.0, 0.3);
    EXPECT_LT(f.confidence, 0.1);
  }
  EXPECT_GE(merged, 3);
}

TEST(ContactsRefine, FailsCleanlyWithoutGreyContrastAndChecksShapes) {
  const PairScan p = scan_pair(12.0, 0.0, 7);
  const auto cs = find_contacts(p.labels, p.grains);
  ASSERT_EQ(cs.size(), 1u);
  Volume<float> flat(p.grey.shape(), p.grey.voxel_size(), p.grey.origin(), 0.5f);
  const Refinement f = refine_contacts(flat, p.labels, cs, p.grains)[0];
  EXPECT_FALSE(f.ok());
  EXPECT_TRUE(std::isnan(f.confidence));
  EXPECT_TRUE(std::isnan(f.normal[0]));
  Volume<float> other({3, 3, 3});
  EXPECT_THROW(refine_contacts(other, p.labels, cs, p.grains), UsageError);
}

TEST(ContactsRefine, GreyVolumeWithoutContrastOrWithNaNIsRefused) {
  const auto message = [](const AnyVolume& v) {
    try {
      check_grey_for_refinement(v, "scan.h5");
    } catch (const DataError& e) {
      return e.message();
    }
    return std::string();
  };
  Volume<std::uint16_t> flat({6, 6, 6});
  for (auto& g : flat.values()) g = 1200;
  EXPECT_EQ(message(flat).rfind("scan.h5 holds the grey value 1200 in every voxel, so there is no contrast", 0), 0u) << message(flat);
  Volume<float> nan({6, 6, 6});
  nan(1, 2, 3) = 1.0f;
  nan(2, 2, 2) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(message(nan).rfind("scan.h5 holds 1 NaN or infinite voxels", 0), 0u) << message(nan);
  Volume<std::uint8_t> grey({6, 6, 6});
  grey(3, 3, 3) = 1;
  EXPECT_EQ(message(grey), "");
}

TEST(ContactsRefine, FailedFitsAreCountedAsUnknownNotAsConfident) {
  std::vector<Refinement> fits(5);  // default: not fitted, confidence NaN
  fits[0].confidence = 0.9;
  fits[1].confidence = 0.5;
  fits[2].confidence = 0.1;
  const ConfidenceCount c = count_confidences(fits, 0.5);
  EXPECT_EQ(c.at_least, 2u);
  EXPECT_EQ(c.below, 1u);
  EXPECT_EQ(c.unknown, 2u);
  const ConfidenceCount none = count_confidences(std::vector<Refinement>(3), 0.5);
  EXPECT_EQ(none.at_least, 0u) << "NaN is not >= 0.5";
  EXPECT_EQ(none.unknown, 3u);
}
