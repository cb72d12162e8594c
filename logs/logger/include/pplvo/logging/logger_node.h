#pragma once
/// pplvo-logger: records LCM channels to an event log, the estimated trajectory to a TUM file
/// and a run summary. A thin LCM node over pplvo_logging; usage in docs/logger.md.
#include <cstdint>
#include <lcm/lcm-cpp.hpp>
#include <memory>
#include <string>
#include <vector>

#include "pplvo/logging/event_log.h"
#include "pplvo/logging/run_record.h"
#include "pplvo/msgs/bus.h"
#include "pplvo/msgs/channels.h"
#include "pplvo/msgs/convert.h"

namespace pplvo::logging {

struct LoggerOptions {
  std::string lcm_url;                             ///< --lcm-url; empty: $LCM_DEFAULT_URL
  std::vector<msgs::ChannelRoute> routes;          ///< --route: channels carried by other URLs
  std::string output;                              ///< --output FILE.lcmlog (event log)
  bool force = false;                              ///< --force: overwrite an existing log
  std::string channels = "PPLVO_.*";               ///< --channels: LCM regex (whole name)
  std::string trajectory;                          ///< --trajectory FILE (TUM lines)
  std::string summary;                             ///< --summary FILE (YAML at exit)
  std::string pose_channel = channels::kPose;      ///< --pose-channel
  std::string stream_channel = channels::kStream;  ///< --stream-channel
  std::string status_channel = channels::kStatus;  ///< --status-channel
  bool until_end = false;       ///< --until-end: stop after stream_event_t END plus drain_s
  double drain_s = 1.0;         ///< --drain: seconds to keep recording after END
  double timeout_s = 0.0;       ///< --timeout: stop after this many seconds (0 = never)
  double idle_timeout_s = 0.0;  ///< --idle-timeout: stop after this long without messages
  bool progress = false;        ///< progress line on stderr (main: isatty)
};

struct LoggerParseResult {
  LoggerOptions options;
  std::vector<std::string> errors;
  bool help = false;
};
LoggerParseResult parseLoggerArgs(const std::vector<std::string>& args);
std::string loggerUsage();

/// Exit statuses of pplvo-logger.
enum LoggerExit : int {
  kExitOk = 0,      ///< stopped by Ctrl-C, --until-end, --timeout, or --idle-timeout alone
  kExitFailed = 1,  ///< write error (full disk), LCM failure
  kExitUsage = 2,   ///< bad command line
  kExitNoEnd = 3,   ///< --until-end given, but the idle timeout fired before any END
};

struct LoggerResult {
  RunSummary summary;
  int exit_code = kExitOk;
  /// "logged 812 events (310.2 MB), 251 poses; stopped: end of stream"
  std::string summaryLine() const;
};

class LoggerNode {
 public:
  /// Opens the outputs (throws LogWriteError naming the file) and subscribes.
  LoggerNode(const LoggerOptions& options, msgs::Bus bus);
  ~LoggerNode();
  LoggerNode(const LoggerNode&) = delete;
  LoggerNode& operator=(const LoggerNode&) = delete;

  /// Records until a stop condition; writes the summary file. Never throws.
  LoggerResult run();

  const RunSummary& summary() const { return summary_; }

 private:
  void onRecord(const lcm::ReceiveBuffer* rbuf, const std::string& channel);
  void onPose(const lcm::ReceiveBuffer* rbuf, const std::string& channel);
  void onStatus(const lcm::ReceiveBuffer* rbuf, const std::string& channel);
  void onStream(const lcm::ReceiveBuffer* rbuf, const std::string& channel);
  void touch();
  void progress(bool final_line);
  double nowS() const;

  LoggerOptions options_;
  msgs::Bus bus_;
  std::unique_ptr<EventLogWriter> log_;
  std::unique_ptr<TrajectoryWriter> trajectory_;
  std::vector<msgs::BusSubscription> subs_;
  RunSummary summary_;
  msgs::NodeCounters counters_;
  std::string fatal_;
  double start_s_ = 0.0;
  double last_msg_s_ = 0.0;
  double end_seen_s_ = -1.0;
  double last_progress_s_ = -1e9;
};

}  // namespace pplvo::logging
