#include "pplvo/logging/logger_node.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <regex>
#include <pplvo_msgs/depth_map_t.hpp>
#include <pplvo_msgs/features_t.hpp>
#include <pplvo_msgs/node_status_t.hpp>
#include <pplvo_msgs/pose_t.hpp>
#include <pplvo_msgs/rgbd_frame_t.hpp>
#include <pplvo_msgs/stream_event_t.hpp>

#include "pplvo/core/args.h"
#include "pplvo/msgs/node_runtime.h"

namespace pplvo::logging {
namespace {

constexpr const char* kNode = "pplvo-logger";

int64_t fingerprint(const lcm::ReceiveBuffer* rbuf) {
  if (rbuf->data_size < 8) return 0;
  const auto* p = static_cast<const uint8_t*>(rbuf->data);
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v = (v << 8) | p[i];
  return static_cast<int64_t>(v);
}

/// Decodes a message of type T; throws MessageError (counted as skipped) if it does not decode.
template <typename T>
T decodeAs(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
  T msg;
  const std::string error = msgs::decodeMessage(rbuf->data, rbuf->data_size, &msg);
  if (!error.empty()) throw msgs::MessageError("cannot decode on " + channel + ": " + error);
  return msg;
}

/// Frame seq of the message types that carry one (rgbd_frame_t, depth_map_t, features_t,
/// pose_t), recognised by their LCM fingerprint.
std::optional<int64_t> frameSeq(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
  const int64_t fp = fingerprint(rbuf);
  if (fp == pplvo_msgs::rgbd_frame_t::getHash()) {
    return decodeAs<pplvo_msgs::rgbd_frame_t>(rbuf, channel).seq;
  }
  if (fp == pplvo_msgs::depth_map_t::getHash()) {
    return decodeAs<pplvo_msgs::depth_map_t>(rbuf, channel).seq;
  }
  if (fp == pplvo_msgs::features_t::getHash()) {
    return decodeAs<pplvo_msgs::features_t>(rbuf, channel).seq;
  }
  if (fp == pplvo_msgs::pose_t::getHash()) return decodeAs<pplvo_msgs::pose_t>(rbuf, channel).seq;
  return std::nullopt;
}

}  // namespace

std::string loggerUsage() {
  return R"(Usage: pplvo-logger [--output FILE.lcmlog] [--trajectory FILE] [--summary FILE] [options]
Records LCM channels to a standard LCM event log (readable by lcm-logplayer and file://),
the estimated trajectory (pose_t) as TUM lines, and a YAML run summary at exit.

  --output FILE            event log to write (flushed after every event)
  --force                  overwrite an existing --output file
  --channels REGEX         channels to record (LCM regex, whole name; default 'PPLVO_.*')
  --trajectory FILE        TUM trajectory from pose_t: stamp tx ty tz qx qy qz qw
  --summary FILE           run summary (YAML) written at exit
  --pose-channel NAME      default PPLVO_POSE
  --stream-channel NAME    default PPLVO_STREAM
  --status-channel NAME    default PPLVO_STATUS
  --until-end              stop once a stream_event_t END (or ERROR) arrived, after --drain
  --drain S                seconds to keep recording after END (default 1)
  --timeout S              stop after S seconds
  --idle-timeout S         stop after S seconds without any message
  --lcm-url URL            LCM URL (default: $LCM_DEFAULT_URL, else LCM's default)
)" + std::string(msgs::kRouteUsage) +
         R"(  --progress / --no-progress   progress line on stderr (default: when stderr is a terminal)
  -h, --help               this text
At least one of --output, --trajectory, --summary is required.

Exit status: 0 stopped normally (Ctrl-C, --until-end, --timeout, --idle-timeout), 1 write
error (full disk) or LCM failure, 2 bad command line, 3 --until-end was given but
--idle-timeout fired before the stream ended (upstream gone?).
)";
}

LoggerParseResult parseLoggerArgs(const std::vector<std::string>& args) {
  LoggerParseResult r;
  LoggerOptions& o = r.options;
  auto seconds = [](const std::string& name, double* out) {
    return [name, out](const std::string& v) -> std::string {
      double s = 0;
      if (!parseDouble(v, &s) || s < 0) return name + ": expected seconds >= 0, got '" + v + "'";
      *out = s;
      return "";
    };
  };
  ArgParser p;
  msgs::addRouteOption(p, &o.routes);
  p.option("--output", &o.output)
      .option("-o", &o.output)
      .option("--channels", &o.channels)
      .option("--trajectory", &o.trajectory)
      .option("--summary", &o.summary)
      .option("--pose-channel", &o.pose_channel)
      .option("--stream-channel", &o.stream_channel)
      .option("--status-channel", &o.status_channel)
      .option("--lcm-url", &o.lcm_url)
      .option("--drain", seconds("--drain", &o.drain_s))
      .option("--timeout", seconds("--timeout", &o.timeout_s))
      .option("--idle-timeout", seconds("--idle-timeout", &o.idle_timeout_s))
      .flag("--force", &o.force)
      .flag("--until-end", &o.until_end)
      .flag("--progress", &o.progress)
      .flag("--no-progress", &o.progress, false);
  p.parse(args);
  r.help = p.help();
  r.errors = p.errors();
  if (!r.help && o.output.empty() && o.trajectory.empty() && o.summary.empty()) {
    r.errors.push_back("nothing to record: give --output, --trajectory and/or --summary");
  }
  if (o.channels.empty()) r.errors.push_back("--channels must not be empty");
  // LCM 1.3.1 only prints a bad regex and then never matches: check it here (ECMAScript
  // syntax is close enough to GLib's PCRE to catch unbalanced brackets and the like).
  try {
    std::regex check(o.channels);
  } catch (const std::regex_error& e) {
    r.errors.push_back("--channels: invalid regular expression '" + o.channels + "': " + e.what());
  }
  return r;
}

std::string LoggerResult::summaryLine() const {
  char buf[320];
  std::snprintf(buf, sizeof buf, "logged %lld events (%.1f MB), %lld poses, %.1f s; stopped: %s",
                static_cast<long long>(summary.events_logged), summary.bytes_logged / 1e6,
                static_cast<long long>(summary.poses_written), summary.elapsed_s,
                summary.stop_reason.c_str());
  std::string s = buf;
  if (!summary.error.empty()) s += "; ERROR: " + summary.error;
  return s;
}

LoggerNode::LoggerNode(const LoggerOptions& options, msgs::Bus bus)
    : options_(options), bus_(std::move(bus)) {
  if (!options_.output.empty()) {
    std::error_code ec;
    if (!options_.force && std::filesystem::exists(options_.output, ec) &&
        std::filesystem::is_regular_file(options_.output, ec)) {
      throw LogWriteError("event log " + options_.output +
                          " already exists (use --force to overwrite)");
    }
    log_ = std::make_unique<EventLogWriter>(options_.output);
    summary_.log_path = options_.output;
  }
  if (!options_.trajectory.empty()) {
    trajectory_ = std::make_unique<TrajectoryWriter>(options_.trajectory);
    summary_.trajectory_path = options_.trajectory;
  }
  // Recording (event log or per-channel summary) listens to every channel of the pattern.
  // With only --trajectory it must not: on udpm that would join the frame channels' ports
  // and copy ~6.5 MB per 640x480 frame out of the kernel for nothing.
  if (log_ || !options_.summary.empty()) {
    subs_.push_back(bus_.subscribe(options_.channels, &LoggerNode::onRecord, this));
  }
  if (trajectory_)
    subs_.push_back(bus_.subscribe(options_.pose_channel, &LoggerNode::onPose, this));
  subs_.push_back(bus_.subscribe(options_.status_channel, &LoggerNode::onStatus, this));
  subs_.push_back(bus_.subscribe(options_.stream_channel, &LoggerNode::onStream, this));
  for (const msgs::BusSubscription& s : subs_) {
    for (const auto& part : s.parts) {
      if (!part.second) throw std::runtime_error("LCM subscription failed (bad --channels regex?)");
    }
  }
}

LoggerNode::~LoggerNode() {
  for (const msgs::BusSubscription& s : subs_) bus_.unsubscribe(s);
}

double LoggerNode::nowS() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

void LoggerNode::touch() { last_msg_s_ = nowS(); }

void LoggerNode::onRecord(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
  touch();
  if (!fatal_.empty()) return;
  msgs::guarded(counters_, kNode, [&] {
    if (log_) {
      try {
        log_->write(channel, rbuf->recv_utime, rbuf->data, static_cast<int32_t>(rbuf->data_size));
      } catch (const LogWriteError& e) {
        fatal_ = e.what();
        return;
      }
      summary_.events_logged = log_->eventsWritten();
      summary_.bytes_logged = log_->bytesWritten();
    }
    ChannelStats& stats = summary_.channels[channel];
    std::optional<int64_t> seq;
    try {
      seq = frameSeq(rbuf, channel);
    } catch (const msgs::MessageError&) {
      stats.add(static_cast<int64_t>(rbuf->data_size), rbuf->recv_utime, std::nullopt);
      throw;  // counted by guarded(); the raw event is logged anyway
    }
    stats.add(static_cast<int64_t>(rbuf->data_size), rbuf->recv_utime, seq);
  });
}

void LoggerNode::onPose(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
  touch();
  if (!fatal_.empty() || !trajectory_) return;
  msgs::guarded(counters_, kNode, [&] {
    const auto pose = decodeAs<pplvo_msgs::pose_t>(rbuf, channel);
    try {
      if (trajectory_->write(pose.stamp, pose.position, pose.orientation)) {
        summary_.poses_written = trajectory_->linesWritten();
      } else {
        ++summary_.poses_not_finite;
        counters_.last_warning = "pose of seq " + std::to_string(pose.seq) + " is not finite";
      }
    } catch (const LogWriteError& e) {
      fatal_ = e.what();
    }
  });
}

void LoggerNode::onStatus(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
  touch();
  msgs::guarded(counters_, kNode, [&] {
    const auto m = decodeAs<pplvo_msgs::node_status_t>(rbuf, channel);
    NodeSnapshot& n = summary_.nodes[m.node];
    n.node = m.node;
    n.utime = m.utime;
    n.last_seq = m.last_seq;
    n.frames_in = m.frames_in;
    n.frames_out = m.frames_out;
    n.frames_dropped = m.frames_dropped;
    n.frames_skipped = m.frames_skipped;
    n.frames_pending = m.frames_pending;
    n.frames_lost = m.frames_lost;
    n.messages_skipped = m.messages_skipped;
    n.errors = m.errors;
    n.last_warning = m.last_warning;
    n.stages.clear();
    for (const auto& s : m.stages)
      n.stages.push_back({s.name, s.count, s.last_ms, s.mean_ms, s.max_ms});
    ++n.reports;
  });
}

void LoggerNode::onStream(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
  touch();
  msgs::guarded(counters_, kNode, [&] {
    const auto m = decodeAs<pplvo_msgs::stream_event_t>(rbuf, channel);
    if (m.event == pplvo_msgs::stream_event_t::EVENT_START) {
      summary_.stream_start_seen = true;
    } else {
      summary_.stream_end_seen = true;
      summary_.stream_frames_published = m.frames_published;
      summary_.stream_frames_skipped = m.frames_skipped;
      if (end_seen_s_ < 0) end_seen_s_ = nowS();
    }
  });
}

void LoggerNode::progress(bool final_line) {
  if (!options_.progress) return;
  const double now = nowS();
  if (!final_line && now - last_progress_s_ < 0.5) return;
  last_progress_s_ = now;
  std::fprintf(stderr, "\r[%s] %lld events, %.1f MB, %lld poses, %.0f s   ", kNode,
               static_cast<long long>(summary_.events_logged), summary_.bytes_logged / 1e6,
               static_cast<long long>(summary_.poses_written), now - start_s_);
  if (final_line) std::fputc('\n', stderr);
  std::fflush(stderr);
}

LoggerResult LoggerNode::run() {
  LoggerResult result;
  start_s_ = nowS();
  last_msg_s_ = start_s_;
  std::string reason;
  auto done = [&]() -> bool {
    const double now = nowS();
    if (!fatal_.empty()) {
      reason = "write error";
    } else if (options_.until_end && end_seen_s_ >= 0 && now - end_seen_s_ >= options_.drain_s) {
      reason = "end of stream";
    } else if (options_.timeout_s > 0 && now - start_s_ >= options_.timeout_s) {
      reason = "timeout";
    } else if (options_.idle_timeout_s > 0 && now - last_msg_s_ >= options_.idle_timeout_s) {
      char buf[160];
      std::snprintf(buf, sizeof buf, "idle: no message for %.1f s (upstream stopped?)",
                    now - last_msg_s_);
      reason = buf;
      if (options_.until_end && end_seen_s_ < 0) result.exit_code = kExitNoEnd;
    }
    return !reason.empty();
  };
  try {
    msgs::spin(
        bus_, done, [&] { progress(false); }, 0.5);
  } catch (const std::exception& e) {
    if (fatal_.empty() && !msgs::shutdownRequested()) fatal_ = e.what();
  }
  if (reason.empty()) reason = msgs::shutdownRequested() ? "interrupted" : "stopped";
  if (!fatal_.empty() && reason != "write error") reason = "error";
  progress(true);

  try {
    if (log_) log_->close();
  } catch (const LogWriteError& e) {
    if (fatal_.empty()) fatal_ = e.what();
  }
  try {
    if (trajectory_) trajectory_->close();
  } catch (const LogWriteError& e) {
    if (fatal_.empty()) fatal_ = e.what();
  }
  summary_.stop_reason = reason;
  summary_.elapsed_s = nowS() - start_s_;
  summary_.handler_errors = counters_.errors + counters_.messages_skipped;
  summary_.error = fatal_;
  if (!options_.summary.empty()) {
    try {
      summary_.writeFile(options_.summary);
    } catch (const LogWriteError& e) {
      if (fatal_.empty()) fatal_ = e.what();
      summary_.error = fatal_;
    }
  }
  if (!fatal_.empty()) result.exit_code = kExitFailed;
  result.summary = summary_;
  return result;
}

}  // namespace pplvo::logging
