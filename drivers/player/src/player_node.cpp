#include "pplvo/player/player_node.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <future>
#include <pplvo_msgs/rgbd_frame_t.hpp>
#include <pplvo_msgs/stream_event_t.hpp>
#include <sstream>

#include "pplvo/core/args.h"
#include "pplvo/msgs/node_runtime.h"

namespace pplvo::player {
namespace {

using Img = pplvo_msgs::image_t;

dataset::DatasetOptions datasetOptions(const PlayerOptions& o) {
  dataset::DatasetOptions d;
  d.camera_file = o.camera_file;
  d.index_frame_rate_hz = o.fps;
  return d;
}

/// A frame read ahead: the item (none at the end of the sequence), the reader's counts after
/// it, a load error to rethrow when its turn comes, and the time it took to decode.
struct Fetched {
  std::optional<dataset::DatasetReader::Item> item;
  dataset::ReadStats stats;
  std::exception_ptr error;
  double load_ms = 0.0;
};

/// The frames in play order. The next frame is decoded on a worker thread while the current
/// one waits for its slot and is published (PNG decoding is the slowest step). Only one task
/// touches the reader at a time: seek() and the next fetch happen after get().
class FrameFeed {
 public:
  FrameFeed(dataset::DatasetReader& reader, size_t start) : reader_(reader), resume_index_(start) {}

  /// --preload: frames decoded now, up to `limit_bytes` (or `max_frames` > 0), then served
  /// from memory; the rest (if any) is decoded while playing, from `resume_index_` on. When
  /// everything fitted, the end marker or a load error is the last entry, so that it surfaces
  /// at the same point of the stream as without --preload.
  void preload(int64_t limit_bytes, int64_t max_frames, const std::string& node_name) {
    int64_t bytes = 0, frames = 0;
    while (!msgs::shutdownRequested()) {
      Fetched f = fetch();
      const bool last = !f.item || f.error;
      if (f.item) {
        const dataset::RawFrame& raw = f.item->frame;
        bytes += static_cast<int64_t>(raw.bgr.total() * raw.bgr.elemSize() +
                                      raw.depth_units.total() * raw.depth_units.elemSize());
        ++frames;
        resume_index_ = f.item->index + 1;
      }
      preloaded_.push_back(std::move(f));
      if (last) {
        preloaded_all_ = true;
        break;
      }
      // Enough for --max-frames (unless one fails to encode: then the rest streams).
      if (max_frames > 0 && frames >= max_frames) break;
      if (bytes >= limit_bytes) {
        std::fprintf(stderr,
                     "[%s] preloaded %lld frames (%lld MiB, --preload-max-mb); the rest is "
                     "decoded while playing\n",
                     node_name.c_str(), static_cast<long long>(frames),
                     static_cast<long long>(bytes >> 20));
        break;
      }
    }
  }
  /// Starts decoding the next frame, unless it is in memory or there is nothing beyond them.
  void fetchNext() {
    if (next_preloaded_ < preloaded_.size() || preloaded_all_) return;
    pending_ = std::async(std::launch::async, [this] { return fetch(); });
  }
  /// The next frame (waiting for its decoding).
  Fetched take() {
    if (next_preloaded_ < preloaded_.size()) return preloaded_[next_preloaded_++];
    if (!pending_.valid()) return Fetched{};  // interrupted while preloading: the end
    return pending_.get();
  }
  /// --loop: back to the first frame; without --preload from the start, with it after the
  /// frames held in memory.
  void rewind() {
    next_preloaded_ = 0;
    reader_.seek(resume_index_);
    fetchNext();
  }

 private:
  Fetched fetch() {
    Fetched f;
    Stopwatch watch;
    try {
      f.item = reader_.next();  // throws FrameLoadError without --skip-bad
    } catch (...) {
      f.error = std::current_exception();
    }
    f.stats = reader_.stats();
    f.load_ms = watch.elapsedMs();
    return f;
  }

