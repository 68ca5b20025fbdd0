#pragma once
// Scene files for the fdem tests: two boxes without contact in two loading stages, a scene text
// written into a test folder, and a scene edited by replacing one part of its text.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "support/run_tool.hpp"

namespace graintwin::test {

/// Two grains without contact: a tet10 box spinning at 2000 rad/s, a rigid box thrown upward under
/// gravity; a platen moving down in the second stage. Two stages of 20 us each.
inline constexpr const char* kTwoBoxScene = R"(
[run]
gravity = [0, 0, -9.81]
contact = false
frame_interval = 1e-5
series_interval = 2e-6

[[materials]]
name = "glass"
density = 2500
young = 60e9
poisson = 0.2

[[grains]]
size = [1e-3, 1e-3, 0.5e-3]
position = [0, 0, 1e-3]
element_size = 0.5e-3
kind = "tet10"
material = "glass"
angular_velocity = [0, 0, 2000]

[[grains]]
size = [1e-3, 2e-3, 1e-3]
position = [3e-3, 0, 0]
element_size = 1e-3
kind = "rigid"
label = 42
velocity = [0, 0, 1.5]

[[platens]]
name = "top"
point = [0, 0, 5e-3]
normal = [0, 0, -1]

[[stages]]
name = "still"
duration = 2e-5

[[stages]]
name = "press"
duration = 2e-5
platens = { top = [0, 0, -0.5] }
)";

inline std::filesystem::path write_text(const TempDir& dir, const std::string& name, const std::string& text) {
  const auto p = dir / name;
  std::ofstream(p) << text;
  return p;
}

/// `text` with its first `from` replaced by `to` (a test failure when it has none).
inline std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

}  // namespace graintwin::test
