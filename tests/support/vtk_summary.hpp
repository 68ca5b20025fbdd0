#pragma once
// Reads a .vtp/.vtu file with VTK's own reader (tests/scripts/vtk_summary.py, Debian python3-vtk9):
// counts, arrays and bounds as JSON, so tests prove ParaView can open what the tools write.
#include <filesystem>

#include <nlohmann/json.hpp>

namespace graintwin::test {

/// {"points", "cells", "bounds", "point_data", "cell_data", and for .vtp "verts", "lines", "polys"};
/// each array entry has "components", "tuples" and "range". Fails the current test if VTK cannot
/// read the file.
nlohmann::json vtk_summary(const std::filesystem::path& file);

}  // namespace graintwin::test
