#pragma once
/// LCM event log files (the format of lcm-logger / lcm-logplayer and the file:// provider),
/// written and read through LCM's C eventlog API (<lcm/eventlog.h>; file I/O only, no LCM
/// transport). See docs/logger.md.
#include <cstdint>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

struct _lcm_eventlog_t;

namespace pplvo::logging {

/// Writing a log, trajectory or summary failed (full disk, I/O error). The message names the
/// file and the system error.
class LogWriteError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A log that cannot be opened for reading.
class LogReadError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Appends events to a new event log, flushing after every event so that a killed process
/// loses nothing it already wrote. After a write error the file is cut back to the end of the
/// last complete event (when the file system allows it) and every later write throws.
class EventLogWriter {
 public:
  /// Creates (truncates) `path`. Throws LogWriteError if it cannot be opened.
  explicit EventLogWriter(const std::string& path);
  ~EventLogWriter();
  EventLogWriter(const EventLogWriter&) = delete;
  EventLogWriter& operator=(const EventLogWriter&) = delete;

  /// Writes one event (receive time in microseconds since the epoch). Throws LogWriteError.
  void write(const std::string& channel, int64_t timestamp_us, const void* data, int32_t size);
  /// Flushes and closes; throws LogWriteError if the final flush fails. Idempotent.
  void close();

  const std::string& path() const { return path_; }
  int64_t eventsWritten() const { return events_; }
  int64_t bytesWritten() const { return good_offset_; }
  bool failed() const { return failed_; }

 private:
  [[noreturn]] void fail(const std::string& what, int err);
  std::string path_;
  _lcm_eventlog_t* log_ = nullptr;
  int64_t events_ = 0;
  int64_t good_offset_ = 0;  ///< bytes of complete, flushed events
  bool failed_ = false;
};

/// One event of a log.
struct LogEvent {
  int64_t eventnum = 0;
  int64_t timestamp_us = 0;
  std::string channel;
  std::vector<uint8_t> data;
};

/// Reads a log event by event and stops at the first incomplete or inconsistent event (a file
/// cut mid-event by a kill, a full disk or a copy): everything before it is returned intact,
/// and truncated() says that the file continues with bytes that are not a complete event.
class EventLogReader {
 public:
  /// Throws LogReadError if the file cannot be opened.
  explicit EventLogReader(const std::string& path);
  ~EventLogReader();
  EventLogReader(const EventLogReader&) = delete;
  EventLogReader& operator=(const EventLogReader&) = delete;

  /// Next complete event, or nullopt at the end (clean or truncated).
  std::optional<LogEvent> next();
  bool truncated() const { return truncated_; }
  /// Bytes of complete events read so far (the truncation point once next() returned nullopt).
  int64_t validBytes() const { return valid_bytes_; }
  /// Why reading stopped early, e.g. "incomplete event at byte 1234 (56 of 1080 bytes)".
  const std::string& truncationDetail() const { return detail_; }

 private:
  int64_t fileSize() const;
  std::string path_;
  _lcm_eventlog_t* log_ = nullptr;
  int64_t valid_bytes_ = 0;
  bool truncated_ = false;
  bool done_ = false;
  std::string detail_;
};

/// Result of reading a whole log.
struct EventLogReadResult {
  std::vector<LogEvent> events;
  bool truncated = false;   ///< the file ends with an incomplete or garbled event
  int64_t valid_bytes = 0;  ///< end of the last complete event
  int64_t file_bytes = 0;
  std::string detail;
};

/// Reads every complete event of `path` (at most max_events if >= 0). Throws LogReadError if
/// the file cannot be opened; never returns a partial event.
EventLogReadResult readEventLog(const std::string& path, int64_t max_events = -1);

}  // namespace pplvo::logging
