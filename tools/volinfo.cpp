// volinfo: what a GrainTwin .h5 file holds: kind, schema, datasets, image geometry and value range,
// and the provenance history. --json prints the same on stdout for scripts.
//   volinfo scan.h5
//   volinfo labels.h5 --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["kind"])'
#include <iostream>

#include "graintwin/cli/tool.hpp"
#include "graintwin/io/file_info.hpp"

namespace fs = std::filesystem;
using namespace graintwin;

int main(int argc, char** argv) {
  cli::Tool tool("volinfo",
                 "Describe a GrainTwin HDF5 file: kind, schema version, every dataset with shape, type and "
                 "units, the geometry and value range of image datasets, and the provenance history (how "
                 "the file was made).");
  fs::path input;
  bool as_json = false, no_range = false;
  tool.add_input("file", input, "Any GrainTwin .h5 file");
  tool.cli().add_flag("--json", as_json, "Print JSON on stdout (for scripts) instead of text");
  tool.cli().add_flag("--no-range", no_range, "Skip the value range (it reads every voxel)");
  tool.set_examples({"volinfo scan.h5", "volinfo scan.h5 --json"});

  return tool.run(argc, argv, [&](cli::RunContext& ctx) {
    const nlohmann::json info =
        io::describe_file(input, !no_range, [&](const std::string& step) { return ctx.progress_callback(step); });
    std::cout << (as_json ? info.dump(2) + "\n" : io::describe_text(info));
  });
}
