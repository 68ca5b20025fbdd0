// Positional arguments of the tool wrapper (its own executable: the interrupt test of cli_test
// leaves the process-wide interrupted flag set).
#include <gtest/gtest.h>
#include <omp.h>

#include <csignal>
#include <fstream>
#include <functional>

#include "graintwin/cli/tool.hpp"
#include "graintwin/io/atomic_output.hpp"
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

namespace {

/// Runs a tool named "t" with an output and the options --grain-shape and --downsample on `args`;
/// `body` runs as the tool's body. Returns the exit code; `err` gets what it printed on stderr.
int run_small_tool(const std::vector<std::string>& args, std::string& err,
                   const std::function<void(cli::RunContext&, const std::filesystem::path&)>& body = {}) {
  cli::Tool tool("t", "test");
  std::filesystem::path o;
  std::string shape;
  int downsample = 1;
  tool.add_output("out", o, "output");
  tool.cli().add_option("--grain-shape", shape, "shape");
  tool.cli().add_option("--downsample", downsample, "factor")->check(CLI::Range(1, 8));
  std::vector<std::string> all{"t"};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : all) argv.push_back(a.data());
  testing::internal::CaptureStderr();
  const int rc = tool.run(static_cast<int>(argv.size()), argv.data(), [&](cli::RunContext& ctx) {
    if (body) body(ctx, o);
  });
  err = testing::internal::GetCapturedStderr();
  return rc;
}

/// A body that writes its output and commits it, raising `signal` before or after the commit point.
auto write_and_signal(bool after_commit) {
  return [after_commit](cli::RunContext& ctx, const std::filesystem::path& o) {
    io::AtomicOutput out(o, ctx.force());
    std::ofstream(out.temp_path()) << "whole";
    if (!after_commit) std::raise(SIGINT);
    io::commit_outputs({&out});
    if (after_commit) std::raise(SIGTERM);
  };
}

}  // namespace

TEST(Tool, OptionErrorsNameTheToolAndTheHelp) {
  test::TempDir dir;
  std::string err;
  EXPECT_EQ(run_small_tool({(dir / "o").string(), "--downsample", "9"}, err), 2);
  EXPECT_EQ(err.rfind("t: --downsample", 0), 0u) << err;
  EXPECT_NE(err.find("t: run 't --help' for the options"), std::string::npos) << err;
}

TEST(Tool, AConfigFileWithBrokenSyntaxIsNamedWithItsLine) {
  test::TempDir dir;
  std::ofstream(dir / "bad.toml") << "grain-shape = \"sand\"\ndownsample = \n";
  std::string err;
  EXPECT_EQ(run_small_tool({(dir / "o").string(), "--config", (dir / "bad.toml").string()}, err), 2);
  EXPECT_NE(err.find("bad.toml line 2"), std::string::npos) << err;
  EXPECT_NE(err.find("fix the TOML syntax"), std::string::npos) << err;
  EXPECT_EQ(err.find("not in range"), std::string::npos) << "CLI11's misleading message leaked: " << err;
}

TEST(Tool, AConfigKeyGivenTwiceIsRefusedNotResolvedSilently) {
  test::TempDir dir;
  std::ofstream(dir / "twice.toml") << "downsample = 2\ngrain-shape = \"sand\"\ndownsample = 4\n";
  std::string err;
  bool ran = false;
  EXPECT_EQ(run_small_tool({(dir / "o").string(), "--config", (dir / "twice.toml").string()}, err,
                           [&](cli::RunContext&, const std::filesystem::path&) { ran = true; }),
            2);
  EXPECT_FALSE(ran);
  EXPECT_NE(err.find("twice.toml line 3"), std::string::npos) << err;
  EXPECT_NE(err.find("downsample"), std::string::npos) << err;
}

TEST(Tool, AnUnknownConfigKeyGetsTheClosestOptionName) {
  test::TempDir dir;
  std::ofstream(dir / "typo.toml") << "grain-shpae = \"sand\"\n";
  std::string err;
  EXPECT_EQ(run_small_tool({(dir / "o").string(), "--config", (dir / "typo.toml").string()}, err), 2);
  EXPECT_NE(err.find("typo.toml: key 'grain-shpae' is not an option of t; did you mean 'grain-shape'?"),
            std::string::npos)
      << err;
  std::ofstream(dir / "far.toml") << "colour = \"blue\"\n";
  EXPECT_EQ(run_small_tool({(dir / "o").string(), "--config", (dir / "far.toml").string()}, err), 2);
  EXPECT_NE(err.find("see t --help for the option names"), std::string::npos) << err;
}

TEST(Tool, AThreadCountBeyondTheCapIsRefused) {
  test::TempDir dir;
  std::string err;
  EXPECT_EQ(run_small_tool({(dir / "o").string(), "--threads", "100000"}, err), 2);
  EXPECT_NE(err.find("--threads"), std::string::npos) << err;
  EXPECT_EQ(run_small_tool({(dir / "o").string(), "--threads", std::to_string(cli::kMaxThreads), "-q"}, err), 0);
}

TEST(Tool, ASignalBeforeTheCommitPointLeavesNoOutputAndSaysSo) {
  test::TempDir dir;
  std::string err;
  EXPECT_EQ(run_small_tool({(dir / "o").string()}, err, write_and_signal(false)), 130);
  EXPECT_NE(err.find("no output was written"), std::string::npos) << err;
  EXPECT_TRUE(test::list_dir(dir.path()).empty());
}

TEST(Tool, ASignalAfterTheCommitPointIsIgnoredAndTheRunSucceeds) {
  test::TempDir dir;
  std::string err;
  EXPECT_EQ(run_small_tool({(dir / "o").string()}, err, write_and_signal(true)), 0) << err;
  EXPECT_EQ(test::list_dir(dir.path()), (std::vector<std::string>{"o"}));
  // The next run listens to signals again.
  EXPECT_EQ(run_small_tool({(dir / "p").string()}, err, write_and_signal(false)), 130);
}

TEST(Tool, AnOutputThatIsAnInputIsRefusedBeforeTheBody) {
  test::TempDir dir;
  const std::string l = (dir / "l.h5").string();
  std::ofstream(l) << "input";
  std::string volume, out;
  EXPECT_EQ(run_optional_middle({l, l, "--force"}, volume, out), 2);
  EXPECT_EQ(out, "") << "the body ran";
}

TEST(Tool, ProcessesSharingTheMachineSplitItsCoresUnlessThreadsAreGiven) {
  // Under mpirun each rank of a machine takes its share of the cores with -j 0 (at least one), and
  // -j still sets a rank's threads whatever the sharing.
  const auto threads = [](int processes, const std::vector<std::string>& extra) {
    cli::Tool tool("t", "test");
    tool.share_cores_with(processes);
    std::vector<std::string> all{"t", "-q"};
    all.insert(all.end(), extra.begin(), extra.end());
    std::vector<char*> argv;
    for (auto& a : all) argv.push_back(a.data());
    int used = -1;
    EXPECT_EQ(tool.run(static_cast<int>(argv.size()), argv.data(), [&](cli::RunContext& ctx) { used = ctx.threads(); }), 0);
    return used;
  };
  const int cores = omp_get_num_procs();
  EXPECT_EQ(threads(1, {}), cores);
  EXPECT_EQ(threads(2, {}), std::max(1, cores / 2));
  EXPECT_EQ(threads(4 * cores, {}), 1) << "more ranks than cores: one thread each";
  EXPECT_EQ(threads(2, {"-j", "3"}), 3);
}
