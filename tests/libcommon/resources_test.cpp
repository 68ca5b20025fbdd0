// Resource estimates: overflow-checked sizes, the memory limit, refusals with the numbers, and
// filter kernels larger than the volume.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "graintwin/core/error.hpp"
#include "graintwin/core/resources.hpp"

using namespace graintwin;

TEST(Resources, CheckedProductCatchesOverflow) {
  EXPECT_EQ(checked_product({128, 144, 1, 2}).value_or(0), 36864u);
  EXPECT_FALSE(checked_product({128, 144115188075856997ull, 1}))
      << "the product wraps round to 143360 in 64 bits: it must be refused, not used";
  EXPECT_FALSE(checked_product({1ull << 32, 1ull << 32}));
  EXPECT_EQ(checked_product({}).value_or(0), 1u);
}

TEST(Resources, VolumeBytesRefusesSizesBeyond64Bits) {
  EXPECT_EQ(volume_bytes({40, 60, 60}, 2, "--dims 40,60,60"), 288000u);
  try {
    volume_bytes({128, 144115188075856997ull, 1}, 2, "--dims 128,144115188075856997,1");
    FAIL();
  } catch (const UsageError& e) {
    EXPECT_EQ(e.message(), "--dims 128,144115188075856997,1 describes a volume of 1.84e+19 voxels, beyond what a "
                           "64-bit size can count; check the sizes");
  }
}

TEST(Resources, MemoryLimitIsThePhysicalMemoryOrLess) {
  const MemoryLimit m = memory_limit();
  EXPECT_GT(m.bytes, 64e6) << m.source;
  EXPECT_TRUE(std::isfinite(m.bytes));
  EXPECT_FALSE(m.source.empty());
}

TEST(Resources, FormatsBytesReadably) {
  EXPECT_EQ(format_bytes(512), "512 B");
  EXPECT_EQ(format_bytes(3.2e3), "3.2 kB");
  EXPECT_EQ(format_bytes(512e6), "512 MB");
  EXPECT_EQ(format_bytes(22.9e9), "23 GB");
  EXPECT_EQ(format_bytes(2.13e12), "2.1 TB");
  EXPECT_EQ(format_bytes(1e300), "1e+282 EB");
  EXPECT_EQ(format_bytes(std::numeric_limits<double>::infinity()), "unbounded memory");
}

TEST(Resources, CheckMemoryRefusesWithTheNumbersAndTheFix) {
  const MemoryLimit machine{24e9, "this machine's memory"};
  EXPECT_NO_THROW(check_memory(1e9, "tool", "x", "fix", machine));
  EXPECT_NO_THROW(check_memory(24e9, "tool", "x", "fix", machine));
  try {
    check_memory(23e12, "labels2shapes", "1e+09 sample directions x 256 SH coefficients", "give --directions of at most 1e+06",
                 machine);
    FAIL();
  } catch (const UsageError& e) {
    EXPECT_EQ(e.message(), "labels2shapes needs about 23 TB for 1e+09 sample directions x 256 SH coefficients, more than "
                           "the 24 GB of this machine's memory; give --directions of at most 1e+06");
  }
  EXPECT_THROW(check_memory(std::numeric_limits<double>::quiet_NaN(), "t", "x", "f", machine), UsageError)
      << "an estimate that went NaN must not pass";
  EXPECT_THROW(check_memory(std::numeric_limits<double>::infinity(), "t", "x", "f", machine), UsageError);
}

TEST(Resources, KernelLargerThanTheVolumeIsRefused) {
  EXPECT_NO_THROW(check_kernel_fits(29, {40, 60, 60}, "--sigma-vox 9.6", "fix"));  // 59 voxels
  EXPECT_NO_THROW(check_kernel_fits(3, {1, 1, 7}, "w", "fix")) << "a thin volume is fine when the kernel fits along one axis";
  try {
    check_kernel_fits(60, {40, 60, 60}, "--sigma-vox 20", "give a smaller sigma");
    FAIL();
  } catch (const UsageError& e) {
    EXPECT_EQ(e.message(), "--sigma-vox 20 spans 121 voxels, more than the volume (40 x 60 x 60 voxels, z y x); give a smaller sigma");
  }
  EXPECT_THROW(check_kernel_fits(1e6, {40, 60, 60}, "w", "f"), UsageError);
}
