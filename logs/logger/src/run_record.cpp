#include "pplvo/logging/run_record.h"

#include <yaml-cpp/yaml.h>

#include <cerrno>
#include <cmath>
#include <cstring>

namespace pplvo::logging {
namespace {
std::string sysError(int err) { return err ? std::strerror(err) : "unknown error"; }
}  // namespace

TrajectoryWriter::TrajectoryWriter(const std::string& path) : path_(path) {
  errno = 0;
  f_ = std::fopen(path.c_str(), "w");
  if (!f_) throw LogWriteError("cannot create trajectory file " + path + ": " + sysError(errno));
  errno = 0;
  if (std::fputs("# pplvo trajectory: timestamp tx ty tz qx qy qz qw (camera to world)\n", f_) <
          0 ||
      std::fflush(f_) != 0) {
    const int err = errno;
    std::fclose(f_);
    f_ = nullptr;
    throw LogWriteError("cannot write trajectory file " + path + ": " + sysError(err));
  }
}

TrajectoryWriter::~TrajectoryWriter() {
  if (f_) std::fclose(f_);
}

bool TrajectoryWriter::write(const std::string& stamp, const double p[3], const double q[4]) {
  if (!f_) throw LogWriteError("trajectory file " + path_ + " is closed");
  for (int i = 0; i < 3; ++i) {
    if (!std::isfinite(p[i])) return false;
  }
  for (int i = 0; i < 4; ++i) {
    if (!std::isfinite(q[i])) return false;
  }
  errno = 0;
  // TUM order: qx qy qz qw; the message carries w x y z.
  const int n = std::fprintf(f_, "%s %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", stamp.c_str(), p[0],
                             p[1], p[2], q[1], q[2], q[3], q[0]);
  if (n < 0 || std::fflush(f_) != 0) {
    const int err = errno;
    std::fclose(f_);
    f_ = nullptr;
    throw LogWriteError("cannot write trajectory file " + path_ + ": " + sysError(err));
  }
  ++lines_;
  return true;
}

void TrajectoryWriter::close() {
  if (!f_) return;
  errno = 0;
  const int rc = std::fclose(f_);
  f_ = nullptr;
  if (rc != 0)
    throw LogWriteError("cannot close trajectory file " + path_ + ": " + sysError(errno));
}

void ChannelStats::add(int64_t bytes_in, int64_t recv_utime, std::optional<int64_t> seq) {
  if (messages == 0) first_recv_utime = recv_utime;
  last_recv_utime = recv_utime;
  ++messages;
  bytes += bytes_in;
  if (!seq) return;
  if (!has_seq) {
    has_seq = true;
    first_seq = last_seq = *seq;
    return;
  }
  if (*seq == last_seq + 1) {
    last_seq = *seq;
  } else if (*seq > last_seq + 1) {
    ++gaps;
    missing_seq += *seq - last_seq - 1;
    last_seq = *seq;
  } else {
    ++non_increasing;  // repeated or older frame (e.g. a restarted player)
    last_seq = *seq;
  }
}

std::string RunSummary::toYaml() const {
  YAML::Emitter y;
  y << YAML::BeginMap;
  y << YAML::Key << "stop_reason" << YAML::Value << stop_reason;
  y << YAML::Key << "elapsed_s" << YAML::Value << elapsed_s;
  if (!error.empty()) y << YAML::Key << "error" << YAML::Value << error;
  y << YAML::Key << "handler_errors" << YAML::Value << handler_errors;
  y << YAML::Key << "log" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "path" << YAML::Value << log_path;
  y << YAML::Key << "events" << YAML::Value << events_logged;
  y << YAML::Key << "bytes" << YAML::Value << bytes_logged;
  y << YAML::EndMap;
  y << YAML::Key << "trajectory" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "path" << YAML::Value << trajectory_path;
  y << YAML::Key << "poses" << YAML::Value << poses_written;
  y << YAML::Key << "poses_not_finite" << YAML::Value << poses_not_finite;
  y << YAML::EndMap;
  y << YAML::Key << "stream" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "start_seen" << YAML::Value << stream_start_seen;
  y << YAML::Key << "end_seen" << YAML::Value << stream_end_seen;
  y << YAML::Key << "frames_published" << YAML::Value << stream_frames_published;
  y << YAML::Key << "frames_skipped" << YAML::Value << stream_frames_skipped;
  y << YAML::EndMap;
  y << YAML::Key << "channels" << YAML::Value << YAML::BeginMap;
  for (const auto& [name, c] : channels) {
    y << YAML::Key << name << YAML::Value << YAML::BeginMap;
    y << YAML::Key << "messages" << YAML::Value << c.messages;
    y << YAML::Key << "bytes" << YAML::Value << c.bytes;
    const double span_s = (c.last_recv_utime - c.first_recv_utime) * 1e-6;
    y << YAML::Key << "rate_hz" << YAML::Value
      << (c.messages > 1 && span_s > 0 ? (c.messages - 1) / span_s : 0.0);
    if (c.has_seq) {
      y << YAML::Key << "first_seq" << YAML::Value << c.first_seq;
      y << YAML::Key << "last_seq" << YAML::Value << c.last_seq;
      y << YAML::Key << "gaps" << YAML::Value << c.gaps;
      y << YAML::Key << "missing_seq" << YAML::Value << c.missing_seq;
      y << YAML::Key << "non_increasing" << YAML::Value << c.non_increasing;
    }
    y << YAML::EndMap;
  }
  y << YAML::EndMap;
  y << YAML::Key << "nodes" << YAML::Value << YAML::BeginMap;
  for (const auto& [name, n] : nodes) {
    y << YAML::Key << name << YAML::Value << YAML::BeginMap;
    y << YAML::Key << "reports" << YAML::Value << n.reports;
    y << YAML::Key << "last_seq" << YAML::Value << n.last_seq;
    y << YAML::Key << "frames_in" << YAML::Value << n.frames_in;
    y << YAML::Key << "frames_out" << YAML::Value << n.frames_out;
    y << YAML::Key << "frames_dropped" << YAML::Value << n.frames_dropped;
    y << YAML::Key << "frames_skipped" << YAML::Value << n.frames_skipped;
    y << YAML::Key << "frames_pending" << YAML::Value << n.frames_pending;
    y << YAML::Key << "frames_lost" << YAML::Value << n.frames_lost;
    y << YAML::Key << "messages_skipped" << YAML::Value << n.messages_skipped;
    y << YAML::Key << "errors" << YAML::Value << n.errors;
    y << YAML::Key << "last_warning" << YAML::Value << n.last_warning;
    y << YAML::Key << "stages" << YAML::Value << YAML::BeginMap;
    for (const auto& s : n.stages) {
      y << YAML::Key << s.name << YAML::Value << YAML::Flow << YAML::BeginMap;
      y << YAML::Key << "count" << YAML::Value << s.count;
      y << YAML::Key << "mean_ms" << YAML::Value << s.mean_ms;
      y << YAML::Key << "max_ms" << YAML::Value << s.max_ms;
      y << YAML::Key << "last_ms" << YAML::Value << s.last_ms;
      y << YAML::EndMap;
    }
    y << YAML::EndMap;
    y << YAML::EndMap;
  }
  y << YAML::EndMap;
  y << YAML::EndMap;
  return std::string(y.c_str()) + "\n";
}

void RunSummary::writeFile(const std::string& path) const {
  const std::string text = toYaml();
  errno = 0;
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (!f) throw LogWriteError("cannot create summary file " + path + ": " + sysError(errno));
  errno = 0;
  const bool ok = std::fwrite(text.data(), 1, text.size(), f) == text.size() && std::fflush(f) == 0;
  const int err = errno;
  const bool closed = std::fclose(f) == 0;
  if (!ok || !closed) {
    throw LogWriteError("cannot write summary file " + path + ": " + sysError(err));
  }
}

}  // namespace pplvo::logging
