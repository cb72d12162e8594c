#pragma once
/// Where every frame of a node's input stream ended, so that a node's counters add up:
///   frames_in = frames_out + frames_dropped + frames_skipped + frames_pending.
/// A frame is *in* once its message reached the node's handler; it leaves as *out* (the node
/// published its result), *dropped* (the node gave it up: stale, behind, its other input never
/// came, an error), *skipped* (bad input: undecodable content, a stray source, older than one
/// already handled) or is still *pending* in the node's queues. Frames that never reached the
/// node (gaps in the source's numbering) are `frames_lost`, outside the sum; messages of the
/// node's other inputs that served no frame are `messages_skipped`.
#include <cstdint>
#include <deque>
#include <string>

#include "pplvo/msgs/convert.h"

namespace pplvo::msgs {

/// Whether `c`'s frames add up: in = out + dropped + skipped + pending.
inline bool countsAddUp(const NodeCounters& c) {
  return c.frames_in == c.frames_out + c.frames_dropped + c.frames_skipped + c.frames_pending;
}

/// "in 10 = out 7 + dropped 1 + skipped 1 + pending 1; lost 2, messages skipped 0, errors 0":
/// how pplvo-run and the nodes' "done:" lines print a node's counts.
std::string countsText(const NodeCounters& c);

class FrameLedger {
 public:
  /// Open frames beyond this many are dropped, oldest first (a node that never closes frames
  /// cannot grow the ledger without bound).
  static constexpr size_t kMaxOpen = 4096;

  explicit FrameLedger(NodeCounters& counters) : counters_(counters) {}
  FrameLedger(const FrameLedger&) = delete;
  FrameLedger& operator=(const FrameLedger&) = delete;

  /// Frame `seq` reached the node: in, and pending until closed.
  void arrived(int64_t seq);
  /// `n` frames reached the node with no usable number (a dataset's unreadable files): in and
  /// skipped at once.
  void skippedOnArrival(int64_t n);

  /// Close frame `seq`; each returns false (and counts nothing) when it is not open. The node
  /// handles its frames in arrival order, so publishing one drops every frame that arrived
  /// before it and is still open (left behind, whatever the path). Where two open frames share
  /// a seq (a restarted or second source), published() and dropped() close the older (queues
  /// are first in, first out), skipped() the newer (input is judged as it arrives).
  bool published(int64_t seq);
  bool dropped(int64_t seq);
  bool skipped(int64_t seq);

  bool isOpen(int64_t seq) const;
  int64_t pending() const { return static_cast<int64_t>(open_.size()); }

 private:
  /// The oldest open entry of `seq`, or open_.end().
  std::deque<int64_t>::iterator find(int64_t seq);
  void sync() { counters_.frames_pending = pending(); }

  NodeCounters& counters_;
  std::deque<int64_t> open_;  ///< seqs of open frames, in arrival order
};

}  // namespace pplvo::msgs
