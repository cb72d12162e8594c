#include "pplvo/launch/launch_args.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <regex>
#include <sstream>

#include "pplvo/launch/supervisor.h"
#include "text_numbers.h"

namespace pplvo::launch {

using detail::fmtDouble;
using detail::toDouble;
using detail::toInt;

const std::vector<std::string>& statusNodes() {
  static const std::vector<std::string> names = {kDepthFilter, kFrontend, kEstimator};
  return names;
}

const std::vector<std::string>& allPrograms() {
  static const std::vector<std::string> names = {kDepthFilter, kFrontend, kEstimator, kLogger,
                                                 kPlayer};
  return names;
}

std::string launchUsage() {
  return "usage: pplvo-launch --dataset DIR --output TRAJ [options]\n"
         "Starts pplvo-depth-filter, pplvo-frontend, pplvo-estimator, pplvo-logger and then\n"
         "pplvo-player as separate processes on one LCM URL, waits for the end of the sequence,\n"
         "lets the pipeline drain, stops them (SIGINT, SIGKILL after --stop-grace) and reports\n"
         "frames in/out/dropped/skipped per stage. Exit 0 only if every process ended cleanly.\n"
         "  --dataset DIR           TUM-layout folder (player)\n"
         "  --camera FILE.yaml      its camera, when it has no calib_params.xml (player;\n"
         "                          config/cameras/: TUM fr1/fr2/fr3, ICL-NUIM, Kinect v1)\n"
         "  --output TRAJ           TUM trajectory written by the logger from PPLVO_POSE\n"
         "  --lockstep              player publishes frame k+2 only after the pose of frame k\n"
         "                          (trajectory equal to pplvo-run's: the depth filter does\n"
         "                          not shed load); default --rate 0 then\n"
         "  --lockstep-in-flight N  frames out without their pose in lockstep (2; 1 = one at\n"
         "                          a time)\n"
         "  --rate R                player speed: 1 real time (default), 0 as fast as possible\n"
         "  --lockstep-timeout S    player's wait for each pose in lockstep mode (10)\n"
         "  --config FILE           pipeline YAML (depth filter, frontend and estimator)\n"
         "  --features LIST         points,lines,planes (frontend and estimator)\n"
         "  --set KEY=VALUE         configuration override (repeatable; every pipeline process)\n"
         "  --depth-model M         sensor | cgm | ogm (depth filter)\n"
         "  --max-frames N          player stops after N frames (0 = all)\n"
         "  --fps HZ                frame rate of integer-stamped datasets (ICL-NUIM: 30)\n"
         "  --log LOG               logger also writes an LCM event log of PPLVO_.* channels\n"
         "  --log-mode full|compact compact: the player sends JPEG colour and zlib depth and\n"
         "                          --log keeps frames, poses, odometry, status, stream\n"
         "                          (~200 KB/frame; pplvo-replay --stage pipeline replays it)\n"
         "  --summary FILE          logger's YAML run summary\n"
         "  --lcm-url URL           udpm URL (default $LCM_DEFAULT_URL; with --isolated\n"
         "                          udpm://239.255.76.67:7667?ttl=0)\n"
         "  --preload, --no-preload player decodes the frames before publishing the first\n"
         "                          (no PNG decoding competes with the pipeline, as with a\n"
         "                          camera; up to 2 GiB); default: on unless --lockstep\n"
         "  --single-url            frame channels on the main URL too (default: RGB-D\n"
         "                          frames and depth maps each on the next port, joined only\n"
         "                          by their subscribers)\n"
         "  --isolated              run everything in a private network namespace (only lo);\n"
         "                          a URL with ttl > 0 is refused\n"
         "  --bin-dir DIR           where the node programs are (default: next to pplvo-launch)\n"
         "  --node-logs DIR         stdout/stderr of each process as DIR/NAME.log (default: a\n"
         "                          temporary directory, kept and named only on failure)\n"
         "  --timeout S             bound on the whole launch (3600)\n"
         "  --startup-timeout S     wait for each node's first status message (20)\n"
         "  --drain-idle S          after the player ends, stop once no pose came for S s (2)\n"
         "  --stop-grace S          SIGINT -> SIGKILL delay when stopping (5)\n"
         "  --test-kill NODE:N      (tests) SIGKILL NODE once N poses were seen\n"
         "  --restart N             start a depth filter, frontend or estimator that died again,\n"
         "                          at most N times per stage (0: a dead stage fails the launch)\n"
         "  --restart-backoff S     wait before a restart, doubled each time (0.5)\n"
         "  --test-pause NODE:N:S   (tests) SIGSTOP NODE once N poses were seen, SIGCONT after\n"
         "                          S seconds\n"
         "  --compress              lossless compressed frames (player png/zlib) and depth\n"
         "                          maps (depth filter zlib); automatic when the kernel's\n"
         "                          net.core.rmem_max is below 2 MiB\n"
         "  --quiet                 only the report\n"
         "  --progress, --no-progress  a progress line on stderr while the sequence plays:\n"
         "                          frames published, posed, dropped (default: on a terminal)\n";
}

namespace {

/// One command-line option being read: its key, the value given inline as "--key=value", and
/// the shared error list (every problem is reported together).
class OptionReader {
 public:
  OptionReader(const std::vector<std::string>& args, size_t* i, std::vector<std::string>* errors)
      : args_(args), i_(*i), errors_(*errors), key_(args[*i]) {
    if (key_.rfind("--", 0) == 0) {
      const size_t eq = key_.find('=');
      if (eq != std::string::npos) {
        value_ = key_.substr(eq + 1);
        key_ = key_.substr(0, eq);
        has_inline_ = true;
      }
    }
  }
  const std::string& key() const { return key_; }
  void error(const std::string& e) { errors_.push_back(e); }
  /// The option's value: inline, or the next argument (consumed).
  bool next(std::string* out) {
    if (has_inline_) {
      *out = value_;
      return true;
    }
    if (i_ + 1 >= args_.size()) {
      error(key_ + " needs a value");
      return false;
    }
    *out = args_[++i_];
    return true;
  }
  /// A finite number >= min_value; `out` is left alone on an error.
  void number(double* out, double min_value) {
    std::string t;
    if (!next(&t)) return;
    double v = 0;
    if (!toDouble(t, &v))
      error(key_ + ": expected a number, not '" + t + "'");
    else if (v < min_value)
      error(key_ + ": must be >= " + fmtDouble(min_value));
    else
      *out = v;
  }
  /// An integer in [lo, hi]. As before the split, a missing value sets `out` to 0 (the
  /// "needs a value" error is reported anyway).
  void integerIn(int* out, int64_t lo, int64_t hi) {
    std::string t;
    int64_t v = 0;
    if (next(&t) && (!toInt(t, &v) || v < lo || v > hi)) {
      error(key_ + ": expected an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) +
            "], not '" + t + "'");
    } else {
      *out = static_cast<int>(v);
    }
  }
  /// A switch: "--key=value" is refused.
  void flag(bool* out) {
    if (has_inline_) error(key_ + " takes no value");
    *out = true;
  }

