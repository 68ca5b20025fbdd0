// mpi/session on 1, 2, 3 and 4 ranks (ctest runs this program through mpirun, label `mpi`): grains
// owned by the ranks of fdem/decomposition's subdomains are summed exactly on each rank and the
// ranks' sums added, and every rank count must give the bits of one rank's exact sum.
#include "graintwin/mpi/session.hpp"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdio>
#include <random>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/decomposition.hpp"

using namespace graintwin;

namespace {

const mpi::Session* g_session = nullptr;

constexpr std::size_t kGrains = 2000;

// Every rank builds the same scene: centroids in a 4 x 4 x 8 mm box and per-grain values whose
// magnitudes span 16 decades with both signs, so that the order of a sum changes its bits.
struct Scene {
  std::vector<Eigen::Vector3d> centroids;
  std::vector<double> radii, work, values;  // values: 3 per grain (a force)
};

Scene make_scene() {
  std::mt19937_64 rng(2026);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Scene s;
  for (std::size_t i = 0; i < kGrains; ++i) {
    s.centroids.emplace_back(4e-3 * unit(rng), 4e-3 * unit(rng), 8e-3 * unit(rng));
    s.radii.push_back(0.1e-3);
    s.work.push_back(1.0 + unit(rng));
    for (int c = 0; c < 3; ++c) s.values.push_back((unit(rng) < 0.5 ? -1 : 1) * std::pow(10.0, 16 * unit(rng) - 8));
  }
  return s;
}

// This rank's share: the grains whose centroid its subdomain holds, and their values.
struct Share {
  std::vector<std::uint32_t> grains;
  std::vector<double> values;
};

Share owned_share(const Scene& s, int rank, int ranks) {
  const fdem::Aabb box{Eigen::Vector3d::Zero(), Eigen::Vector3d(4e-3, 4e-3, 8e-3)};
  const fdem::Subdomains subdomains = fdem::bisect_domain(s.centroids, s.radii, s.work, box, ranks, 0.02e-3);
  Share share;
  for (std::uint32_t g = 0; g < kGrains; ++g)
    if (fdem::owner_rank(subdomains, s.centroids[g]) == rank) {
      share.grains.push_back(g);
      share.values.insert(share.values.end(), s.values.begin() + 3 * g, s.values.begin() + 3 * g + 3);
    }
  return share;
}

// A plain loop over the grains in index order.
std::vector<double> serial_sum(const Scene& s) {
  std::vector<double> sum(3, 0.0);
  for (std::uint32_t g = 0; g < kGrains; ++g)
    for (int c = 0; c < 3; ++c) sum[c] += s.values[3 * g + c];
  return sum;
}

std::vector<std::uint64_t> bits(const std::vector<double>& v) {
  std::vector<std::uint64_t> b;
  for (double x : v) b.push_back(std::bit_cast<std::uint64_t>(x));
  return b;
}

std::vector<double> backwards_sum(const Scene& s) {
  std::vector<double> sum(3, 0.0);
  for (std::size_t g = kGrains; g-- > 0;)
    for (int c = 0; c < 3; ++c) sum[c] += s.values[3 * g + c];
  return sum;
}

bool platen_grains(std::uint32_t g) { return g % 7 == 3; }  // a sparse few, as those touching a platen

}  // namespace

TEST(MpiSession, RanksAreNumberedFromZero) {
  EXPECT_GE(g_session->rank(), 0);
  EXPECT_LT(g_session->rank(), g_session->size());
  EXPECT_EQ(mpi::sum_over_ranks(*g_session, 1), static_cast<std::uint64_t>(g_session->size()));
  EXPECT_EQ(g_session->ranks_on_this_machine(), g_session->size()) << "ctest starts every rank on this machine";
}

TEST(MpiSession, EveryGrainHasExactlyOneOwner) {
  const Scene s = make_scene();
  const Share share = owned_share(s, g_session->rank(), g_session->size());
  EXPECT_EQ(mpi::sum_over_ranks(*g_session, share.grains.size()), kGrains);
  if (g_session->size() > 1) {
    EXPECT_LT(share.grains.size(), kGrains) << "each rank owns a part";
  }
}

TEST(MpiSession, ExactSumsAddedOverTheRanksHaveTheOneRankBitsOnAnyRankCount) {
  // Each rank adds the forces of the grains its box owns, in the order it lists them (reversed
  // here); the ranks' accumulators added word by word round to the one-rank sum's bits.
  const Scene s = make_scene();
  std::vector<ExactSum> expected(3);
  for (std::uint32_t g = 0; g < kGrains; ++g)
    for (int c = 0; c < 3; ++c) expected[c].add(s.values[3 * g + c]);
  // The data are order-sensitive: a plain sum forwards and backwards gives other bits.
  EXPECT_NE(bits(serial_sum(s)), bits(backwards_sum(s)));

  const Share share = owned_share(s, g_session->rank(), g_session->size());
  std::vector<ExactSum> mine(3), few(3);
  for (std::size_t i = share.grains.size(); i-- > 0;)
    for (int c = 0; c < 3; ++c) {
      mine[c].add(share.values[3 * i + c]);
      if (platen_grains(share.grains[i])) few[c].add(share.values[3 * i + c]);
    }
  std::vector<ExactSum*> sums;
  for (ExactSum& e : mine) sums.push_back(&e);
  for (ExactSum& e : few) sums.push_back(&e);
  double largest = g_session->rank();
  mpi::sum_over_ranks(*g_session, sums, largest);
  EXPECT_EQ(largest, g_session->size() - 1.0) << "the largest value rides with the sums";
  std::vector<ExactSum> few_expected(3);
  for (std::uint32_t g = 0; g < kGrains; ++g)
    if (platen_grains(g))
      for (int c = 0; c < 3; ++c) few_expected[c].add(s.values[3 * g + c]);
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(std::bit_cast<std::uint64_t>(mine[c].value()), std::bit_cast<std::uint64_t>(expected[c].value()))
        << "rank " << g_session->rank() << " of " << g_session->size();
    EXPECT_EQ(std::bit_cast<std::uint64_t>(few[c].value()), std::bit_cast<std::uint64_t>(few_expected[c].value()));
  }
}

namespace {

// `--throw-on-last-rank`: the last rank leaves by an exception, caught above its session, while the
// others wait for it in a collective. The session must end the whole job where a plain MPI_Finalize
// would leave the others waiting for ever (ctest's timeout fails that). ctest looks for this
// program's own line, not for MPI's abort message, whose printing races with the abort.
int leave_one_rank_by_exception(int argc, char** argv) {
  try {
    mpi::Session session(argc, argv);
    if (session.rank() == session.size() - 1) {
      std::fprintf(stderr, "rank %d leaves by an exception\n", session.rank());
      std::fflush(stderr);
      throw DataError("a refusal found on one rank alone");
    }
    mpi::sum_over_ranks(session, 1);
  } catch (const Error&) {
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 1 && std::string(argv[1]) == "--throw-on-last-rank") return leave_one_rank_by_exception(argc, argv);
  mpi::Session session(argc, argv);
  g_session = &session;
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
