#pragma once
// Messages that quote text from a user's file: a parser's description may quote a whole token (a
// 70-digit number, a 5 000-character name), and a message must stay one readable sentence.
#include <cstddef>
#include <string>

namespace graintwin {

/// `message` with every single-quoted passage longer than `max` characters cut to its first `max`
/// (as excerpt(): unprintable bytes as '?', then "..."); the rest of the sentence is kept.
std::string shorten_quotes(const std::string& message, std::size_t max = 40);

}  // namespace graintwin
