#include "pplvo/core/stage_timer.h"

#include <algorithm>
#include <cstdio>

namespace pplvo {

void StageStats::add(double ms) {
  ++count;
  last_ms = ms;
  total_ms += ms;
  max_ms = std::max(max_ms, ms);
}

void StageTimings::add(const std::string& stage, double ms) {
  for (auto& s : stages_) {
    if (s.name == stage) {
      s.add(ms);
      return;
    }
  }
  stages_.push_back(StageStats{stage});
  stages_.back().add(ms);
}

void StageTimings::merge(const StageStats& stats) {
  for (auto& s : stages_) {
    if (s.name == stats.name) {
      s.count += stats.count;
      s.last_ms = stats.last_ms;
      s.total_ms += stats.total_ms;
      s.max_ms = std::max(s.max_ms, stats.max_ms);
      return;
    }
  }
  stages_.push_back(stats);
}

const StageStats* StageTimings::find(const std::string& stage) const {
  for (const auto& s : stages_) {
    if (s.name == stage) return &s;
  }
  return nullptr;
}

std::string StageTimings::table() const {
  std::string out;
  char buf[160];
  std::snprintf(buf, sizeof(buf), "%-28s %8s %10s %10s\n", "stage", "count", "mean_ms", "max_ms");
  out += buf;
  for (const auto& s : stages_) {
    std::snprintf(buf, sizeof(buf), "%-28s %8lld %10.3f %10.3f\n", s.name.c_str(),
                  static_cast<long long>(s.count), s.meanMs(), s.max_ms);
    out += buf;
  }
  return out;
}

int64_t hostUtime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace pplvo
