#include <gtest/gtest.h>

#include <cstdint>

#include "pplvo/estimator/frame_intervals.h"

namespace pplvo::estimator {
namespace {

constexpr int64_t kStart = 1305031102000000;  // a TUM-like stamp (us)

TEST(FrameIntervals, NothingKnownWithoutTwoStamps) {
  FrameIntervals f;
  EXPECT_FALSE(f.period_s());
  EXPECT_EQ(f.periodsUntil(kStart), 1);
  f.add(kStart);
  EXPECT_FALSE(f.period_s());
  EXPECT_EQ(f.periodsUntil(kStart + 100000), 1);  // no period to count in yet
}

TEST(FrameIntervals, PeriodIsTheMedianSoJitterAndDropsLeaveItAlone) {
  // fr1's stamps alternate 32 / 36 ms around 33.3 ms; every fifth frame is dropped.
  FrameIntervals f;
  int64_t t = kStart;
  f.add(t);
  for (int k = 1; k <= 40; ++k) {
    t += (k % 2 ? 32000 : 36000) + (k % 5 == 0 ? 33333 : 0);
    f.add(t);
  }
  ASSERT_TRUE(f.period_s());
  EXPECT_GE(*f.period_s(), 0.032);
  EXPECT_LE(*f.period_s(), 0.036);
  EXPECT_EQ(f.periodsUntil(t + 36000), 1);   // jitter: still the next frame
  EXPECT_EQ(f.periodsUntil(t + 68000), 2);   // one frame dropped
  EXPECT_EQ(f.periodsUntil(t + 101000), 3);  // two dropped
  EXPECT_EQ(f.periodsUntil(t - 1000), 1);    // not after the last: nothing to count
}

TEST(FrameIntervals, ALowerFrameRateIsOnePeriodPerFrame) {
  // A dataset played at every third frame: 100 ms is the stream's own period.
  FrameIntervals f;
  for (int k = 0; k < 10; ++k) f.add(kStart + k * 100000);
  EXPECT_NEAR(*f.period_s(), 0.1, 1e-12);
  EXPECT_EQ(f.periodsUntil(kStart + 10 * 100000), 1);
  EXPECT_EQ(f.periodsUntil(kStart + 11 * 100000), 2);
}

TEST(FrameIntervals, ARestartedOrStamplessStreamStartsAgainAndAPauseIsBounded) {
  FrameIntervals f;
  for (int k = 0; k < 10; ++k) f.add(kStart + k * 33333);
  f.add(kStart);  // the stream restarted from its beginning
  EXPECT_FALSE(f.period_s());
  FrameIntervals stampless;  // every stamp 0, as sources without clocks give
  for (int k = 0; k < 5; ++k) stampless.add(0);
  EXPECT_FALSE(stampless.period_s());
  EXPECT_EQ(stampless.periodsUntil(0), 1);
  FrameIntervals paused;
  for (int k = 0; k < 10; ++k) paused.add(kStart + k * 33333);
  const int periods = paused.periodsUntil(kStart + int64_t{3600} * 1000000);  // an hour later
  EXPECT_GT(periods, 1000);
  EXPECT_LE(periods, 10000);
}

}  // namespace
}  // namespace pplvo::estimator
