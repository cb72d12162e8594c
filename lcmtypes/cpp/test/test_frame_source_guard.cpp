// msgs::FrameSourceGuard: which frames on PPLVO_RGBD are the followed stream (issue 39's stray
// and forged publishers).
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "pplvo/msgs/frame_source_guard.h"

namespace pplvo::msgs {
namespace {

constexpr int64_t kPeriodUs = 33333;
int64_t stamp(int64_t seq) { return 1'000'000'000 + seq * kPeriodUs; }

TEST(FrameSourceGuard, FollowsOneStreamThroughLostFrames) {
  FrameSourceGuard g;
  for (int64_t seq : {0, 1, 2, 5, 6, 40}) {  // frames 3, 4, 7-39 lost on the way
    EXPECT_EQ(g.judge("/data/seq", seq, stamp(seq)), FrameVerdict::kFollow) << seq;
  }
  EXPECT_EQ(g.strayFrames(), 0);
}

TEST(FrameSourceGuard, ForgedSeqOrStampIsStrayAndTheStreamGoesOn) {
  FrameSourceGuard g;
  EXPECT_EQ(g.judge("/data/seq", 0, stamp(0)), FrameVerdict::kFollow);
  EXPECT_EQ(g.judge("/data/seq", 1, stamp(1)), FrameVerdict::kFollow);
  std::string why;
  // issue 39: one well-formed frame with seq 10^12 on the bus.
  EXPECT_EQ(g.judge("/data/seq", 1'000'000'000'000, stamp(2), &why), FrameVerdict::kStray);
  EXPECT_NE(why.find("jumps"), std::string::npos) << why;
  // A stamp 1000 s ahead, one going back.
  EXPECT_EQ(g.judge("/data/seq", 2, stamp(2) + 1'000'000'000, &why), FrameVerdict::kStray);
  EXPECT_NE(why.find("s after the previous frame"), std::string::npos) << why;
  EXPECT_EQ(g.judge("/data/seq", 2, stamp(0), &why), FrameVerdict::kStray);
  EXPECT_NE(why.find("earlier"), std::string::npos) << why;
  // The real stream is not derailed.
  for (int64_t seq = 2; seq < 10; ++seq) {
    EXPECT_EQ(g.judge("/data/seq", seq, stamp(seq)), FrameVerdict::kFollow) << seq;
  }
  EXPECT_EQ(g.strayFrames(), 3);
}

TEST(FrameSourceGuard, SecondSourceStaysStrayWhileTheFirstGoesOn) {
  FrameSourceGuard g;
  std::string why;
  int64_t strays = 0;
  // A second player on the bus, from seq 0, interleaved with the followed one (same folder).
  for (int64_t k = 0; k < 30; ++k) {
    EXPECT_EQ(g.judge("/data/seq", 100 + k, stamp(100 + k)), FrameVerdict::kFollow) << k;
    const FrameVerdict v = g.judge("/data/seq", k, stamp(k), &why);
    EXPECT_EQ(v, FrameVerdict::kStray) << k;
    strays += v == FrameVerdict::kStray ? 1 : 0;
  }
  EXPECT_NE(why.find("second source"), std::string::npos) << why;
  // Another source name, likewise.
  EXPECT_EQ(g.judge("fakenect:0", 130, stamp(130), &why), FrameVerdict::kStray);
  EXPECT_NE(why.find("another source 'fakenect:0'"), std::string::npos) << why;
  EXPECT_EQ(g.strayFrames(), strays + 1);
}

TEST(FrameSourceGuard, ARestartedSourceIsFollowedAfterAFewFrames) {
  FrameSourceGuardOptions o;
  FrameSourceGuard g(o);
  for (int64_t seq = 0; seq < 50; ++seq) g.judge("/data/seq", seq, stamp(seq));
  // The player starts again (seq and stamps from the beginning); the old stream is silent.
  std::vector<FrameVerdict> v;
  for (int64_t seq = 0; seq < 6; ++seq) v.push_back(g.judge("/data/seq", seq, stamp(seq)));
  for (int k = 0; k < o.restart_after - 1; ++k) EXPECT_EQ(v[k], FrameVerdict::kStray) << k;
  EXPECT_EQ(v[o.restart_after - 1], FrameVerdict::kRestart);
  for (size_t k = o.restart_after; k < v.size(); ++k) EXPECT_EQ(v[k], FrameVerdict::kFollow);
  // A camera that reconnects under another name is followed the same way.
  for (int64_t seq = 0; seq < o.restart_after - 1; ++seq) {
    EXPECT_EQ(g.judge("fakenect:1", seq, stamp(1000 + seq)), FrameVerdict::kStray);
  }
  EXPECT_EQ(g.judge("fakenect:1", o.restart_after - 1, stamp(1000 + o.restart_after - 1)),
            FrameVerdict::kRestart);
}

}  // namespace
}  // namespace pplvo::msgs