 private:
  const std::vector<std::string>& args_;
  size_t& i_;
  std::vector<std::string>& errors_;
  std::string key_, value_;
  bool has_inline_ = false;
};

// The options by topic; each returns false for a key that is not its own.

/// What the player plays and how fast, where the results go.
bool readRunOption(OptionReader& r, LaunchOptions& o, bool* rate_given) {
  const std::string& key = r.key();
  if (key == "--dataset")
    r.next(&o.dataset_dir);
  else if (key == "--camera")
    r.next(&o.camera_file);
  else if (key == "--output")
    r.next(&o.output);
  else if (key == "--lockstep")
    r.flag(&o.lockstep);
  else if (key == "--rate") {
    r.number(&o.rate, 0.0);
    *rate_given = true;
  } else if (key == "--lockstep-timeout")
    r.number(&o.lockstep_timeout_s, 0.1);
  else if (key == "--lockstep-in-flight")
    r.integerIn(&o.lockstep_in_flight, 1, 1000);
  else if (key == "--max-frames") {
    std::string t;
    if (r.next(&t) && (!toInt(t, &o.max_frames) || o.max_frames < 0)) {
      r.error("--max-frames: expected an integer >= 0, not '" + t + "'");
    }
  } else if (key == "--fps")
    r.number(&o.fps, 0.0);
  else if (key == "--log")
    r.next(&o.log);
  else if (key == "--log-mode") {
    std::string mode;
    if (r.next(&mode)) {
      if (mode == "compact" || mode == "full")
        o.compact_log = mode == "compact";
      else
        r.error("--log-mode: full or compact, not '" + mode + "'");
    }
  }
  else if (key == "--summary")
    r.next(&o.summary);
  else if (key == "--preload" || key == "--no-preload") {
    bool given = false;
    r.flag(&given);  // refuses "--preload=x"
    o.preload = key == "--preload";
  } else if (key == "--quiet")
    r.flag(&o.quiet);
  else if (key == "--progress" || key == "--no-progress") {
    bool given = false;
    r.flag(&given);
    o.progress = key == "--progress";
  } else
    return false;
  return true;
}

/// The pipeline configuration handed to the depth filter, frontend and estimator.
bool readPipelineOption(OptionReader& r, LaunchOptions& o) {
  const std::string& key = r.key();
  if (key == "--config")
    r.next(&o.config);
  else if (key == "--set") {
    std::string kv;
    if (r.next(&kv)) {
      if (kv.find('=') == std::string::npos || kv.front() == '=') {
        r.error("--set: KEY=VALUE, not '" + kv + "'");
      } else {
        o.set.push_back(kv);
      }
    }
  } else if (key == "--features")
    r.next(&o.features);
  else if (key == "--depth-model") {
    if (r.next(&o.depth_model) && o.depth_model != "sensor" && o.depth_model != "cgm" &&
        o.depth_model != "ogm") {
      r.error("--depth-model: sensor, cgm or ogm, not '" + o.depth_model + "'");
    }
  } else
    return false;
  return true;
}

/// The bus and the processes: LCM URL, namespace, programs, logs, compression.
bool readTransportOption(OptionReader& r, LaunchOptions& o) {
  const std::string& key = r.key();
  if (key == "--lcm-url")
    r.next(&o.lcm_url);
  else if (key == "--isolated")
    r.flag(&o.isolated);
  else if (key == "--single-url")
    r.flag(&o.single_url);
  else if (key == "--bin-dir")
    r.next(&o.bin_dir);
  else if (key == "--node-logs")
    r.next(&o.node_log_dir);
  else if (key == "--compress")
    r.flag(&o.compress);
  else
    return false;
  return true;
}

/// Time limits and restarts of the supervision.
bool readSupervisionOption(OptionReader& r, LaunchOptions& o) {
  const std::string& key = r.key();
  if (key == "--timeout")
    r.number(&o.timeout_s, 1.0);
  else if (key == "--startup-timeout")
    r.number(&o.startup_timeout_s, 1.0);
  else if (key == "--drain-idle")
    r.number(&o.drain_idle_s, 0.1);
  else if (key == "--stop-grace")
    r.number(&o.stop_grace_s, 0.1);
  else if (key == "--restart")
    r.integerIn(&o.restart_limit, 0, 1000);
  else if (key == "--restart-backoff")
    r.number(&o.restart_backoff_s, 0.0);
  else
    return false;
  return true;
}

/// True when `text` matches `re` and its first group names one of the programs.
bool namesAProgram(const std::string& text, const std::regex& re) {
  std::smatch m;
  bool known = false;
  if (std::regex_match(text, m, re)) {
    for (const std::string& n : allPrograms()) known = known || n == m[1].str();
  }
  return known;
}

/// The faults injected by tests (--test-kill, --test-pause).
bool readTestOption(OptionReader& r, LaunchOptions& o) {
  const std::string& key = r.key();
  if (key == "--test-kill") {
    static const std::regex re("(pplvo-[a-z-]+):([0-9]+)");
    if (r.next(&o.test_kill) && !namesAProgram(o.test_kill, re)) {
      r.error("--test-kill: NODE:POSES with NODE one of the programs");
    }
  } else if (key == "--test-pause") {
    static const std::regex re("(pplvo-[a-z-]+):([0-9]+):([0-9]+(\\.[0-9]*)?)");
    if (r.next(&o.test_pause) && !namesAProgram(o.test_pause, re)) {
      r.error("--test-pause: NODE:POSES:SECONDS with NODE one of the programs");
    }
  } else
    return false;
  return true;
}

}  // namespace

ParsedArgs parseLaunchArgs(const std::vector<std::string>& args) {
  ParsedArgs p;
  LaunchOptions& o = p.options;
  bool rate_given = false;
  for (size_t i = 0; i < args.size(); ++i) {
    OptionReader r(args, &i, &p.errors);
    if (r.key() == "--help" || r.key() == "-h") {
      p.help = true;
    } else if (!readRunOption(r, o, &rate_given) && !readPipelineOption(r, o) &&
               !readTransportOption(r, o) && !readSupervisionOption(r, o) &&
               !readTestOption(r, o)) {
      p.errors.push_back("unknown option " + args[i]);
    }
  }
  if (p.help) return p;
  // Lockstep runs as fast as the pipeline unless a rate was asked for.
  if (!rate_given && o.lockstep) o.rate = 0.0;
  if (o.dataset_dir.empty()) p.errors.push_back("--dataset is required");
  if (o.output.empty()) p.errors.push_back("--output is required");
  return p;
}

TestFaultPlan planTestFaults(const LaunchOptions& o) {
  TestFaultPlan plan;
  if (!o.test_kill.empty()) {
    const size_t colon = o.test_kill.rfind(':');
    plan.kill_node = o.test_kill.substr(0, colon);
    plan.kill_after_poses = std::stoll(o.test_kill.substr(colon + 1));
  }
  if (!o.test_pause.empty()) {
    const size_t second = o.test_pause.rfind(':');
    const size_t first = o.test_pause.rfind(':', second - 1);
    plan.pause_node = o.test_pause.substr(0, first);
    plan.pause_after_poses = std::stoll(o.test_pause.substr(first + 1, second - first - 1));
    plan.pause_s = std::stod(o.test_pause.substr(second + 1));
  }
  return plan;
}

std::vector<std::string> missingPrograms(const std::string& bin_dir) {
  std::vector<std::string> missing;
  for (const std::string& name : allPrograms()) {
    const std::string why = checkExecutable(bin_dir + "/" + name);
    if (!why.empty()) missing.push_back(bin_dir + "/" + name + ": " + why);
  }
  return missing;
}

}  // namespace pplvo::launch
