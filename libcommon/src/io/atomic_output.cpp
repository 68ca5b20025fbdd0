#include "graintwin/io/atomic_output.hpp"

#include <unistd.h>

#include "graintwin/core/error.hpp"

namespace graintwin::io {

namespace fs = std::filesystem;

void check_output_allowed(const fs::path& path, bool force) {
  std::error_code ec;
  if (fs::exists(path, ec) && !force)
    throw UsageError("output " + path.string() + " already exists; use --force to overwrite it");
  const fs::path parent = path.parent_path().empty() ? fs::path(".") : path.parent_path();
  if (!fs::is_directory(parent, ec))
    throw UsageError("output " + path.string() + ": folder " + parent.string() +
                     " does not exist; create it first");
}

AtomicOutput::AtomicOutput(fs::path final_path, bool force) : final_(std::move(final_path)), force_(force) {
  check_output_allowed(final_, force);
  temp_ = final_.parent_path() / ("." + final_.filename().string() + ".tmp-" + std::to_string(::getpid()));
  std::error_code ec;
  fs::remove_all(temp_, ec);  // a leftover of a killed run with the same pid
}

AtomicOutput::~AtomicOutput() {
  if (!committed_) {
    std::error_code ec;
    fs::remove_all(temp_, ec);
  }
}

void AtomicOutput::commit() {
  std::error_code ec;
  if (!fs::exists(temp_, ec))
    throw DataError("output " + final_.string() + " was not written (no temporary file)");
  if (fs::is_directory(temp_, ec) && fs::exists(final_, ec)) {
    if (!force_) throw UsageError("output " + final_.string() + " already exists; use --force to overwrite it");
    fs::remove_all(final_, ec);
  }
  fs::rename(temp_, final_, ec);
  if (ec) throw DataError("cannot rename " + temp_.string() + " to " + final_.string() + ": " + ec.message());
  committed_ = true;
}

}  // namespace graintwin::io
