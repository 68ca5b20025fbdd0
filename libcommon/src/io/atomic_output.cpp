#include "graintwin/io/atomic_output.hpp"

#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>  // renameat2 (glibc 2.28, _GNU_SOURCE)
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <fstream>
#include <mutex>
#include <string>

#include "graintwin/core/error.hpp"
#include "graintwin/core/interrupt.hpp"

extern char* program_invocation_short_name;  // glibc: the running program's name

namespace graintwin::io {

namespace fs = std::filesystem;

namespace {

std::mutex g_inputs_mutex;
std::vector<fs::path> g_inputs;  // canonical paths of this process's inputs

fs::path canonical_or_lexical(const fs::path& p) {
  std::error_code ec;
  fs::path c = fs::weakly_canonical(p, ec);
  return ec ? fs::absolute(p).lexically_normal() : c;
}

bool path_exists(const fs::path& p) {
  std::error_code ec;
  return fs::symlink_status(p, ec).type() != fs::file_type::not_found && !ec;
}

// The input `final` is, or the input a folder `final` holds; empty when none.
fs::path input_at_or_under(const fs::path& final) {
  const fs::path target = canonical_or_lexical(final);
  const std::string folder = target.string() + "/";
  std::lock_guard lock(g_inputs_mutex);
  for (const fs::path& in : g_inputs) {
    std::error_code ec;
    if (in == target || fs::equivalent(in, final, ec)) return in;
    if (in.string().starts_with(folder)) return in;
  }
  return {};
}

// Process `pid` is gone (a PID in use by another process counts as alive: we cannot tell).
bool process_gone(long pid) { return pid > 0 && ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH; }

// Temporaries ".<name>.tmp-<pid>[-<n>][.swap]" beside `final` whose process is gone.
void clear_stale_temporaries(const fs::path& final) {
  const std::string prefix = "." + final.filename().string() + ".tmp-";
  std::error_code ec;
  for (fs::directory_iterator it(final.parent_path(), ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (!name.starts_with(prefix)) continue;
    const std::string rest = name.substr(prefix.size());
    std::size_t digits = 0;
    while (digits < rest.size() && std::isdigit(static_cast<unsigned char>(rest[digits]))) ++digits;
    if (digits == 0 || digits > 9) continue;
    if (!process_gone(std::stol(rest.substr(0, digits)))) continue;
    std::error_code rm;
    fs::remove_all(it->path(), rm);
  }
}

// rename(2) with RENAME_NOREPLACE or RENAME_EXCHANGE; falls back where the file system lacks them.
int rename_with(const fs::path& from, const fs::path& to, unsigned flags) {
  if (::renameat2(AT_FDCWD, from.c_str(), AT_FDCWD, to.c_str(), flags) == 0) return 0;
  if (errno != EINVAL && errno != ENOSYS && errno != ENOTSUP) return -1;
  if (flags == RENAME_NOREPLACE) {
    if (!fs::is_directory(from)) {  // link(2) refuses an existing target atomically
      if (::link(from.c_str(), to.c_str()) != 0) return -1;
      return ::unlink(from.c_str());
    }
    if (path_exists(to)) return errno = EEXIST, -1;
    return ::rename(from.c_str(), to.c_str());
  }
  // Exchange in three renames through a side name.
  const fs::path side = from.string() + ".swap";
  if (::rename(to.c_str(), side.c_str()) != 0) return -1;
  if (::rename(from.c_str(), to.c_str()) != 0) {
    const int saved = errno;
    ::rename(side.c_str(), to.c_str());
    return errno = saved, -1;
  }
  return ::rename(side.c_str(), from.c_str());
}

}  // namespace

void declare_input(const fs::path& input) {
  std::lock_guard lock(g_inputs_mutex);
  g_inputs.push_back(canonical_or_lexical(input));
}

void check_output_allowed(const fs::path& path, bool force) {
  const fs::path absolute = fs::absolute(path).lexically_normal();
  const fs::path final = absolute.has_filename() ? absolute : absolute.parent_path();
  const std::string shown = path.string();
  if (const fs::path in = input_at_or_under(final); !in.empty())
    throw UsageError(in == canonical_or_lexical(final)
                         ? "output " + shown + " is an input of this run; write the output to another path"
                         : "output " + shown + " is a folder holding the input " + in.string() +
                               "; write the output to another folder");
  std::error_code ec;
  if (path_exists(final)) {
    if (!force) throw UsageError("output " + shown + " already exists; use --force to overwrite it");
    if (fs::is_directory(fs::symlink_status(final, ec)) && !path_exists(final / kOutputFolderMarker))
      throw UsageError("output " + shown + " is a folder that no GrainTwin tool wrote (it has no " +
                       std::string(kOutputFolderMarker) + "), so --force will not replace it; choose a new " +
                       "name or remove the folder yourself");
  }
  const fs::path parent = final.parent_path();
  if (!fs::is_directory(parent, ec))
    throw UsageError("output " + shown + ": folder " + parent.string() + " does not exist; create it first");
  if (::access(parent.c_str(), W_OK) != 0)
    throw UsageError("output " + shown + ": folder " + parent.string() + " is not writable; choose another folder");
}

AtomicOutput::AtomicOutput(fs::path final_path, bool force) : force_(force) {
  check_output_allowed(final_path, force);
  const fs::path absolute = fs::absolute(final_path).lexically_normal();
  final_ = absolute.has_filename() ? absolute : absolute.parent_path();
  // The count tells apart outputs of one process for the same path (tests, retries).
  static std::atomic<unsigned> count{0};
  temp_ = final_.parent_path() /
          ("." + final_.filename().string() + ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(++count));
  clear_stale_temporaries(final_);
}

AtomicOutput::~AtomicOutput() {
  if (placed_ == Placed::no) {
    std::error_code ec;
    fs::remove_all(temp_, ec);
  }
}

void AtomicOutput::place() {
  std::error_code ec;
  if (!path_exists(temp_)) throw DataError("output " + final_.string() + " was not written (no temporary file)");
  check_output_allowed(final_, force_);
  if (fs::is_directory(fs::symlink_status(temp_, ec))) {
    std::ofstream marker(temp_ / kOutputFolderMarker);
    marker << "written by " << program_invocation_short_name << " (GrainTwin)\n";
    if (!marker) throw DataError("cannot write " + (temp_ / kOutputFolderMarker).string());
  }
  if (rename_with(temp_, final_, RENAME_NOREPLACE) == 0) {
    placed_ = Placed::new_path;
    return;
  }
  if (errno == EEXIST && force_) {  // it appeared since the check: replace it the same way
    check_output_allowed(final_, force_);
    if (rename_with(temp_, final_, RENAME_EXCHANGE) == 0) {
      placed_ = Placed::exchanged;
      return;
    }
  }
  if (errno == EEXIST || errno == ENOTEMPTY)
    throw UsageError("output " + final_.string() + " already exists (another run wrote it meanwhile); use --force to " +
                     "overwrite it");
  throw DataError("cannot put " + final_.string() + " in place: " + std::strerror(errno));
}

void AtomicOutput::put_back() noexcept {
  if (placed_ == Placed::new_path) rename_with(final_, temp_, RENAME_NOREPLACE);
  if (placed_ == Placed::exchanged) rename_with(temp_, final_, RENAME_EXCHANGE);
  placed_ = Placed::no;
}

void AtomicOutput::drop_replaced() noexcept {
  if (placed_ != Placed::exchanged) return;
  std::error_code ec;
  fs::remove_all(temp_, ec);  // what the output replaced, now under the temporary name
}

void AtomicOutput::replace_now() {
  place();
  drop_replaced();
}

void commit_outputs(const std::vector<AtomicOutput*>& outputs) {
  pass_commit_point();
  std::vector<AtomicOutput*> placed;
  try {
    for (AtomicOutput* o : outputs)
      if (o) o->place(), placed.push_back(o);
  } catch (...) {
    for (auto it = placed.rbegin(); it != placed.rend(); ++it) (*it)->put_back();
    throw;
  }
  for (AtomicOutput* o : placed) o->drop_replaced();
}

}  // namespace graintwin::io
