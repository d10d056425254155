// The one rule for outside text (rv/field/text.hpp): validity as RFC 3629 defines it, an escape that
// is injective and reversible, and echoes of client input that stay short.
#include <gtest/gtest.h>

#include <random>
#include <set>
#include <string>

#include "rv/field/text.hpp"

namespace rv {
namespace {

// An oracle written differently from the implementation: decode by the lead byte's declared
// length, then require that the code point is a scalar value whose shortest encoding is exactly
// those bytes (this excludes overlong forms, surrogates and values above U+10FFFF).
std::string encode(uint32_t cp) {
  std::string s;
  if (cp < 0x80) {
    s += static_cast<char>(cp);
  } else if (cp < 0x800) {
    s += static_cast<char>(0xC0 | (cp >> 6));
    s += static_cast<char>(0x80 | (cp & 0x3F));
  } else if (cp < 0x10000) {
    s += static_cast<char>(0xE0 | (cp >> 12));
    s += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
    s += static_cast<char>(0x80 | (cp & 0x3F));
  } else {
    s += static_cast<char>(0xF0 | (cp >> 18));
    s += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
    s += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
    s += static_cast<char>(0x80 | (cp & 0x3F));
  }
  return s;
}

bool oracle_valid(const std::string& s) {
  for (size_t i = 0; i < s.size();) {
    const auto b = static_cast<unsigned char>(s[i]);
    size_t n = b < 0x80 ? 1 : (b >> 5) == 6 ? 2 : (b >> 4) == 14 ? 3 : (b >> 3) == 30 ? 4 : 0;
    if (n == 0 || i + n > s.size()) return false;
    uint32_t cp = n == 1 ? b : n == 2 ? (b & 0x1F) : n == 3 ? (b & 0x0F) : (b & 0x07);
    for (size_t k = 1; k < n; ++k) {
      const auto c = static_cast<unsigned char>(s[i + k]);
      if ((c >> 6) != 2) return false;
      cp = (cp << 6) | (c & 0x3F);
    }
    if (cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return false;
    if (encode(cp) != s.substr(i, n)) return false;
    i += n;
  }
  return true;
}

std::string random_bytes(std::mt19937_64& rng, size_t max_len) {
  // Biased towards the bytes that matter: backslashes, 'x', hex digits, lead and continuation
  // bytes, so that sequences near the edges of validity and of the escape are common.
  static const std::string alphabet = "\\\\\\xxA0F9 a\x80\xbf\xc0\xc1\xc2\xdf\xe0\xed\xef\xf0\xf4\xf5\xff";
  std::uniform_int_distribution<size_t> len(0, max_len);
  std::uniform_int_distribution<int> pick(0, 3);
  std::uniform_int_distribution<size_t> from_alphabet(0, alphabet.size() - 1);
  std::uniform_int_distribution<int> any(0, 255);
  std::string s(len(rng), '\0');
  for (char& c : s) c = pick(rng) == 0 ? static_cast<char>(any(rng)) : alphabet[from_alphabet(rng)];
  return s;
}

TEST(Text, ValidityFollowsRfc3629) {
  EXPECT_TRUE(is_valid_utf8(""));
  EXPECT_TRUE(is_valid_utf8("Danmark \xc3\x98resund \xe2\x82\xac \xf0\x9f\x8c\x8a"));
  EXPECT_TRUE(is_valid_utf8(std::string("a\0b", 3)));  // NUL is a character
  EXPECT_TRUE(is_valid_utf8("\xed\x9f\xbf"));          // U+D7FF, just below the surrogates
  EXPECT_TRUE(is_valid_utf8("\xf4\x8f\xbf\xbf"));      // U+10FFFF
  for (const char* bad : {"\x80", "o\x80", "\xc0\x80", "\xc1\xbf", "\xe0\x80\x80", "\xe0\x9f\xbf", "\xed\xa0\x80",
                          "\xed\xbf\xbf", "\xf0\x80\x80\x80", "\xf4\x90\x80\x80", "\xf5\x80\x80\x80", "\xff", "\xc3",
                          "\xe2\x82", "\xf0\x9f\x8c", "\xc3\x28"}) {
    EXPECT_FALSE(is_valid_utf8(bad)) << "accepted " << escape_utf8(bad);
  }
  std::mt19937_64 rng(7);
  for (int i = 0; i < 200000; ++i) {
    const std::string s = random_bytes(rng, 8);
    ASSERT_EQ(is_valid_utf8(s), oracle_valid(s)) << escape_utf8(s);
  }
  // Every code point through the oracle's encoder is valid; every surrogate is not.
  for (uint32_t cp = 0; cp <= 0x10FFFF; cp += (cp < 0x20000 ? 1 : 97)) {
    const bool surrogate = cp >= 0xD800 && cp <= 0xDFFF;
    ASSERT_EQ(is_valid_utf8(encode(cp)), !surrogate) << cp;
  }
}

TEST(Text, EscapeWritesInvalidBytesAsHexAndLeavesPlainTextAlone) {
  EXPECT_EQ(escape_utf8("o\x80"), "o\\x80");
  EXPECT_EQ(escape_utf8("\xc0\x80"), "\\xC0\\x80");
  EXPECT_EQ(escape_utf8("\xe2\x82"), "\\xE2\\x82");  // a truncated sequence, byte by byte
  EXPECT_EQ(escape_utf8("\xc3\x98resund"), "\xc3\x98resund");
  EXPECT_EQ(escape_utf8("C:\\data\\seeds.gpkg"), "C:\\data\\seeds.gpkg");  // no ambiguity: unchanged
  // A typed "\x80" must not read as the byte 0x80: its backslash is doubled.
  EXPECT_EQ(escape_utf8("\\x80"), "\\\\x80");
  EXPECT_EQ(escape_utf8("a\\\\b"), "a\\\\\\b");
  EXPECT_EQ(escape_utf8("\\\x80"), "\\\\\\x80");
  EXPECT_EQ(escape_utf8("end\\"), "end\\");
}

TEST(Text, EscapeIsValidInjectiveAndReversible) {
  std::mt19937_64 rng(11);
  std::set<std::string> outputs;
  std::set<std::string> inputs;
  for (int i = 0; i < 300000; ++i) {
    const std::string s = random_bytes(rng, 10);
    const std::string e = escape_utf8(s);
    ASSERT_TRUE(oracle_valid(e)) << e;
    ASSERT_EQ(unescape_utf8(e), s) << e;
    if (oracle_valid(s) && s.find('\\') == std::string::npos) {
      ASSERT_EQ(e, s);
    }
    if (inputs.insert(s).second) {
      ASSERT_TRUE(outputs.insert(e).second) << "two inputs give " << e;
    }
  }
  // The pair the issue names: a label with an invalid byte and one without stay apart.
  EXPECT_NE(escape_utf8("DK\x80"), escape_utf8("DK"));
  EXPECT_NE(escape_utf8("DK\x80"), escape_utf8("DK\\x80"));
}

TEST(Text, ValidUtf8NeverEscapesTwice) {
  const std::string once = escape_utf8("field o\x80");
  EXPECT_EQ(valid_utf8(once), once);
  EXPECT_EQ(valid_utf8("plain"), "plain");
  EXPECT_EQ(valid_utf8("x\xff"), "x\\xFF");
}

TEST(Text, QuoteInputCutsLongEchoesAtACharacterBoundary) {
  EXPECT_EQ(quote_input("EPSG:4326"), "EPSG:4326");
  const std::string huge(700000, 'W');
  const std::string q = quote_input(huge, 80);
  EXPECT_EQ(q, std::string(80, 'W') + "... (700000 bytes)");
  // 40 two-byte characters: a cut at 79 bytes would split one; it goes back to 78.
  std::string oe;
  for (int i = 0; i < 40; ++i) oe += "\xc3\x98";
  const std::string cut = quote_input(oe, 79);
  EXPECT_TRUE(is_valid_utf8(cut)) << cut;
  EXPECT_EQ(cut.substr(0, 78), oe.substr(0, 78));
  EXPECT_NE(cut.find("(80 bytes)"), std::string::npos);
  EXPECT_TRUE(is_valid_utf8(quote_input(std::string(100, '\x80'), 10)));
}

}  // namespace
}  // namespace rv
