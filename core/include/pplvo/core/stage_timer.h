#pragma once
/// Wall-clock timing statistics for named processing stages.
#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

namespace pplvo {

struct StageStats {
  std::string name;
  int64_t count = 0;
  double last_ms = 0.0;
  double total_ms = 0.0;
  double max_ms = 0.0;
  double meanMs() const { return count > 0 ? total_ms / static_cast<double>(count) : 0.0; }
  void add(double ms);
};

/// Keeps one StageStats per stage name, in first-use order.
class StageTimings {
 public:
  void add(const std::string& stage, double ms);
  /// Adds a whole StageStats (e.g. from another node's table) to the stage of the same name.
  void merge(const StageStats& stats);
  const std::vector<StageStats>& stages() const { return stages_; }
  const StageStats* find(const std::string& stage) const;
  /// Multi-line table "stage  count  mean  max" for run summaries.
  std::string table() const;

 private:
  std::vector<StageStats> stages_;
};

/// Measures from construction (or restart()) to elapsedMs().
class Stopwatch {
 public:
  Stopwatch() : start_(std::chrono::steady_clock::now()) {}
  void restart() { start_ = std::chrono::steady_clock::now(); }
  double elapsedMs() const {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_)
        .count();
  }

 private:
  std::chrono::steady_clock::time_point start_;
};

/// Adds the time of its scope to `timings` under `stage`.
class ScopedStageTimer {
 public:
  ScopedStageTimer(StageTimings& timings, std::string stage)
      : timings_(timings), stage_(std::move(stage)) {}
  ~ScopedStageTimer() { timings_.add(stage_, watch_.elapsedMs()); }
  ScopedStageTimer(const ScopedStageTimer&) = delete;
  ScopedStageTimer& operator=(const ScopedStageTimer&) = delete;

 private:
  StageTimings& timings_;
  std::string stage_;
  Stopwatch watch_;
};

/// Microseconds since the Unix epoch (host clock), for message utime fields.
int64_t hostUtime();

}  // namespace pplvo
