#include "support/vtk_summary.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

namespace graintwin::test {

nlohmann::json vtk_summary(const std::filesystem::path& file) {
  const std::string cmd = std::string("/usr/bin/python3 ") + GRAINTWIN_SOURCE_DIR + "/tests/scripts/vtk_summary.py '" +
                          file.string() + "' 2>&1";
  std::string out;
  if (FILE* p = popen(cmd.c_str(), "r")) {
    char buf[4096];
    while (std::size_t n = std::fread(buf, 1, sizeof buf, p)) out.append(buf, n);
    EXPECT_EQ(pclose(p), 0) << out;
  }
  const auto j = nlohmann::json::parse(out, nullptr, false);
  EXPECT_FALSE(j.is_discarded()) << "VTK could not read " << file << ": " << out;
  return j;
}

}  // namespace graintwin::test
