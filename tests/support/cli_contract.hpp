#pragma once
// The CLI contract every tool keeps (docs/conventions.md): help exits 0 and shows the standard
// options, a bad option exits 2, --version names the tool. Each tool test instantiates it.
#include <gtest/gtest.h>

#include "support/run_tool.hpp"

namespace graintwin::test {

/// `config` is the name of the configuration option: "--config", or a positional such as ctsynth's "scene".
inline void expect_standard_cli(const std::string& tool, const std::string& config = "--config") {
  const ToolResult help = run_tool(tool, {"--help"});
  EXPECT_EQ(help.exit_code, 0) << help.err;
  for (const std::string& opt : {std::string("--help"), std::string("--version"), std::string("--quiet"),
                                 std::string("--verbose"), std::string("--force"), std::string("--threads"),
                                 std::string("Examples:"), config})
    EXPECT_NE(help.out.find(opt), std::string::npos) << tool << " --help lacks " << opt;
  const ToolResult bad = run_tool(tool, {"--no-such-option"});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_FALSE(bad.err.empty());
  const ToolResult ver = run_tool(tool, {"--version"});
  EXPECT_EQ(ver.exit_code, 0);
  EXPECT_NE(ver.out.find(tool), std::string::npos);
  const ToolResult none = run_tool(tool, {});
  EXPECT_EQ(none.exit_code, 2) << "missing positional arguments must be a usage error";
}

/// Runs `tool` expecting failure: checks the exit code, that stderr holds `words` (e.g. the file
/// name and the fix), and that nothing new appeared in `dir` (no half-written output).
inline void expect_clean_failure(const std::string& tool, const TempDir& dir, const std::vector<std::string>& args,
                                 int code, const std::string& words) {
  const auto before = list_dir(dir.path());
  const ToolResult r = run_tool(tool, args);
  EXPECT_EQ(r.exit_code, code) << r.err;
  EXPECT_NE(r.err.find(words), std::string::npos) << r.err;
  EXPECT_EQ(list_dir(dir.path()), before) << "a failing run left files behind";
}

/// The option contract's refusal: `tool` with `args` and then `options` exits 2 saying `words`
/// (the option, its range, the value) and leaves nothing new in `dir`.
inline void expect_option_refused(const std::string& tool, const TempDir& dir, std::vector<std::string> args,
                                  const std::vector<std::string>& options, const std::string& words) {
  args.insert(args.end(), options.begin(), options.end());
  expect_clean_failure(tool, dir, args, 2, words);
}

}  // namespace graintwin::test
