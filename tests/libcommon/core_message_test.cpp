// core/message: messages that quote a user's file stay one readable sentence.
#include <gtest/gtest.h>

#include <string>

#include "graintwin/core/message.hpp"

using namespace graintwin;

TEST(ShortenQuotes, CutsLongQuotedPassagesAndKeepsTheSentence) {
  const std::string digits(70, '6');
  EXPECT_EQ(shorten_quotes("Error while parsing decimal integer: '" + digits + "' is not representable in 64 bits", 10),
            "Error while parsing decimal integer: '6666666666...' is not representable in 64 bits");
  EXPECT_EQ(shorten_quotes("key 'blur' and 'noise' are short"), "key 'blur' and 'noise' are short");
  EXPECT_EQ(shorten_quotes("an unmatched 'quote stays as it is"), "an unmatched 'quote stays as it is");
  EXPECT_EQ(shorten_quotes(std::string("bytes '\x01\x02' shown"), 10), "bytes '??' shown");
}
