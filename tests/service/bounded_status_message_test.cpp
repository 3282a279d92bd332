// BoundedStatusMessage (server/bounded_status_message.h): how a long status message is cut.
#include "server/bounded_status_message.h"

#include <gtest/gtest.h>

#include <string>

namespace {

using glint::BoundedStatusMessage;

TEST(BoundedStatusMessage, ShortMessagesAreUnchanged) {
  EXPECT_EQ(BoundedStatusMessage("material: unset"), "material: unset");
  EXPECT_EQ(BoundedStatusMessage(std::string(2048, 'a')), std::string(2048, 'a'));
}

TEST(BoundedStatusMessage, LongMessagesAreCutSayingHowLongTheyWere) {
  EXPECT_EQ(BoundedStatusMessage("input 'abcdefgh'", 8), "input 'a... (16 bytes in all)");
  // A two-byte UTF-8 character straddling the cut is dropped whole, never split.
  EXPECT_EQ(BoundedStatusMessage("abc\xc3\xa9xyz", 4), "abc... (8 bytes in all)");
  EXPECT_EQ(BoundedStatusMessage("abc\xc3\xa9xyz", 5), "abc\xc3\xa9... (8 bytes in all)");
  EXPECT_EQ(BoundedStatusMessage(std::string(20000, 'x')).size(),
            glint::kMaxStatusMessageBytes + std::string("... (20000 bytes in all)").size());
}

}  // namespace
