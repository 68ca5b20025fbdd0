#pragma once
// Checking what a library function refuses: the message of the graintwin::Error it throws.
#include <functional>
#include <string>

#include "graintwin/core/error.hpp"

namespace graintwin::test {

/// The message of the graintwin::Error that `f` throws, "" when it throws none. Any other
/// exception propagates (and fails the test): readers must throw graintwin::Error.
inline std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.message();
  }
  return "";
}

}  // namespace graintwin::test
