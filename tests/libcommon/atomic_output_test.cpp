// The output contract (io/atomic_output): temporaries put in place at one commit point, all or
// none; --force replaces only what a GrainTwin tool wrote; inputs are never outputs; a refused
// overwrite is decided by the rename; stale temporaries of dead runs are cleared.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <sstream>

#include "graintwin/core/error.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "support/fixtures.hpp"
#include "support/run_tool.hpp"

using namespace graintwin;
using namespace graintwin::io;
namespace fs = std::filesystem;

namespace {

std::string read_text(const fs::path& p) {
  std::stringstream s;
  s << std::ifstream(p).rdbuf();
  return s.str();
}

/// The message of the UsageError `f` throws (fails the test when it throws nothing).
template <class F>
std::string usage_error_of(F&& f) {
  try {
    f();
  } catch (const UsageError& e) {
    return e.message();
  }
  ADD_FAILURE() << "no UsageError";
  return {};
}

/// A folder output written through the contract, holding `file` with `text`.
void write_folder_output(const fs::path& folder, const std::string& file, const std::string& text, bool force) {
  AtomicOutput out(folder, force);
  fs::create_directory(out.temp_path());
  std::ofstream(out.temp_path() / file) << text;
  commit_outputs({&out});
}

/// The PID of a process that has ended (a child that exited and was reaped).
pid_t dead_pid() {
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  int status = 0;
  ::waitpid(child, &status, 0);
  return child;
}

}  // namespace

TEST(AtomicOutput, PutInPlaceAtTheCommitOnly) {
  test::TempDir dir;
  const auto final_path = dir / "out.h5";
  {
    AtomicOutput out(final_path, false);
    std::ofstream(out.temp_path()) << "partial";
    EXPECT_FALSE(fs::exists(final_path));
  }  // not committed: the temporary disappears
  EXPECT_TRUE(test::list_dir(dir.path()).empty());
  {
    AtomicOutput out(final_path, false);
    std::ofstream(out.temp_path()) << "complete";
    commit_outputs({&out});
  }
  EXPECT_EQ(test::list_dir(dir.path()), (std::vector<std::string>{"out.h5"}));
  EXPECT_NE(usage_error_of([&] { AtomicOutput(final_path, false); }).find("use --force"), std::string::npos);
  EXPECT_NO_THROW(AtomicOutput(final_path, true));
}

TEST(AtomicOutput, RefusesAMissingFolder) {
  test::TempDir dir;
  EXPECT_NE(usage_error_of([&] { AtomicOutput(dir / "no" / "such" / "out.h5", false); }).find("create it first"),
            std::string::npos);
}

TEST(AtomicOutput, ForceReplacesAFolderOnlyWhenAToolWroteIt) {
  test::TempDir dir;
  const auto folder = dir / "frames";
  write_folder_output(folder, "old.txt", "old", false);
  EXPECT_TRUE(fs::exists(folder / kOutputFolderMarker));
  write_folder_output(folder, "new.txt", "new", true);
  EXPECT_EQ(test::list_dir(folder), (std::vector<std::string>{kOutputFolderMarker, "new.txt"}));
  EXPECT_TRUE(test::list_dir(dir.path()) == std::vector<std::string>{"frames"}) << "the replaced folder is gone";

  // A user's folder: --force is refused, before and at the commit, and nothing in it is touched.
  const auto user = dir / "mine";
  fs::create_directory(user);
  std::ofstream(user / "thesis.tex") << "years of work";
  EXPECT_NE(usage_error_of([&] { AtomicOutput(user, true); }).find("no GrainTwin tool wrote"), std::string::npos);
  EXPECT_NE(usage_error_of([&] { AtomicOutput(user / "", true); }).find("no GrainTwin tool wrote"), std::string::npos);
  EXPECT_EQ(read_text(user / "thesis.tex"), "years of work");
}

TEST(AtomicOutput, TheCurrentFolderIsNeverReplaced) {
  test::TempDir dir;
  std::ofstream(dir / "notes.txt") << "keep";
  const fs::path before = fs::current_path();
  fs::current_path(dir.path());
  const std::string message = usage_error_of([&] { AtomicOutput(".", true); });
  fs::current_path(before);
  EXPECT_NE(message.find("output . is a folder"), std::string::npos) << message;
  EXPECT_EQ(read_text(dir / "notes.txt"), "keep");
}

