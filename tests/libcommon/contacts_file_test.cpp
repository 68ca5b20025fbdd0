// kind=contacts files: the content labels2contacts builds from found and refined contacts (which
// contacts are counted, which normal and point each keeps), the write/read round trip, the
// reader's refusals of damaged tables, and the contact network drawn from the content.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "graintwin/contacts/contacts_file.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"
#include "support/run_tool.hpp"

using namespace graintwin;
using namespace graintwin::contacts;

namespace {

/// Grains 1, 2, 3 on the x axis 1 mm apart (grain 3 touches the volume edge) and grain 4 alone.
std::vector<segment::GrainRecord> four_grains() {
  std::vector<segment::GrainRecord> g(4);
  for (std::uint32_t k = 0; k < 4; ++k) g[k].label = k + 1, g[k].centroid_xyz = {1e-3 * k, 0.0, 0.0};
  g[2].touches_edge = true;
  return g;
}

/// Contacts 1-2 (normal +x), 2-3 (normal +x) and 1-3 (normal +y), with PCA data only.
std::vector<Contact> three_contacts() {
  std::vector<Contact> cs(3);
  const std::uint32_t pairs[3][2] = {{1, 2}, {1, 3}, {2, 3}};
  for (std::size_t k = 0; k < 3; ++k) {
    cs[k].low = pairs[k][0], cs[k].high = pairs[k][1];
    cs[k].voxels_low = 10 + k, cs[k].voxels_high = 20 + k;
    cs[k].normal = k == 1 ? Vec3{0, 1, 0} : Vec3{1, 0, 0};
    cs[k].centroid = {0.5e-3 + 1e-3 * double(k), 0.0, 0.0};
    cs[k].vector_area = {1e-8 * double(k + 1), 0, 0};
    cs[k].area = 1e-8 * double(k + 1);
    cs[k].branch = {1e-3 * double(pairs[k][1] - pairs[k][0]), 0, 0};
  }
  return cs;
}

/// Fits: contact 0 fitted with confidence 0.9 and normal +z, contact 1 fitted with confidence 0.1,
/// contact 2 failed (confidence unknown).
std::vector<Refinement> three_fits() {
  std::vector<Refinement> f(3);
  f[0].status = RefineStatus::fitted, f[0].confidence = 0.9, f[0].normal = {0, 0, 1}, f[0].point = {7e-4, 0, 1e-5};
  f[0].gap = -1e-6, f[0].gap_sd = 2e-7, f[0].radius = {4e-4, 5e-4}, f[0].blur = 3e-5, f[0].rms = 0.05;
  f[1].status = RefineStatus::fitted, f[1].confidence = 0.1, f[1].normal = {0, 1, 0}, f[1].point = {1.5e-3, 0, 0};
  f[2].status = RefineStatus::not_converged;
  return f;
}

ContactsSettings refined_settings() {
  ContactsSettings s;
  s.refined = true;
  s.min_confidence = 0.5;
  s.theta_bins = 3, s.phi_bins = 4;
  return s;
}

bool same(double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

template <class V>
void expect_same_doubles(const V& a, const V& b, const char* what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  for (std::size_t k = 0; k < a.size(); ++k) EXPECT_TRUE(same(a[k], b[k])) << what << "[" << k << "]: " << a[k] << " vs " << b[k];
}

void expect_same_vec3(const std::vector<Vec3>& a, const std::vector<Vec3>& b, const char* what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  for (std::size_t k = 0; k < a.size(); ++k) expect_same_doubles(a[k], b[k], what);
}

}  // namespace

TEST(ContactsFile, ConfidentAndUnknownContactsAreCountedLowConfidenceOnesAreNot) {
  const ContactsFile c = contacts_content(three_contacts(), three_fits(), four_grains(), refined_settings());
  const ContactTable& t = c.contacts;
  ASSERT_EQ(t.size(), 3u);
  EXPECT_EQ(t.accepted, (std::vector<std::uint8_t>{1, 0, 1}));
  EXPECT_EQ(accepted_count(c), 2u);
  EXPECT_EQ(t.fit_status, (std::vector<std::uint8_t>{0, 0, 2}));  // fitted, fitted, not_converged (RefineStatus order)
  // The refined normal and point where the fit succeeded, the PCA normal and centroid elsewhere.
  EXPECT_EQ(t.normal[0], (Vec3{0, 0, 1}));
  EXPECT_EQ(t.point[0], (Vec3{7e-4, 0, 1e-5}));
  EXPECT_EQ(t.normal_pca[0], (Vec3{1, 0, 0}));
  EXPECT_EQ(t.normal[2], (Vec3{1, 0, 0}));
  EXPECT_EQ(t.point[2], (Vec3{2.5e-3, 0, 0}));
  EXPECT_EQ(t.pair, (std::vector<std::uint32_t>{1, 2, 1, 3, 2, 3}));
  EXPECT_EQ(t.voxels, (std::vector<std::uint64_t>{10, 20, 11, 21, 12, 22}));
  EXPECT_EQ(t.radius[0], 4e-4);
  EXPECT_EQ(t.radius[1], 5e-4);
  EXPECT_EQ(t.gap[0], -1e-6);
  EXPECT_TRUE(std::isnan(t.confidence[2]));
  // Z from the counted contacts 1-2 and 2-3: grain 3 touches the edge, so grains 1, 2 and 4 are counted.
  EXPECT_EQ(c.coordination.per_grain, (std::vector<std::uint32_t>{1, 2, 1, 0}));
  EXPECT_EQ(c.coordination.histogram, (std::vector<std::uint64_t>{1, 1, 1}));
  EXPECT_DOUBLE_EQ(c.coordination.mean, 1.0);
  EXPECT_EQ(c.grain_label, (std::vector<std::uint32_t>{1, 2, 3, 4}));
  EXPECT_EQ(c.grain_touches_edge, (std::vector<std::uint8_t>{0, 0, 1, 0}));
  // The fabric of the counted normals +z and +x: phi = diag(1/2, 0, 1/2); branches both +x.
  EXPECT_EQ(c.fabric_normal.count, 2u);
  EXPECT_NEAR(c.fabric_normal.tensor(0, 0), 0.5, 1e-15);
  EXPECT_NEAR(c.fabric_normal.tensor(2, 2), 0.5, 1e-15);
  EXPECT_NEAR(c.fabric_branch.tensor(0, 0), 1.0, 1e-15);
  std::uint64_t rose_total = 0;
  for (std::uint64_t n : c.rose_normal.counts) rose_total += n;
  EXPECT_EQ(rose_total, 2u);
  EXPECT_EQ(c.rose_normal.counts.size(), 12u);
}

TEST(ContactsFile, WithoutRefinementEveryContactKeepsItsPcaDataAndIsCounted) {
  ContactsSettings s;
  s.min_confidence = 0.9;
  const ContactsFile c = contacts_content(three_contacts(), {}, four_grains(), s);
  EXPECT_EQ(c.contacts.fit_status, (std::vector<std::uint8_t>(3, kFitNotAttempted)));
  EXPECT_EQ(c.contacts.accepted, (std::vector<std::uint8_t>(3, 1)));
  EXPECT_EQ(c.contacts.normal, c.contacts.normal_pca);
  EXPECT_EQ(c.contacts.point, c.contacts.centroid);
  EXPECT_EQ(c.fabric_normal.count, 3u);
  // Refined content needs one fit per contact.
  EXPECT_THROW(contacts_content(three_contacts(), {Refinement{}}, four_grains(), refined_settings()), UsageError);
}

TEST(ContactsFile, WhatIsWrittenIsReadBack) {
  test::TempDir dir;
  ContactsSettings s = refined_settings();
  s.min_voxels = 3, s.window_vox = 5.5, s.gap_tolerance_vox = 0.75, s.include_edge_grains = true;
  const ContactsFile c = contacts_content(three_contacts(), three_fits(), four_grains(), s);
  write_contacts_file(dir / "c.h5", c, {"a history line"});
  const ContactsFile r = read_contacts_file(dir / "c.h5");
  const ContactTable &a = c.contacts, &b = r.contacts;
  EXPECT_EQ(b.pair, a.pair);
  EXPECT_EQ(b.voxels, a.voxels);
  expect_same_vec3(b.normal, a.normal, "normal");
  expect_same_vec3(b.normal_pca, a.normal_pca, "normal_pca");
  expect_same_vec3(b.vector_area, a.vector_area, "vector_area");
  expect_same_vec3(b.centroid, a.centroid, "centroid");
  expect_same_vec3(b.point, a.point, "point");
  expect_same_vec3(b.branch, a.branch, "branch");
  for (auto [x, y, name] : {std::tuple{&a.area, &b.area, "area"}, {&a.confidence, &b.confidence, "confidence"},
                            {&a.gap, &b.gap, "gap"}, {&a.gap_sd, &b.gap_sd, "gap_sd"}, {&a.radius, &b.radius, "radius"},
                            {&a.blur, &b.blur, "blur"}, {&a.fit_rms, &b.fit_rms, "fit_rms"}})
    expect_same_doubles(*y, *x, name);
  EXPECT_EQ(b.fit_status, a.fit_status);
  EXPECT_EQ(b.accepted, a.accepted);
  EXPECT_EQ(r.grain_label, c.grain_label);
  EXPECT_EQ(r.grain_touches_edge, c.grain_touches_edge);
  EXPECT_EQ(r.coordination.per_grain, c.coordination.per_grain);
  EXPECT_EQ(r.coordination.histogram, c.coordination.histogram);
  EXPECT_EQ(r.coordination.mean, c.coordination.mean);
  EXPECT_EQ(r.coordination.counted, c.coordination.counted);
  for (auto [x, y] : {std::pair{&c.fabric_normal, &r.fabric_normal}, {&c.fabric_branch, &r.fabric_branch}}) {
    EXPECT_EQ(y->count, x->count);
    EXPECT_EQ(y->tensor, x->tensor);
    EXPECT_EQ(y->principal_values, x->principal_values);
    EXPECT_EQ(y->principal_directions, x->principal_directions);
    EXPECT_EQ(y->anisotropy, x->anisotropy);
  }
  for (auto [x, y] : {std::pair{&c.rose_normal, &r.rose_normal}, {&c.rose_branch, &r.rose_branch}}) {
    EXPECT_EQ(y->theta_edges, x->theta_edges);
    EXPECT_EQ(y->phi_edges, x->phi_edges);
    EXPECT_EQ(y->counts, x->counts);
    EXPECT_EQ(y->density, x->density);
  }
  EXPECT_EQ(r.settings.min_voxels, 3u);
  EXPECT_TRUE(r.settings.refined);
  EXPECT_EQ(r.settings.window_vox, 5.5);
  EXPECT_EQ(r.settings.gap_tolerance_vox, 0.75);
  EXPECT_EQ(r.settings.min_confidence, 0.5);
  EXPECT_TRUE(r.settings.include_edge_grains);
  EXPECT_EQ(r.settings.theta_bins, 3);
  EXPECT_EQ(r.settings.phi_bins, 4);
  const io::H5File f = io::H5File::open(dir / "c.h5");
  EXPECT_EQ(*f.attr_string(schema::contacts::fit_status, schema::contacts::codes), kFitStatusCodes);
  EXPECT_EQ(*f.attr_string(schema::contacts::normal, schema::attr::units), "1");
  EXPECT_EQ(*f.attr_string(schema::contacts::area, schema::attr::units), "m^2");
}

TEST(ContactsFile, TheReaderRefusesDamagedTablesAndOtherKinds) {
  test::TempDir dir;
  const ContactsFile good = contacts_content(three_contacts(), three_fits(), four_grains(), refined_settings());
  const auto refused = [&](const ContactsFile& c, const char* name, const std::string& says) {
    write_contacts_file(dir / name, c, {});
    try {
      read_contacts_file(dir / name);
      ADD_FAILURE() << name << " was read";
    } catch (const DataError& e) {
      EXPECT_NE(std::string(e.message()).find(says), std::string::npos) << e.message();
      EXPECT_NE(std::string(e.message()).find("labels2contacts"), std::string::npos) << e.message();
    }
  };
  ContactsFile c = good;
  c.contacts.area.push_back(1e-8);  // a column one row longer than the others
  refused(c, "long.h5", "area");
  c = good;
  c.contacts.normal[1][2] = std::nan("");  // the geometry is always measured
  refused(c, "nan.h5", "normal");
  c = good;
  c.contacts.gap[1] = INFINITY;  // NaN is "not measured" in the fit columns, infinity is nothing
  refused(c, "inf.h5", "gap");
  c = good;
  c.coordination.per_grain.pop_back();  // a grain without its coordination number
  refused(c, "grains.h5", "/grains");
  // NaN in a fit column is "not measured" and reads back.
  c = good;
  c.contacts.gap[0] = std::nan("");
  write_contacts_file(dir / "nan_gap.h5", c, {});
  EXPECT_TRUE(std::isnan(read_contacts_file(dir / "nan_gap.h5").contacts.gap[0]));
  // Another kind is a usage error naming the tool that writes contacts.
  {
    io::H5File f = io::H5File::create(dir / "labels.h5");
    io::write_root_attrs(f, schema::kind::labels);
  }
  try {
    read_contacts_file(dir / "labels.h5");
    ADD_FAILURE() << "a labels file was read as contacts";
  } catch (const UsageError& e) {
    EXPECT_NE(std::string(e.message()).find("labels2contacts"), std::string::npos) << e.message();
  }
}

TEST(ContactsFile, TheNetworkJoinsTheCentroidsOfEachContactsGrains) {
  const auto grains = four_grains();
  const ContactsFile c = contacts_content(three_contacts(), three_fits(), grains, refined_settings());
  const ContactNetwork net = contact_network(c, grains);
  ASSERT_EQ(net.pairs.size(), 3u);
  EXPECT_EQ(net.pairs[1], (std::array<std::uint32_t, 2>{1, 3}));
  EXPECT_EQ(net.centroids[1][0], grains[0].centroid_xyz);
  EXPECT_EQ(net.centroids[1][1], grains[2].centroid_xyz);
  EXPECT_EQ(net.points, c.contacts.point);
  EXPECT_EQ(net.normals, c.contacts.normal);
  ASSERT_EQ(net.values.size(), 4u);
  EXPECT_EQ(net.values[3].first, "accepted");
  EXPECT_EQ(net.values[3].second, (std::vector<double>{1, 0, 1}));
  // A contact whose grain is not in the table cannot be drawn.
  std::vector<segment::GrainRecord> fewer(grains.begin(), grains.begin() + 2);
  EXPECT_THROW(contact_network(c, fewer), DataError);
}
