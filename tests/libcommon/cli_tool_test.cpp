// Positional arguments of the tool wrapper (its own executable: the interrupt test of cli_test
// leaves the process-wide interrupted flag set).
#include <gtest/gtest.h>

#include <fstream>

#include "graintwin/cli/tool.hpp"
#include "support/run_tool.hpp"

using namespace graintwin;

namespace {

/// Runs a tool shaped like `labels2contacts LABELS [VOLUME] OUT` on `args`; returns the exit code
/// and what the body saw (inputs must exist, so they are files in `dir`).
int run_optional_middle(const std::vector<std::string>& args, std::string& volume, std::string& out) {
  cli::Tool tool("t", "test");
  std::filesystem::path l, v, o;
  tool.add_input("labels", l, "labels");
  tool.add_optional_input("volume", v, "grey volume");
  tool.add_output("out", o, "output");
  std::vector<std::string> all{"t"};
  all.insert(all.end(), args.begin(), args.end());
  all.push_back("-q");
  std::vector<char*> argv;
  for (auto& a : all) argv.push_back(a.data());
  return tool.run(static_cast<int>(argv.size()), argv.data(), [&](cli::RunContext&) {
    volume = v.string();
    out = o.string();
  });
}

}  // namespace

TEST(Tool, OptionalInputBeforeTheOutputTakesAnArgumentOnlyWhenOneIsLeft) {
  test::TempDir dir;
  const std::string l = (dir / "l.h5").string(), v = (dir / "v.h5").string(), o = (dir / "o.h5").string();
  std::ofstream(l) << "x";
  std::ofstream(v) << "x";
  std::string volume, out;
  EXPECT_EQ(run_optional_middle({l, o}, volume, out), 0);
  EXPECT_EQ(volume, "");
  EXPECT_EQ(out, o);
  EXPECT_EQ(run_optional_middle({l, v, o}, volume, out), 0);
  EXPECT_EQ(volume, v);
  EXPECT_EQ(out, o);
  EXPECT_EQ(run_optional_middle({l}, volume, out), 2);                              // no output
  EXPECT_EQ(run_optional_middle({l, (dir / "none.h5").string(), o}, volume, out), 2);  // the volume must exist
}
