#pragma once
// Typed errors thrown by library code. Only tools print them and choose the exit code.
#include <string>
#include <vector>

namespace graintwin {

/// Exit codes shared by every tool (docs/conventions.md).
enum class ExitCode : int { ok = 0, data_error = 1, usage_error = 2, interrupted = 130 };

/// Base error: a one-sentence message plus context lines added while it propagates.
class Error {
 public:
  explicit Error(std::string message) : message_(std::move(message)) {}
  virtual ~Error() = default;
  virtual ExitCode exit_code() const { return ExitCode::data_error; }
  const std::string& message() const { return message_; }
  const std::vector<std::string>& context() const { return context_; }
  /// Adds a line such as "while reading scan.h5"; innermost first.
  Error& add_context(std::string line) {
    context_.push_back(std::move(line));
    return *this;
  }

 private:
  std::string message_;
  std::vector<std::string> context_;
};

/// The data are bad, inconsistent or cannot be processed (exit 1).
class DataError : public Error {
 public:
  using Error::Error;
};

/// The command was asked for something it cannot do as asked: bad option value, missing input,
/// wrong file kind, existing output without --force (exit 2).
class UsageError : public Error {
 public:
  using Error::Error;
  ExitCode exit_code() const override { return ExitCode::usage_error; }
};

/// The run was interrupted by SIGINT/SIGTERM (exit 130).
class InterruptedError : public Error {
 public:
  InterruptedError() : Error("interrupted") {}
  ExitCode exit_code() const override { return ExitCode::interrupted; }
};

}  // namespace graintwin
