#include "pplvo/msgs/frame_ledger.h"

#include <algorithm>
#include <cstdio>
#include <iterator>

namespace pplvo::msgs {

std::string countsText(const NodeCounters& c) {
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "in %lld = out %lld + dropped %lld + skipped %lld + pending %lld; lost %lld, "
                "messages skipped %lld, errors %lld",
                static_cast<long long>(c.frames_in), static_cast<long long>(c.frames_out),
                static_cast<long long>(c.frames_dropped), static_cast<long long>(c.frames_skipped),
                static_cast<long long>(c.frames_pending), static_cast<long long>(c.frames_lost),
                static_cast<long long>(c.messages_skipped), static_cast<long long>(c.errors));
  return buf;
}

void FrameLedger::arrived(int64_t seq) {
  ++counters_.frames_in;
  open_.push_back(seq);
  while (open_.size() > kMaxOpen) {
    open_.pop_front();
    ++counters_.frames_dropped;
  }
  sync();
}

void FrameLedger::skippedOnArrival(int64_t n) {
  if (n <= 0) return;
  counters_.frames_in += n;
  counters_.frames_skipped += n;
}

std::deque<int64_t>::iterator FrameLedger::find(int64_t seq) {
  return std::find(open_.begin(), open_.end(), seq);
}

bool FrameLedger::isOpen(int64_t seq) const {
  return std::find(open_.begin(), open_.end(), seq) != open_.end();
}

bool FrameLedger::published(int64_t seq) {
  const auto it = find(seq);
  if (it == open_.end()) return false;
  counters_.frames_dropped += std::distance(open_.begin(), it);
  open_.erase(open_.begin(), it + 1);
  ++counters_.frames_out;
  sync();
  return true;
}

bool FrameLedger::dropped(int64_t seq) {
  const auto it = find(seq);
  if (it == open_.end()) return false;
  open_.erase(it);
  ++counters_.frames_dropped;
  sync();
  return true;
}

bool FrameLedger::skipped(int64_t seq) {
  const auto newest = std::find(open_.rbegin(), open_.rend(), seq);
  if (newest == open_.rend()) return false;
  open_.erase(std::next(newest).base());
  ++counters_.frames_skipped;
  sync();
  return true;
}

}  // namespace pplvo::msgs
