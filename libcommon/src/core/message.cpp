#include "graintwin/core/message.hpp"

#include "graintwin/core/strings.hpp"

namespace graintwin {

std::string shorten_quotes(const std::string& message, std::size_t max) {
  std::string out;
  std::size_t at = 0;
  while (at < message.size()) {
    const std::size_t open = message.find('\'', at);
    const std::size_t close = open == std::string::npos ? std::string::npos : message.find('\'', open + 1);
    if (close == std::string::npos) {
      out += message.substr(at);
      break;
    }
    out += message.substr(at, open + 1 - at) + excerpt(message.substr(open + 1, close - open - 1), max) + '\'';
    at = close + 1;
  }
  return out;
}

}  // namespace graintwin