TEST(AtomicOutput, AnInputIsNeverAnOutputNorInsideAReplacedFolder) {
  test::TempDir dir;
  std::ofstream(dir / "in.h5") << "input";
  declare_input(dir / "in.h5");
  EXPECT_NE(usage_error_of([&] { AtomicOutput(dir / "in.h5", true); }).find("is an input"), std::string::npos);
  fs::create_directory(dir / "sub");
  EXPECT_NE(usage_error_of([&] { AtomicOutput(dir / "sub" / ".." / "in.h5", true); }).find("is an input"),
            std::string::npos);
  fs::create_symlink(dir / "in.h5", dir / "link.h5");
  EXPECT_NE(usage_error_of([&] { AtomicOutput(dir / "link.h5", true); }).find("is an input"), std::string::npos);

  write_folder_output(dir / "run", "in_run.h5", "input", false);
  declare_input(dir / "run" / "in_run.h5");
  EXPECT_NE(usage_error_of([&] { AtomicOutput(dir / "run", true); }).find("holding the input"), std::string::npos);
  EXPECT_EQ(read_text(dir / "in.h5"), "input");
  EXPECT_EQ(read_text(dir / "run" / "in_run.h5"), "input");
}

TEST(AtomicOutput, ARefusedOverwriteIsDecidedByTheRename) {
  // Two runs to one path without --force both pass the early check; the first to commit wins and
  // the second changes nothing.
  test::TempDir dir;
  const auto target = dir / "result.h5";
  AtomicOutput first(target, false), second(target, false);
  std::ofstream(first.temp_path()) << "first";
  std::ofstream(second.temp_path()) << "second";
  commit_outputs({&first});
  EXPECT_NE(usage_error_of([&] { commit_outputs({&second}); }).find("already exists"), std::string::npos);
  EXPECT_EQ(read_text(target), "first");
}

TEST(AtomicOutput, ARunsOutputsArePutInPlaceAllOrNone) {
  // report's page and its image folder: when the folder cannot be put in place, the page is taken
  // back, and what the page replaced is back too.
  test::TempDir dir;
  const auto page = dir / "report.html", images = dir / "report_files";
  std::ofstream(page) << "old page";
  AtomicOutput page_out(page, true), images_out(images, false);
  std::ofstream(page_out.temp_path()) << "new page";
  fs::create_directory(images_out.temp_path());
  fs::create_directory(images);  // another run got there first
  std::ofstream(images / kOutputFolderMarker) << "written by report";
  std::ofstream(images / "chart.png") << "the other run's";
  EXPECT_THROW(commit_outputs({&page_out, &images_out}), UsageError);
  EXPECT_EQ(read_text(page), "old page");
  EXPECT_EQ(read_text(images / "chart.png"), "the other run's");
}

TEST(AtomicOutput, StaleTemporariesOfDeadRunsAreCleared) {
  test::TempDir dir;
  const std::string dead = std::to_string(dead_pid()), alive = std::to_string(::getppid());
  std::ofstream(dir / (".out.h5.tmp-" + dead)) << "left by a killed run";
  fs::create_directory(dir / (".out.h5.tmp-" + dead + ".swap"));
  std::ofstream(dir / (".out.h5.tmp-" + alive)) << "a run still going";
  std::ofstream(dir / ".other.h5.tmp-1") << "another output's";
  AtomicOutput out(dir / "out.h5", false);
  EXPECT_EQ(test::list_dir(dir.path()),
            (std::vector<std::string>{".other.h5.tmp-1", ".out.h5.tmp-" + alive}));
}

TEST(AtomicOutput, ReplaceNowLeavesACheckpointInPlace) {
  test::TempDir dir;
  const auto checkpoint = dir / "run.ckpt.h5";
  for (const char* text : {"step 100", "step 200"}) {
    AtomicOutput out(checkpoint, true);
    std::ofstream(out.temp_path()) << text;
    out.replace_now();
  }
  EXPECT_EQ(read_text(checkpoint), "step 200");
  EXPECT_EQ(test::list_dir(dir.path()), (std::vector<std::string>{"run.ckpt.h5"}));
}
