// Fuzz target: fdemrun scene files (fdem/scene.cpp), byte level TOML. A scene's [model] file =
// "model.h5" finds a valid model file beside it (tests/fuzz/base/model.h5).
#include <filesystem>

#include "fuzz_support.hpp"
#include "graintwin/fdem/scene.hpp"

GRAINTWIN_FUZZ_TARGET(scene) {
  static const bool model_beside = [] {
    std::filesystem::copy_file(graintwin::fuzz::base_file("model.h5"), graintwin::fuzz::scratch_dir() / "model.h5",
                               std::filesystem::copy_options::overwrite_existing);
    return true;
  }();
  (void)model_beside;
  const auto path = graintwin::fuzz::write_scratch("scene.toml", data, size);
  graintwin::fuzz::expect_clean("read_scene", [&] { graintwin::fdem::read_scene(path); });
}
