#pragma once
/// Trajectory files written live and the run summary of the logger (no LCM types here: the
/// logger node converts messages into these plain structs).
#include <cstdint>
#include <cstdio>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "pplvo/logging/event_log.h"

namespace pplvo::logging {

/// Writes TUM trajectory lines `stamp tx ty tz qx qy qz qw` (camera to world, T_w_c) as poses
/// arrive, flushing every line. The stamp is copied verbatim.
class TrajectoryWriter {
 public:
  /// Creates `path` and writes a '#' header line. Throws LogWriteError.
  explicit TrajectoryWriter(const std::string& path);
  ~TrajectoryWriter();
  TrajectoryWriter(const TrajectoryWriter&) = delete;
  TrajectoryWriter& operator=(const TrajectoryWriter&) = delete;

  /// position_m: T_w_c translation; q_wxyz: T_w_c rotation as w x y z (pose_t's order). Poses
  /// with a non-finite value are not written and return false. Throws LogWriteError.
  bool write(const std::string& stamp, const double position_m[3], const double q_wxyz[4]);
  void close();
  int64_t linesWritten() const { return lines_; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::FILE* f_ = nullptr;
  int64_t lines_ = 0;
};

/// Messages of one channel.
struct ChannelStats {
  int64_t messages = 0;
  int64_t bytes = 0;
  int64_t first_recv_utime = 0;
  int64_t last_recv_utime = 0;
  bool has_seq = false;  ///< the message type carries a frame seq
  int64_t first_seq = -1;
  int64_t last_seq = -1;
  int64_t gaps = 0;            ///< times seq jumped forward by more than 1
  int64_t missing_seq = 0;     ///< frames those jumps skipped
  int64_t non_increasing = 0;  ///< seq repeated or went back
  /// Counts one message; seq when its type has one.
  void add(int64_t bytes_in, int64_t recv_utime, std::optional<int64_t> seq);
};

/// Timing of one stage of a node, as its status reports it.
struct StageSnapshot {
  std::string name;
  int64_t count = 0;
  double last_ms = 0, mean_ms = 0, max_ms = 0;
};

/// Latest status of one node (from node_status_t).
struct NodeSnapshot {
  std::string node;
  int64_t utime = 0;
  int64_t last_seq = -1;
  int64_t frames_in = 0, frames_out = 0, frames_dropped = 0, frames_skipped = 0, errors = 0;
  int64_t frames_pending = 0, frames_lost = 0, messages_skipped = 0;
  std::vector<StageSnapshot> stages;
  std::string last_warning;
  int64_t reports = 0;  ///< status messages received from this node
};

/// Everything the run summary reports.
struct RunSummary {
  std::string log_path;
  int64_t events_logged = 0;
  int64_t bytes_logged = 0;
  std::string trajectory_path;
  int64_t poses_written = 0;
  int64_t poses_not_finite = 0;
  std::string stop_reason;
  double elapsed_s = 0.0;
  int64_t handler_errors = 0;
  std::string error;  ///< fatal error, if any
  bool stream_start_seen = false;
  bool stream_end_seen = false;
  int64_t stream_frames_published = -1;  ///< from the END event
  int64_t stream_frames_skipped = -1;
  std::map<std::string, ChannelStats> channels;
  std::map<std::string, NodeSnapshot> nodes;

  /// YAML text (keys documented in docs/logger.md).
  std::string toYaml() const;
  /// Writes toYaml() to `path`. Throws LogWriteError.
  void writeFile(const std::string& path) const;
};

}  // namespace pplvo::logging
