// Tests of server/core/src/text.cc: client strings made safe for messages and logs, numbers
// printed exactly.
#include "dysa/core/text.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

namespace dysa {
namespace {

using ::testing::EndsWith;
using ::testing::HasSubstr;
using ::testing::StartsWith;

TEST(SafeTextTest, KeepsPrintableTextAsItIs) {
  EXPECT_EQ(SafeText("seed_basic"), "seed_basic");
  EXPECT_EQ(SafeText(""), "");
  EXPECT_EQ(SafeText("C:\\scenes\\a b.json"), "C:\\scenes\\a b.json");
  // UTF-8 letters are not control characters.
  EXPECT_EQ(SafeText("Wasserstra\xc3\x9f"
                     "e \xe6\xb0\xb4 \xf0\x9f\x8c\x8a"),
            "Wasserstra\xc3\x9f"
            "e \xe6\xb0\xb4 \xf0\x9f\x8c\x8a");
  EXPECT_FALSE(
      HasUnsafeCharacters("Wasserstra\xc3\x9f"
                          "e \xf0\x9f\x8c\x8a"));
}

TEST(SafeTextTest, EscapesEveryControlCharacter) {
  EXPECT_EQ(SafeText("a\nb\rc\td"), "a\\nb\\rc\\td");
  EXPECT_EQ(SafeText("\x1b[31mred"), "\\x1b[31mred");
  EXPECT_EQ(SafeText(std::string("a\0b", 3)), "a\\x00b");  // a NUL does not end the text
  EXPECT_EQ(SafeText("\x7f"), "\\x7f");
  EXPECT_EQ(SafeText("\xc2\x9b"
                     "2J"),
            "\\u009b2J");  // C1 CSI, which some terminals obey
  for (int c = 0; c < 0x20; ++c) {
    const std::string safe = SafeText(std::string(1, char(c)));
    EXPECT_THAT(safe, StartsWith("\\")) << c;
    EXPECT_TRUE(HasUnsafeCharacters(std::string(1, char(c)))) << c;
  }
  // A forged log line stays on the line it was written in.
  EXPECT_EQ(SafeText("x\n2026-01-01T00:00:00.000Z dysa-server: stopped").find('\n'),
            std::string::npos);
}

TEST(SafeTextTest, EscapesBytesThatAreNotUtf8) {
  EXPECT_EQ(SafeText("a\xff"
                     "b"),
            "a\\xffb");
  EXPECT_EQ(SafeText("\x80"), "\\x80");                    // a stray continuation byte
  EXPECT_EQ(SafeText("\xe6\xb0"), "\\xe6\\xb0");           // a truncated sequence
  EXPECT_EQ(SafeText("\xc0\xaf"), "\\xc0\\xaf");           // an overlong '/'
  EXPECT_EQ(SafeText("\xed\xa0\x80"), "\\xed\\xa0\\x80");  // a surrogate
  EXPECT_TRUE(HasUnsafeCharacters("a\xff"));
}

TEST(SafeTextTest, BoundsTheLengthAndStatesTheOriginalOne) {
  const std::string huge(4'000'000, 'N');
  const std::string safe = SafeText(huge, 100);
  EXPECT_LE(safe.size(), 100u);
  EXPECT_THAT(safe, StartsWith("NNNNNNNNNN"));
  EXPECT_THAT(safe, EndsWith("... (4000000 bytes)"));
  // Escapes count towards the bound, and a cut never splits a character or an escape.
  const std::string controls(1000, '\x1b');
  const std::string cut = SafeText(controls, 60);
  EXPECT_LE(cut.size(), 60u);
  EXPECT_THAT(cut, EndsWith("\\x1b... (1000 bytes)"));
  std::string letters;
  for (int i = 0; i < 100; ++i) letters += "\xe6\xb0\xb4";  // 3 bytes each
  const std::string letters_cut = SafeText(letters, 50);
  EXPECT_FALSE(HasUnsafeCharacters(letters_cut));
  EXPECT_THAT(letters_cut, EndsWith("\xe6\xb0\xb4... (300 bytes)"));
  // Text that fits is not cut, even when exactly at the bound.
  EXPECT_EQ(SafeText(std::string(100, 'a'), 100), std::string(100, 'a'));
  EXPECT_THAT(SafeText(std::string(101, 'a'), 100), EndsWith("... (101 bytes)"));
}

TEST(SafeTextTest, IsIdempotent) {
  for (const std::string& text :
       {std::string(5000, 'x'), std::string("a\nb\x1b\xff"), std::string(300, '\n')}) {
    const std::string once = SafeText(text, 200);
    EXPECT_EQ(SafeText(once, 200), once);
    EXPECT_EQ(SafeText(once, 4096), once);
    EXPECT_FALSE(HasUnsafeCharacters(once));
  }
}

TEST(ExactNumberTest, ShowsTheValueItself) {
  EXPECT_EQ(ExactNumber(0.1), "0.1");
  EXPECT_EQ(ExactNumber(1e-5), "1e-05");
  EXPECT_EQ(ExactNumber(100000), "100000");
  EXPECT_EQ(ExactNumber(-2.5), "-2.5");
  EXPECT_EQ(ExactNumber(2.0000000001), "2.0000000001");  // %g would print 2
  EXPECT_EQ(ExactNumber(1.0 / 3.0), "0.3333333333333333");
  EXPECT_EQ(ExactNumber(1e308 * 10), "inf");
  EXPECT_EQ(ExactNumber(-1e308 * 10), "-inf");
  EXPECT_EQ(ExactNumber(std::nan("")), "nan");
  for (double v : {0.086, 6.02214076e23, 4.9e-324, 1.7976931348623157e308, 0.1 + 0.2}) {
    EXPECT_EQ(std::strtod(ExactNumber(v).c_str(), nullptr), v) << ExactNumber(v);
  }
}

}  // namespace
}  // namespace dysa
