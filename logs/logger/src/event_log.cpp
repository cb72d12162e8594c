#include "pplvo/logging/event_log.h"

#include <lcm/eventlog.h>
#include <stdio_ext.h>  // __fpurge (glibc)
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace pplvo::logging {
namespace {

constexpr uint32_t kSyncWord = 0xEDA1DA01u;
constexpr int64_t kHeaderBytes = 4 + 8 + 8 + 4 + 4;  // sync, eventnum, timestamp, lengths
constexpr int32_t kMaxChannelBytes = 1000;           // LCM readers reject longer names

uint32_t be32(const unsigned char* p) {
  return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | uint32_t(p[3]);
}

std::string sysError(int err) { return err ? std::strerror(err) : "unknown error"; }

}  // namespace

EventLogWriter::EventLogWriter(const std::string& path) : path_(path) {
  errno = 0;
  log_ = lcm_eventlog_create(path.c_str(), "w");
  if (!log_) {
    throw LogWriteError("cannot create event log " + path + ": " + sysError(errno));
  }
}

EventLogWriter::~EventLogWriter() {
  try {
    close();
  } catch (const LogWriteError&) {
    // Reported by an explicit close(); a destructor must not throw.
  }
}

void EventLogWriter::fail(const std::string& what, int err) {
  failed_ = true;
  if (log_) {
    // Drop what is buffered and cut the file back to the last complete event, so the log stays
    // readable to its end (on a full disk the cut frees the space the partial event took).
    __fpurge(log_->f);
    clearerr(log_->f);
    if (::ftruncate(fileno(log_->f), static_cast<off_t>(good_offset_)) != 0) {
      // Not possible on character devices such as /dev/full; readers stop at the cut anyway.
    }
  }
  throw LogWriteError(what + " " + path_ + ": " + sysError(err) + " (" + std::to_string(events_) +
                      " complete events kept)");
}

void EventLogWriter::write(const std::string& channel, int64_t timestamp_us, const void* data,
                           int32_t size) {
  if (failed_ || !log_) {
    throw LogWriteError("event log " + path_ + " is closed after an earlier error");
  }
  if (channel.empty() || channel.size() >= static_cast<size_t>(kMaxChannelBytes)) {
    throw LogWriteError("channel name of " + std::to_string(channel.size()) +
                        " bytes cannot be logged");
  }
  if (size < 0) throw LogWriteError("negative event size");
  lcm_eventlog_event_t ev{};
  ev.timestamp = timestamp_us;
  ev.channellen = static_cast<int32_t>(channel.size());
  ev.datalen = size;
  ev.channel = const_cast<char*>(channel.data());
  ev.data = const_cast<void*>(data);
  errno = 0;
  if (lcm_eventlog_write_event(log_, &ev) != 0) fail("cannot write event log", errno);
  errno = 0;
  if (std::fflush(log_->f) != 0 || std::ferror(log_->f)) fail("cannot write event log", errno);
  ++events_;
  good_offset_ += kHeaderBytes + ev.channellen + ev.datalen;
}

void EventLogWriter::close() {
  if (!log_) return;
  int err = 0;
  const bool ok = failed_ || (std::fflush(log_->f) == 0 && !std::ferror(log_->f));
  if (!ok) err = errno;
  lcm_eventlog_destroy(log_);
  log_ = nullptr;
  if (!ok) {
    failed_ = true;
    throw LogWriteError("cannot write event log " + path_ + ": " + sysError(err));
  }
}

EventLogReader::EventLogReader(const std::string& path) : path_(path) {
  errno = 0;
  log_ = lcm_eventlog_create(path.c_str(), "r");
  if (!log_) throw LogReadError("cannot open event log " + path + ": " + sysError(errno));
}

EventLogReader::~EventLogReader() {
  if (log_) lcm_eventlog_destroy(log_);
}

int64_t EventLogReader::fileSize() const {
  struct stat st {};
  if (::fstat(fileno(log_->f), &st) != 0) return -1;
  return static_cast<int64_t>(st.st_size);
}

std::optional<LogEvent> EventLogReader::next() {
  if (done_) return std::nullopt;
  auto stop = [&](const std::string& why) -> std::optional<LogEvent> {
    done_ = true;
    if (!why.empty()) {
      truncated_ = true;
      detail_ = why;
    }
    return std::nullopt;
  };
  const int64_t pos = valid_bytes_;
  const int64_t size = fileSize();
  if (size < 0) return stop("cannot stat " + path_);
  const int64_t left = size - pos;
  if (left == 0) return stop("");
  const std::string at = " at byte " + std::to_string(pos);
  if (left < kHeaderBytes) {
    return stop("incomplete event header" + at + " (" + std::to_string(left) + " of " +
                std::to_string(kHeaderBytes) + " bytes)");
  }
  // Check the header ourselves before handing the event to lcm_eventlog: it would scan ahead
  // for the next sync word on garbage and allocate whatever length a garbled header claims.
  unsigned char h[kHeaderBytes];
  if (::fseeko(log_->f, static_cast<off_t>(pos), SEEK_SET) != 0 ||
      std::fread(h, 1, sizeof h, log_->f) != sizeof h) {
    return stop("read error" + at);
  }
  if (be32(h) != kSyncWord) return stop("no event sync word" + at);
  const int32_t channellen = static_cast<int32_t>(be32(h + 20));
  const int32_t datalen = static_cast<int32_t>(be32(h + 24));
  if (channellen <= 0 || channellen >= kMaxChannelBytes || datalen < 0) {
    return stop("garbled event header" + at);
  }
  const int64_t total = kHeaderBytes + channellen + int64_t(datalen);
  if (total > left) {
    return stop("incomplete event" + at + " (" + std::to_string(left) + " of " +
                std::to_string(total) + " bytes)");
  }
  if (::fseeko(log_->f, static_cast<off_t>(pos), SEEK_SET) != 0) return stop("seek error" + at);
  lcm_eventlog_event_t* ev = lcm_eventlog_read_next_event(log_);
  if (!ev) return stop("lcm_eventlog could not read the event" + at);
  LogEvent out;
  out.eventnum = ev->eventnum;
  out.timestamp_us = ev->timestamp;
  out.channel.assign(ev->channel, static_cast<size_t>(ev->channellen));
  const auto* bytes = static_cast<const uint8_t*>(ev->data);
  out.data.assign(bytes, bytes + ev->datalen);
  lcm_eventlog_free_event(ev);
  valid_bytes_ = pos + total;
  return out;
}

EventLogReadResult readEventLog(const std::string& path, int64_t max_events) {
  EventLogReader reader(path);
  EventLogReadResult r;
  while (max_events < 0 || static_cast<int64_t>(r.events.size()) < max_events) {
    auto ev = reader.next();
    if (!ev) break;
    r.events.push_back(std::move(*ev));
  }
  r.truncated = reader.truncated();
  r.valid_bytes = reader.validBytes();
  r.detail = reader.truncationDetail();
  struct stat st {};
  r.file_bytes = ::stat(path.c_str(), &st) == 0 ? static_cast<int64_t>(st.st_size) : -1;
  return r;
}

}  // namespace pplvo::logging
