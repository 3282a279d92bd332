// LogSafe (server/log_sanitize.h): what a client-chosen string becomes in glintd's request log.
// Expectations are written out byte by byte.
#include "server/log_sanitize.h"

#include <gtest/gtest.h>

#include <string>

namespace {

using glint::LogSafe;

TEST(LogSafe, PlainTextAndUtf8AreKept) {
  EXPECT_EQ(LogSafe("Evaluate n=16 model=SMOOTH ok"), "Evaluate n=16 model=SMOOTH ok");
  EXPECT_EQ(LogSafe("normal map caf\xc3\xa9.exr"), "normal map caf\xc3\xa9.exr");
  EXPECT_EQ(LogSafe(""), "");
}

TEST(LogSafe, ControlCharactersCannotStartALineOrRewriteOne) {
  EXPECT_EQ(LogSafe("x\nglintd: forged"), "x\\nglintd: forged");
  EXPECT_EQ(LogSafe("a\rb\tc"), "a\\rb\\tc");
  EXPECT_EQ(LogSafe(std::string("\x1b[2Jz\x7f\x00", 7)), "\\x1b[2Jz\\x7f\\x00");
  // A backslash is doubled, so "\n" in the log is always an escaped newline.
  EXPECT_EQ(LogSafe("a\\nb"), "a\\\\nb");
  for (char c : LogSafe("\n\r\v\f\x01\x1f")) EXPECT_GE(static_cast<unsigned char>(c), 0x20);
}

TEST(LogSafe, LongLinesAreCutSayingHowLongTheyWere) {
  const std::string name(100000, 'a');
  const std::string out = LogSafe("UploadNormalMap " + name, 64);
  EXPECT_EQ(out, "UploadNormalMap " + std::string(48, 'a') + "... (100016 bytes in all)");
  // An escape is never cut in half: the cut falls before it.
  EXPECT_EQ(LogSafe("abc\n", 4), "abc... (4 bytes in all)");
  EXPECT_EQ(LogSafe(std::string(64, 'b'), 64), std::string(64, 'b'));
  EXPECT_EQ(LogSafe(std::string(100000, 'c')).size(),
            glint::kMaxLogLineBytes + std::string("... (100000 bytes in all)").size());
}

}  // namespace
