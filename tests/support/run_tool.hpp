#pragma once
// Runs a built tool as a child process and captures its exit code, stdout and stderr, for the
// CLI-contract tests every tool has.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace graintwin::test {

struct ToolResult {
  int exit_code = -1;
  std::string out;  ///< stdout
  std::string err;  ///< stderr
};

/// Runs build/bin/<tool> with `args` (no shell involved).
ToolResult run_tool(const std::string& tool, const std::vector<std::string>& args);
/// Runs build/bin/<tool> under an address-space limit of `bytes` (prlimit --as, as `ulimit -v`
/// would), so that memory checks meet the same limit on every machine.
ToolResult run_tool_with_memory_limit(const std::string& tool, std::uint64_t bytes, const std::vector<std::string>& args);
/// Runs the program `exe` (a path, not looked up in PATH) with `args` the same way.
ToolResult run_program(const std::filesystem::path& exe, const std::vector<std::string>& args);

/// A fresh empty directory under the system temp folder, removed when the object dies.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

/// Files in `dir` (names only, sorted), to check that a failing run left nothing behind.
std::vector<std::string> list_dir(const std::filesystem::path& dir);

}  // namespace graintwin::test
