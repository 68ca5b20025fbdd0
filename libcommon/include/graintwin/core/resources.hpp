#pragma once
// Resource estimates checked before allocation: when a user-controlled size (volume dimensions,
// sample size against voxel size, sample directions, a filter kernel) decides a large allocation
// or a long loop, the tool estimates it first and refuses, with the numbers, what cannot run here,
// instead of crashing, being killed by the kernel, or running for days.
#include <cstdint>
#include <initializer_list>
#include <optional>
#include <string>

#include "graintwin/core/volume.hpp"

namespace graintwin {

/// The memory this process may use, and what sets it.
struct MemoryLimit {
  double bytes = 0.0;
  std::string source;  ///< "this machine's memory", "the address-space limit (ulimit -v)", "the cgroup memory limit"
};
/// The machine's physical memory (sysconf), or less when an address-space limit (ulimit -v) or a
/// cgroup (v2) memory limit is lower.
MemoryLimit memory_limit();

/// a * b * ... exactly, or nothing when the product does not fit in 64 bits.
std::optional<std::uint64_t> checked_product(std::initializer_list<std::uint64_t> factors);

/// Bytes as people read them: "512 B", "3.2 kB", "23 GB", "2.1 TB" (decimal units).
std::string format_bytes(double bytes);

/// Throws UsageError when `bytes` (an estimate; may be astronomically large or infinite) exceed
/// `limit`: "<who> needs about 23 GB for <for_what>, more than this machine's memory (16 GB);
/// <fix>".
void check_memory(double bytes, const std::string& who, const std::string& for_what, const std::string& fix,
                  const MemoryLimit& limit = memory_limit());

/// Bytes of a (nz, ny, nx) volume of `bytes_per_voxel`, checked for overflow: UsageError naming
/// `what` (e.g. "--dims 128,144115188075856997,1") when the voxel count or the bytes exceed 64 bits.
std::uint64_t volume_bytes(const Shape3& shape, std::uint64_t bytes_per_voxel, const std::string& what);

/// A filter of `radius` voxels (a Gaussian's ceil(3 sigma), a fitting window) spans 2 radius + 1
/// voxels; UsageError when that exceeds the volume in every direction, where the result would be
/// the volume's edge values smeared over everything: "<what> spans 121 voxels, more than the
/// volume (40 x 60 x 60 voxels, z y x); <fix>".
void check_kernel_fits(double radius_vox, const Shape3& shape, const std::string& what, const std::string& fix);

}  // namespace graintwin
