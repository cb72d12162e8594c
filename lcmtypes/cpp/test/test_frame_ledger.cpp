#include "pplvo/msgs/frame_ledger.h"

#include <gtest/gtest.h>

#include "pplvo/msgs/node_runtime.h"

namespace pplvo::msgs {
namespace {

TEST(FrameLedger, EveryFrameEndsInExactlyOneCount) {
  NodeCounters c;
  FrameLedger ledger(c);
  for (int64_t seq = 0; seq < 6; ++seq) ledger.arrived(seq);
  EXPECT_EQ(c.frames_in, 6);
  EXPECT_EQ(c.frames_pending, 6);
  EXPECT_TRUE(ledger.skipped(1));
  EXPECT_TRUE(ledger.dropped(2));
  EXPECT_TRUE(ledger.published(0));
  EXPECT_FALSE(ledger.published(0));  // closed once only
  EXPECT_FALSE(ledger.dropped(42));   // never arrived: nothing counted
  EXPECT_EQ(c.frames_out, 1);
  EXPECT_EQ(c.frames_dropped, 1);
  EXPECT_EQ(c.frames_skipped, 1);
  EXPECT_EQ(c.frames_pending, 3);
  EXPECT_TRUE(countsAddUp(c));
}

TEST(FrameLedger, PublishingAFrameDropsTheOpenOnesThatArrivedBeforeIt) {
  // Whatever path left frames 3 and 4 behind (an error, a forgotten queue), they are dropped
  // once a later frame is out: nothing stays pending for ever.
  NodeCounters c;
  FrameLedger ledger(c);
  for (int64_t seq = 3; seq < 7; ++seq) ledger.arrived(seq);
  EXPECT_TRUE(ledger.published(5));
  EXPECT_EQ(c.frames_dropped, 2);
  EXPECT_EQ(c.frames_out, 1);
  EXPECT_EQ(c.frames_pending, 1);
  EXPECT_TRUE(ledger.isOpen(6));
  EXPECT_TRUE(countsAddUp(c));
}

TEST(FrameLedger, ARepeatedSeqSkipsTheNewcomerAndPublishesTheOlder) {
  // A second source restarting at 0 repeats seqs: its frames are judged as they arrive (skip
  // the newest), the followed stream's leave its queues first in, first out.
  NodeCounters c;
  FrameLedger ledger(c);
  ledger.arrived(7);
  ledger.arrived(8);
  ledger.arrived(7);  // the stray copy
  EXPECT_TRUE(ledger.skipped(7));
  EXPECT_TRUE(ledger.published(7));
  EXPECT_TRUE(ledger.published(8));
  EXPECT_EQ(c.frames_out, 2);
  EXPECT_EQ(c.frames_skipped, 1);
  EXPECT_EQ(c.frames_dropped, 0);
  EXPECT_EQ(c.frames_pending, 0);
}

TEST(FrameLedger, StaysBoundedWhenNothingEverCloses) {
  NodeCounters c;
  FrameLedger ledger(c);
  const auto n = static_cast<int64_t>(FrameLedger::kMaxOpen) + 10;
  for (int64_t seq = 0; seq < n; ++seq) ledger.arrived(seq);
  EXPECT_EQ(ledger.pending(), static_cast<int64_t>(FrameLedger::kMaxOpen));
  EXPECT_EQ(c.frames_dropped, 10);
  EXPECT_TRUE(countsAddUp(c));
}

TEST(FrameLedger, UnnumberedSkipsAreInAndSkipped) {
  NodeCounters c;
  FrameLedger ledger(c);
  ledger.skippedOnArrival(3);
  EXPECT_EQ(c.frames_in, 3);
  EXPECT_EQ(c.frames_skipped, 3);
  EXPECT_TRUE(countsAddUp(c));
}

TEST(GuardedFrame, ABadFrameIsSkippedAnErrorDropsItAndSecondaryMessagesStayOutOfTheLedger) {
  NodeCounters c;
  FrameLedger ledger(c);
  ledger.arrived(0);
  EXPECT_FALSE(guardedFrame(ledger, c, "test", 0, [] { throw MessageError("bad size"); }));
  ledger.arrived(1);
  EXPECT_FALSE(guardedFrame(ledger, c, "test", 1, [] { throw std::runtime_error("boom"); }));
  ledger.arrived(2);
  EXPECT_TRUE(guardedFrame(ledger, c, "test", 2, [&] { ledger.published(2); }));
  // A bad message of another input (a pose, a depth map) is no frame of this node.
  EXPECT_FALSE(guarded(c, "test", [] { throw MessageError("NaN pose"); }));
  EXPECT_EQ(c.frames_in, 3);
  EXPECT_EQ(c.frames_skipped, 1);
  EXPECT_EQ(c.frames_dropped, 1);
  EXPECT_EQ(c.frames_out, 1);
  EXPECT_EQ(c.errors, 1);
  EXPECT_EQ(c.messages_skipped, 1);
  EXPECT_TRUE(countsAddUp(c));
}

TEST(NoteFrameSequence, FramesThatNeverArrivedAreLostNotDropped) {
  NodeCounters c;
  noteFrameSequence(c, 0);
  noteFrameSequence(c, 4);
  EXPECT_EQ(c.frames_lost, 3);
  EXPECT_EQ(c.frames_dropped, 0);
  noteFrameSequence(c, 0);  // a restarted source
  EXPECT_EQ(c.frames_lost, 3);
}

}  // namespace
}  // namespace pplvo::msgs
