#pragma once
// Tools as background processes, for tests of what happens around them: their child processes,
// and signals sent while they run (Linux /proc).
#include <fcntl.h>
#include <spawn.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace graintwin::test {

/// Starts build/bin/<tool> with `args` (stdout and stderr to /dev/null) and returns its pid without
/// waiting; the caller reaps it.
inline pid_t spawn_tool(const std::string& tool, const std::vector<std::string>& args) {
  std::vector<std::string> words{(std::filesystem::path(GRAINTWIN_TOOL_DIR) / tool).string()};
  words.insert(words.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& w : words) argv.push_back(w.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&fa, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  if (rc != 0) throw std::runtime_error("cannot start " + words[0]);
  return pid;
}

/// Children of process `pid`'s main thread.
inline std::vector<pid_t> child_pids(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/task/" + std::to_string(pid) + "/children");
  std::vector<pid_t> out;
  for (pid_t c; in >> c;) out.push_back(c);
  return out;
}

/// True once process `pid` has ended: gone, or a zombie (dead, waiting for a parent to reap it;
/// an orphan's new parent may be slow to do so).
inline bool process_ended(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string stat;
  if (!std::getline(in, stat)) return true;
  const std::size_t close = stat.rfind(')');  // the name in parentheses may hold spaces
  const char state = close != std::string::npos && close + 2 < stat.size() ? stat[close + 2] : '?';
  return state == 'Z' || state == 'X';
}

/// Waits up to `limit` for process `pid` to end; true if it did.
inline bool process_ends_within(pid_t pid, std::chrono::milliseconds limit) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (!process_ended(pid)) {
    if (std::chrono::steady_clock::now() >= end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}

}  // namespace graintwin::test