  dataset::DatasetReader& reader_;
  std::vector<Fetched> preloaded_;
  size_t next_preloaded_ = 0;
  bool preloaded_all_ = false;
  size_t resume_index_;
  std::future<Fetched> pending_;
};

/// Duration of one pass from `start` plus one frame period: keeps utime increasing across
/// --loop passes.
int64_t passDurationUs(const std::vector<dataset::DatasetEntry>& entries, size_t start) {
  return (entries.back().utime - entries[start].utime) +
         (entries.size() - start > 1 ? (entries.back().utime - entries[start].utime) /
                                           static_cast<int64_t>(entries.size() - start - 1)
                                     : 33333);
}

/// Real-time pacing (--rate > 0): the wall time and stream time (or frame count for --fps) of
/// a reference frame, from which each frame's publish time follows.
struct PacingClock {
  bool anchored = false;
  double anchor_wall_s = 0.0;
  int64_t anchor_utime = 0;
  int64_t anchor_count = 0;

  /// When to publish the frame stamped `utime`, the `published`-th; restarts the clock on the
  /// first frame, when the player fell behind by more than --max-lag or the stamps jumped.
  double target(double now, int64_t utime, int64_t published, const PlayerOptions& o) {
    double t = now;
    if (anchored) {
      t = o.fps > 0 ? anchor_wall_s + (published - anchor_count) / (o.fps * o.rate)
                    : anchor_wall_s + (utime - anchor_utime) * 1e-6 / o.rate;
    }
    if (!anchored || now - t > o.max_lag_s || t - now > 60.0) {
      anchored = true;
      anchor_wall_s = now;
      anchor_utime = utime;
      anchor_count = published;
      t = now;
    }
    return t;
  }
};

}  // namespace

std::string playerUsage() {
  return R"(Usage: pplvo-player --dataset DIR [options]
Publishes a TUM-layout RGB-D folder (rgb/, depth/, associations.txt or rgb.txt+depth.txt,
calib_params.xml) as pplvo_msgs.rgbd_frame_t.

  --dataset DIR            dataset folder (required)
  --camera FILE.yaml       camera file (keys: width height fx fy cx cy distortion depth_scale);
                           default: DIR/calib_params.xml
  --lcm-url URL            LCM URL (default: $LCM_DEFAULT_URL, else LCM's default)
)" + std::string(msgs::kRouteUsage) +
         R"(  --channel NAME           frame channel (default PPLVO_RGBD)
  --pose-channel NAME      pose channel for --lockstep (default PPLVO_POSE)
  --stream-channel NAME    START/END events (default PPLVO_STREAM)
  --status-channel NAME    node_status_t (default PPLVO_STATUS)
  --rate R                 1 = real time from the stamps, 2 = twice as fast,
                           0 = as fast as possible (default 1)
  --fps F                  fixed publish rate in Hz instead of the stamps (scaled by --rate);
                           also the frame rate of frame-index stamps (ICL-NUIM, default 30)
  --lockstep               publish the next frame only after a pose_t of the frame
                           --lockstep-in-flight frames before it arrived on the pose channel
                           (and wait for the last frame's pose at the end)
  --lockstep-in-flight N   frames published without their pose in lockstep (default 2: the
                           next frame's features are extracted while this one is fused;
                           1 = one frame at a time)
  --lockstep-timeout S     seconds to wait for that pose before warning and going on (default 5)
  --start N                first associated frame to publish (default 0)
  --max-frames N           publish at most N frames (default 0 = all)
  --max-depth-m M          depth beyond M metres is published as missing (default: no limit)
  --skip-bad               skip (and count) frames whose images are missing or corrupt;
                           without it such a frame is a fatal error
  --rgb-encoding E         raw | jpeg | png (default raw)
  --jpeg-quality Q         JPEG quality 1..100 (default 90)
  --depth-encoding E       raw | zlib | png (default raw)
  --loop                   start over at the end (seq keeps counting; utime keeps increasing)
  --preload                decode frames (up to --max-frames and --preload-max-mb) before
                           publishing the first: no PNG decoding competes with the pipeline
                           while they play, as with a camera (width x height x 5 bytes each);
                           frames beyond the bound are decoded while playing
  --preload-max-mb N       memory for --preload, MiB (2048)
  --progress / --no-progress   progress line on stderr (default: when stderr is a terminal)
  -h, --help               this text

Exit status: 0 done (or stopped by Ctrl-C), 1 fatal error, 2 bad command line.
)";
}

ParseResult parsePlayerArgs(const std::vector<std::string>& args) {
  ParseResult r;
  PlayerOptions& o = r.options;
  auto encoding = [](const char* name, std::vector<std::pair<const char*, int8_t>> choices,
                     int8_t* out) {
    return [=](const std::string& v) -> std::string {
      std::string names;
      for (size_t k = 0; k < choices.size(); ++k) {
        if (v == choices[k].first) {
          *out = choices[k].second;
          return "";
        }
        names += (k == 0                    ? ""
                  : k + 1 == choices.size() ? " or "
                                            : ", ") +
                 std::string(choices[k].first);
      }
      return std::string(name) + " must be " + names + ", got '" + v + "'";
    };
  };
  ArgParser p;
  msgs::addRouteOption(p, &o.routes);
  p.option("--dataset", &o.dataset_dir)
      .option("--camera", &o.camera_file)
      .option("--lcm-url", &o.lcm_url)
      .option("--channel", &o.channel)
      .option("--pose-channel", &o.pose_channel)
      .option("--stream-channel", &o.stream_channel)
      .option("--status-channel", &o.status_channel)
      .option("--rate", &o.rate, 0.0)
      .option("--fps", &o.fps, 0.0)
      .option("--lockstep-timeout", &o.lockstep_timeout_s, 0.0)
      .option("--max-depth-m", &o.max_depth_m, 0.0)
      .option("--start", &o.start, int64_t{0})
      .option("--max-frames", &o.max_frames, int64_t{0})
      .option("--lockstep-in-flight", &o.lockstep_in_flight, 1, 1000)
      .option("--jpeg-quality", &o.jpeg_quality, 1, 100)
      .option("--rgb-encoding", encoding("--rgb-encoding",
                                         {{"raw", Img::ENCODING_RAW_BGR8},
                                          {"jpeg", Img::ENCODING_JPEG},
                                          {"png", Img::ENCODING_PNG}},
                                         &o.rgb_encoding))
      .option("--depth-encoding", encoding("--depth-encoding",
                                           {{"raw", Img::ENCODING_RAW_U16},
                                            {"zlib", Img::ENCODING_ZLIB_U16},
                                            {"png", Img::ENCODING_PNG_U16}},
                                           &o.depth_encoding))
      .flag("--lockstep", &o.lockstep)
      .flag("--skip-bad", &o.skip_bad)
      .flag("--loop", &o.loop)
      .flag("--preload", &o.preload)
      .option("--preload-max-mb", &o.preload_max_mb, int64_t{1})
      .flag("--progress", &o.progress)
      .flag("--no-progress", &o.progress, false);
  p.parse(args);
  r.help = p.help();
  r.errors = p.errors();
  if (!r.help && o.dataset_dir.empty()) r.errors.push_back("--dataset DIR is required");
  if (o.channel.empty()) r.errors.push_back("--channel must not be empty");
  return r;
}

std::string PlayerResult::summaryLine() const {
  char buf[256];
  std::snprintf(buf, sizeof buf, "published %lld frames, skipped %lld, %.2f s, %.1f frames/s",
                static_cast<long long>(published), static_cast<long long>(skipped), elapsed_s,
                elapsed_s > 0 ? published / elapsed_s : 0.0);
  std::string s = buf;
  if (lockstep_timeouts > 0) s += ", " + std::to_string(lockstep_timeouts) + " lockstep timeouts";
  if (loops > 0) s += ", " + std::to_string(loops) + " loops";
  if (interrupted) s += " (interrupted)";
  if (failed) s += " (FAILED: " + error + ")";
  return s;
}

PlayerNode::PlayerNode(const PlayerOptions& options, msgs::Bus bus)
    : options_(options),
      bus_(std::move(bus)),
      dataset_(dataset::Dataset::open(options.dataset_dir, datasetOptions(options))) {
  if (options_.lockstep) {
    pose_sub_ = bus_.subscribe(options_.pose_channel, &PlayerNode::onPose, this, counters_,
                               options_.node_name);
  }
}

PlayerNode::~PlayerNode() { bus_.unsubscribe(pose_sub_); }

double PlayerNode::nowS() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

void PlayerNode::onPose(const lcm::ReceiveBuffer*, const std::string&,
                        const pplvo_msgs::pose_t* msg) {
  msgs::guarded(counters_, options_.node_name.c_str(), [&] {
    if (msg->seq > last_pose_seq_) last_pose_seq_ = msg->seq;
  });
}

void PlayerNode::publishStream(int8_t event, const PlayerResult& result) {
  pplvo_msgs::stream_event_t ev;
  ev.utime = hostUtime();
  ev.source = dataset_.dir();
  ev.event = event;
  ev.frames_published = result.published;
  ev.frames_skipped = result.skipped;
  bus_.publish(options_.stream_channel, &ev);
}

std::string progressLine(const std::string& name, int64_t done, int64_t total, double elapsed_s,
                         int64_t skipped) {
  const double rate = elapsed_s > 0 ? done / elapsed_s : 0.0;
  char buf[256];
  if (total <= 0) {
    std::snprintf(buf, sizeof buf, "[%s] %lld frames, %.1f frames/s, skipped %lld", name.c_str(),
                  static_cast<long long>(done), rate, static_cast<long long>(skipped));
    return buf;
  }
  char eta[32] = "--:--";
  if (rate > 0) {
    const long long s = std::llround(std::max<int64_t>(0, total - done) / rate);
    std::snprintf(eta, sizeof eta, "%lld:%02lld", s / 60, s % 60);
  }
  std::snprintf(buf, sizeof buf, "[%s] %lld/%lld frames, %.1f frames/s, ETA %s, skipped %lld",
                name.c_str(), static_cast<long long>(done), static_cast<long long>(total), rate,
                eta, static_cast<long long>(skipped));
  return buf;
}

void PlayerNode::periodic(bool force) {
  const double now = nowS();
  if (force || now - last_status_s_ >= options_.status_period_s) {
    last_status_s_ = now;
    // Forced only as the player ends: its final status.
    auto msg =
        msgs::toStatusMsg(options_.node_name, counters_, timings_, hostUtime(), /*final=*/force);
    msgs::appendBlockedPublishes(bus_, &msg);
    bus_.publish(options_.status_channel, &msg);
  }
  if (options_.progress && (force || now - last_progress_s_ >= 0.25)) {
    last_progress_s_ = now;
    // Frames this run publishes: from --start to the end, or --max-frames (unknown: --loop).
    const int64_t available =
        std::max<int64_t>(0, static_cast<int64_t>(dataset_.size()) - options_.start);
    int64_t total = options_.loop ? 0 : available;
    if (options_.max_frames > 0) {
      total = options_.loop ? options_.max_frames : std::min(available, options_.max_frames);
    }
    const std::string line = progressLine(options_.node_name, published_, total, now - start_s_,
                                          counters_.frames_skipped);
    std::fprintf(stderr, "\r%s   ", line.c_str());
    std::fflush(stderr);
  }
}

void PlayerNode::drain() {
  // memq queues until handled: dispatch what is pending so subscribers on this instance run
  // and the queue does not grow (bounded in case a handler keeps republishing).
  for (int i = 0; i < 100000; ++i) {
    const int rc = bus_.handleTimeout(0);
    if (rc < 0 && !msgs::shutdownRequested()) throw std::runtime_error("LCM handle failed");
    if (rc < 0) break;
    // In process, the workers' last results (the last frames' fusion and lifting) too.
    if (rc == 0 && !inProcessWorkPublished()) break;
  }
}

void PlayerNode::waitUntil(double target_s) {
  while (!msgs::shutdownRequested()) {
    const double remaining = target_s - nowS();
    if (remaining <= 0) break;
    const int ms = static_cast<int>(std::min(100.0, std::ceil(remaining * 1000.0)));
    // EINTR from Ctrl-C ends the wait; the loop then sees the shutdown request.
    if (bus_.handleTimeout(ms) < 0 && !msgs::shutdownRequested()) {
      throw std::runtime_error("LCM handle failed");
    }
    periodic(false);
  }
}

bool PlayerNode::waitForPose(int64_t seq) {
  if (options_.in_process) {
    while (last_pose_seq_ < seq && !msgs::shutdownRequested()) {
      const int rc = bus_.handleTimeout(0);
      if (rc < 0 && !msgs::shutdownRequested()) throw std::runtime_error("LCM handle failed");
      if (rc < 0) break;
      if (rc == 0 && !inProcessWorkPublished()) break;
    }
    return last_pose_seq_ >= seq;
  }
  const double deadline = nowS() + options_.lockstep_timeout_s;
  msgs::spin(
      bus_, [&] { return last_pose_seq_ >= seq || nowS() >= deadline; }, [&] { periodic(false); },
      0.05);
  return last_pose_seq_ >= seq;
}

PlayerResult PlayerNode::run() {
  PlayerResult result;
  start_s_ = nowS();
  try {
    publishStream(pplvo_msgs::stream_event_t::EVENT_START, result);
    runLoop(result);
  } catch (const std::exception& e) {
    result.failed = true;
    result.error = e.what();
  }
  result.published = published_;
  result.skipped = counters_.frames_skipped;
  result.interrupted = msgs::shutdownRequested();
  result.elapsed_s = nowS() - start_s_;
  if (result.failed) counters_.last_warning = result.error;
  try {
    publishStream(result.failed ? pplvo_msgs::stream_event_t::EVENT_ERROR
                                : pplvo_msgs::stream_event_t::EVENT_END,
                  result);
    periodic(true);
    drain();
  } catch (const std::exception& e) {
    if (!result.failed) {
      result.failed = true;
      result.error = e.what();
    }
  }
  if (options_.progress) std::fputc('\n', stderr);
  return result;
}

void PlayerNode::runLoop(PlayerResult& result) {
  dataset::FrameLoadOptions load;
  load.max_depth_m = options_.max_depth_m;
  const size_t start = static_cast<size_t>(options_.start);
  if (start >= dataset_.size()) {
    throw std::runtime_error("--start " + std::to_string(options_.start) + " is beyond the " +
                             std::to_string(dataset_.size()) + " frames of the dataset");
  }
  dataset::DatasetReader reader(dataset_, options_.skip_bad, load, start);
  const pplvo_msgs::camera_info_t camera_msg = msgs::toMsg(dataset_.camera().camera);
  const int64_t pass_us = passDurationUs(dataset_.index().entries, start);
  int64_t loop_offset_us = 0;
  int64_t published_this_pass = 0;
  int64_t skipped_before = 0;
  PacingClock pacing;

  FrameFeed feed(reader, start);
  if (options_.preload) {
    ScopedStageTimer t(timings_, "preload");
    feed.preload(options_.preload_max_mb << 20, options_.max_frames, options_.node_name);
  }
  feed.fetchNext();

  while (!msgs::shutdownRequested()) {
    if (options_.max_frames > 0 && published_ >= options_.max_frames) break;
    Fetched fetched;
    {
      ScopedStageTimer t(timings_, "load_wait");
      fetched = feed.take();
    }
    timings_.add("load", fetched.load_ms);
    if (fetched.error) std::rethrow_exception(fetched.error);
    countSkipped(fetched.stats, &skipped_before);
    if (!fetched.item) {  // end of the pass: stop, or play it again
      if (!options_.loop || published_this_pass == 0) break;
      feed.rewind();
      loop_offset_us += pass_us;
      published_this_pass = 0;
      ++result.loops;
      continue;
    }
    feed.fetchNext();
    std::optional<dataset::DatasetReader::Item> item = std::move(fetched.item);
    ledger_.arrived(published_);  // the seq it goes out with
    const dataset::DatasetEntry& entry = dataset_.entry(item->index);
    const int64_t utime = entry.utime + loop_offset_us;

    if (options_.rate > 0) {
      waitUntil(pacing.target(nowS(), utime, published_, options_));
      if (msgs::shutdownRequested()) {
        ledger_.dropped(published_);
        break;
      }
    }

    pplvo_msgs::rgbd_frame_t msg;
    if (!encodeFrame(*item, entry, utime, camera_msg, &msg)) continue;  // counted by guarded()
    if (options_.lockstep) {
      // At most lockstep_in_flight frames without their pose.
      const int64_t timeouts = result.lockstep_timeouts;
      lockstepWait(published_ - std::max(1, options_.lockstep_in_flight), result);
      if (result.lockstep_timeouts != timeouts) pacing.anchored = false;  // do not rush after
      if (msgs::shutdownRequested()) {
        ledger_.dropped(published_);
        break;
      }
    }
    publishFrame(msg);
    ++published_this_pass;
    // In lockstep the wait before the next publish dispatches the messages (one at a time, so
    // that the next frame goes out as soon as the lockstep allows, mid-way through this one).
    if (!options_.lockstep) drain();
    periodic(false);
  }
  if (options_.lockstep && published_ > 0) lockstepWait(published_ - 1, result);
}

void PlayerNode::countSkipped(const dataset::ReadStats& stats, int64_t* skipped_before) {
  const int64_t newly_skipped = stats.frames_skipped - *skipped_before;
  *skipped_before = stats.frames_skipped;
  if (newly_skipped <= 0) return;
  ledger_.skippedOnArrival(newly_skipped);  // unreadable files: no frame, no seq
  counters_.last_warning = "skipped bad frame: " + stats.last_error;
  if (counters_.frames_skipped <= 5 || counters_.frames_skipped % 100 == 0) {
    std::fprintf(stderr, "[%s] %s\n", options_.node_name.c_str(), counters_.last_warning.c_str());
  }
}

bool PlayerNode::encodeFrame(const dataset::DatasetReader::Item& item,
                             const dataset::DatasetEntry& entry, int64_t utime,
                             const pplvo_msgs::camera_info_t& camera_msg,
                             pplvo_msgs::rgbd_frame_t* msg) {
  return msgs::guardedFrame(ledger_, counters_, options_.node_name.c_str(), published_, [&] {
    ScopedStageTimer t(timings_, "encode");
    msg->utime = utime;
    msg->depth_utime = entry.depth_utime + (utime - entry.utime);  // same loop offset
    msg->seq = published_;
    msg->stamp = entry.stamp_text;
    msg->source = dataset_.dir();
    msg->camera = camera_msg;
    msg->depth_scale = dataset_.camera().depth_scale;
    msg->rgb = msgs::encodeImage(item.frame.bgr, options_.rgb_encoding, options_.jpeg_quality);
    msg->depth = msgs::encodeImage(item.frame.depth_units, options_.depth_encoding);
    msgs::setDepthCamera(dataset_.camera().depth_camera, msg);
  });
}

void PlayerNode::publishFrame(const pplvo_msgs::rgbd_frame_t& msg) {
  {
    ScopedStageTimer t(timings_, "publish");
    if (bus_.publish(options_.channel, &msg) != 0) {
      ledger_.dropped(msg.seq);
      throw std::runtime_error("LCM publish failed on " + options_.channel);
    }
  }
  counters_.last_seq = msg.seq;
  ledger_.published(msg.seq);
  ++published_;
}

void PlayerNode::lockstepWait(int64_t seq, PlayerResult& result) {
  if (seq < 0 || last_pose_seq_ >= seq) return;
  ScopedStageTimer t(timings_, "lockstep_wait");
  // In process an idle queue is no timeout: the pose may follow once later frames flush the
  // pipeline (a frame whose pose never comes shows in the posed count).
  if (waitForPose(seq) || options_.in_process || msgs::shutdownRequested()) return;
  ++result.lockstep_timeouts;
  ++counters_.errors;
  counters_.last_warning = "lockstep: no pose for seq " + std::to_string(seq) + " within " +
                           std::to_string(options_.lockstep_timeout_s) + " s";
  if (result.lockstep_timeouts <= 5 || result.lockstep_timeouts % 100 == 0) {
    std::fprintf(stderr, "[%s] %s; continuing (%lld so far)\n", options_.node_name.c_str(),
                 counters_.last_warning.c_str(), static_cast<long long>(result.lockstep_timeouts));
  }
}

}  // namespace pplvo::player
