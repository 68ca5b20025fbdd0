#include "graintwin/core/resources.hpp"

#include <fmt/format.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>

#include "graintwin/core/error.hpp"

namespace graintwin {

namespace {

/// The limit in bytes of this process's cgroup (v2), if it has one.
std::optional<double> cgroup_memory_max() {
  std::string group;
  {
    std::ifstream self("/proc/self/cgroup");
    for (std::string line; std::getline(self, line);)
      if (line.rfind("0::", 0) == 0) group = line.substr(3);
  }
  for (const std::string& dir : {std::string("/sys/fs/cgroup") + group, std::string("/sys/fs/cgroup")}) {
    std::ifstream in(dir + "/memory.max");
    std::string value;
    if (!(in >> value)) continue;
    if (value == "max") return std::nullopt;
    try {
      return std::stod(value);
    } catch (const std::exception&) {
      return std::nullopt;
    }
  }
  return std::nullopt;
}

}  // namespace

MemoryLimit memory_limit() {
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
  MemoryLimit m{pages > 0 && page > 0 ? static_cast<double>(pages) * static_cast<double>(page) : HUGE_VAL,
                "this machine's memory"};
  rlimit as{};
  if (getrlimit(RLIMIT_AS, &as) == 0 && as.rlim_cur != RLIM_INFINITY && static_cast<double>(as.rlim_cur) < m.bytes)
    m = {static_cast<double>(as.rlim_cur), "the address-space limit (ulimit -v)"};
  if (const auto cg = cgroup_memory_max(); cg && *cg < m.bytes) m = {*cg, "the cgroup memory limit"};
  return m;
}

std::optional<std::uint64_t> checked_product(std::initializer_list<std::uint64_t> factors) {
  std::uint64_t p = 1;
  for (const std::uint64_t f : factors)
    if (__builtin_mul_overflow(p, f, &p)) return std::nullopt;
  return p;
}

std::string format_bytes(double bytes) {
  if (!std::isfinite(bytes)) return "unbounded memory";
  static const char* units[] = {"B", "kB", "MB", "GB", "TB", "PB", "EB"};
  int k = 0;
  while (bytes >= 1000.0 && k < 6) bytes /= 1000.0, ++k;
  if (bytes >= 1000.0) return fmt::format("{:.2g} {}", bytes, units[k]);  // beyond exabytes: keep it short
  if (bytes >= 10.0 || k == 0) return fmt::format("{:.0f} {}", bytes, units[k]);
  return fmt::format("{:.2g} {}", bytes, units[k]);
}

void check_memory(double bytes, const std::string& who, const std::string& for_what, const std::string& fix,
                  const MemoryLimit& limit) {
  if (bytes <= limit.bytes) return;  // NaN (an estimate gone wrong) is refused too
  throw UsageError(who + " needs about " + format_bytes(bytes) + " for " + for_what + ", more than the " +
                   format_bytes(limit.bytes) + " of " + limit.source + "; " + fix);
}

std::uint64_t volume_bytes(const Shape3& shape, std::uint64_t bytes_per_voxel, const std::string& what) {
  const auto bytes = checked_product({shape[0], shape[1], shape[2], bytes_per_voxel});
  if (!bytes)
    throw UsageError(what + " describes a volume of " +
                     fmt::format("{:.3g}", static_cast<double>(shape[0]) * static_cast<double>(shape[1]) *
                                               static_cast<double>(shape[2])) +
                     " voxels, beyond what a 64-bit size can count; check the sizes");
  return *bytes;
}

void check_kernel_fits(double radius_vox, const Shape3& shape, const std::string& what, const std::string& fix) {
  const double span = 2.0 * std::ceil(radius_vox) + 1.0;
  const double largest = static_cast<double>(std::max({shape[0], shape[1], shape[2]}));
  if (span > largest)
    throw UsageError(what + " spans " + fmt::format("{:.6g}", span) + " voxels, more than the volume (" +
                     std::to_string(shape[0]) + " x " + std::to_string(shape[1]) + " x " + std::to_string(shape[2]) +
                     " voxels, z y x); " + fix);
}

}  // namespace graintwin
