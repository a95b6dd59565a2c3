// Tests of viewer/src/session_watch.h: when a viewer gives up by itself, and what it says.
#include "session_watch.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace dysa::viewer {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;
using Clock = SessionWatch::Clock;

const Clock::time_point kStart = Clock::time_point() + 1h;

TEST(SessionWatchTest, AServerLostForLongerThanTheTimeoutEndsTheViewer) {
  SessionWatch watch({false, 5, 60}, 100, kStart);
  EXPECT_FALSE(watch.Check(kStart, true, "", "", 100));
  EXPECT_FALSE(watch.Check(kStart + 1s, false, "connection refused", "", 100));
  EXPECT_FALSE(watch.Check(kStart + 6s, false, "connection refused", "", 100));  // 5 s lost
  const auto why = watch.Check(kStart + 7s, false, "connection refused", "", 100);
  ASSERT_TRUE(why);
  EXPECT_THAT(*why, HasSubstr("lost the server for 6 s (connection refused)"));
}

TEST(SessionWatchTest, AServerBackInTimeResetsTheClock) {
  SessionWatch watch({false, 5, 60}, 100, kStart);
  watch.Check(kStart, true, "", "", 100);
  watch.Check(kStart + 1s, false, "", "", 100);
  EXPECT_FALSE(watch.Check(kStart + 4s, true, "", "", 100));
  EXPECT_FALSE(watch.Check(kStart + 5s, false, "", "", 100));
  EXPECT_FALSE(watch.Check(kStart + 9s, false, "", "", 100));
  EXPECT_TRUE(watch.Check(kStart + 11s, false, "", "", 100));
}

TEST(SessionWatchTest, AnInteractiveViewerWaitsForAServerItNeverHadOrWhenToldTo) {
  SessionWatch never({false, 5, 60}, 100, kStart);
  EXPECT_FALSE(never.Check(kStart + 1h, false, "connection refused", "", 100));
  SessionWatch patient({false, 0, 60}, 100, kStart);
  patient.Check(kStart, true, "", "", 100);
  EXPECT_FALSE(patient.Check(kStart + 1h, false, "", "", 100));
  // Nor does an interactive viewer mind its parent going (a terminal closed with nohup).
  EXPECT_FALSE(patient.Check(kStart + 1h, true, "", "", 1));
}

TEST(SessionWatchTest, AScreenshotEndsWhenItsParentGoesOrItIsOverdue) {
  SessionWatch orphan({true, 5, 60}, 100, kStart);
  const auto gone = orphan.Check(kStart + 1s, false, "", "particle frame", 1);
  ASSERT_TRUE(gone);
  EXPECT_THAT(*gone, HasSubstr("pid 100"));

  SessionWatch late({true, 5, 60}, 100, kStart);
  EXPECT_FALSE(late.Check(kStart + 59s, false, "refused", "particle frame", 100));
  const auto overdue = late.Check(kStart + 61s, false, "refused", "particle frame", 100);
  ASSERT_TRUE(overdue);
  EXPECT_THAT(*overdue, HasSubstr("no particle frame within 60 s: refused"));
  // Nothing left to wait for: the screenshot is being rendered.
  SessionWatch rendering({true, 5, 60}, 100, kStart);
  EXPECT_FALSE(rendering.Check(kStart + 61s, true, "", "", 100));
}

}  // namespace
}  // namespace dysa::viewer
