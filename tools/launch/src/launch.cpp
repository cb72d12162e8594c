#include "pplvo/launch/launch.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <regex>
#include <sstream>

#include "pplvo/msgs/channels.h"

namespace pplvo::launch {

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
         "  --quiet                 only the report\n";
}

namespace {

bool toDouble(const std::string& t, double* out) {
  try {
    size_t end = 0;
    const double v = std::stod(t, &end);
    if (end != t.size() || !std::isfinite(v)) return false;
    *out = v;
    return true;
  } catch (const std::exception&) {
    return false;
  }
}

bool toInt(const std::string& t, int64_t* out) {
  try {
    size_t end = 0;
    const long long v = std::stoll(t, &end);
    if (end != t.size()) return false;
    *out = v;
    return true;
  } catch (const std::exception&) {
    return false;
  }
}

std::string fmtDouble(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

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
  else if (key == "--summary")
    r.next(&o.summary);
  else if (key == "--preload" || key == "--no-preload") {
    bool given = false;
    r.flag(&given);  // refuses "--preload=x"
    o.preload = key == "--preload";
  } else if (key == "--quiet")
    r.flag(&o.quiet);
  else
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

LcmUrl parseLcmUrl(const std::string& url) {
  LcmUrl u;
  const size_t sep = url.find("://");
  if (sep == std::string::npos || sep == 0) {
    u.error = "'" + url + "' is not an LCM URL (provider://address?options)";
    return u;
  }
  u.provider = url.substr(0, sep);
  std::string rest = url.substr(sep + 3);
  std::string query;
  if (const size_t q = rest.find('?'); q != std::string::npos) {
    query = rest.substr(q + 1);
    rest = rest.substr(0, q);
  }
  if (u.provider == "udpm") {
    u.address = "239.255.76.67";
    u.port = 7667;
    if (!rest.empty()) {
      const size_t colon = rest.find(':');
      u.address = rest.substr(0, colon);
      if (colon != std::string::npos) {
        int64_t port = 0;
        if (!toInt(rest.substr(colon + 1), &port) || port <= 0 || port > 65535) {
          u.error = "bad port in '" + url + "'";
          return u;
        }
        u.port = static_cast<int>(port);
      }
    }
    // Multicast group: 224.0.0.0/4.
    static const std::regex ip("([0-9]{1,3})\\.([0-9]{1,3})\\.([0-9]{1,3})\\.([0-9]{1,3})");
    std::smatch m;
    if (!std::regex_match(u.address, m, ip) || std::stoi(m[1].str()) < 224 ||
        std::stoi(m[1].str()) > 239) {
      u.error = "'" + u.address + "' in '" + url + "' is not an IPv4 multicast group";
      return u;
    }
  }
  std::istringstream qs(query);
  for (std::string kv; std::getline(qs, kv, '&');) {
    const size_t eq = kv.find('=');
    if (eq == std::string::npos) continue;
    if (kv.substr(0, eq) == "ttl") {
      int64_t ttl = 0;
      if (!toInt(kv.substr(eq + 1), &ttl) || ttl < 0 || ttl > 255) {
        u.error = "bad ttl in '" + url + "'";
        return u;
      }
      u.ttl = static_cast<int>(ttl);
    }
  }
  u.valid = true;
  return u;
}

int64_t readRmemMax() {
  std::ifstream in("/proc/sys/net/core/rmem_max");
  int64_t v = -1;
  if (!(in >> v)) return -1;
  return v;
}

UrlDecision decideLcmUrl(const LaunchOptions& o, const char* env_lcm_default_url,
                         int64_t rmem_max_bytes) {
  UrlDecision d;
  if (!o.lcm_url.empty()) {
    d.url = o.lcm_url;
  } else if (o.isolated) {
    d.url = kIsolatedUrl;  // $LCM_DEFAULT_URL is for the host; the namespace has its own
  } else if (env_lcm_default_url != nullptr && *env_lcm_default_url != '\0') {
    d.url = env_lcm_default_url;
  } else {
    d.url = kIsolatedUrl;  // LCM's own default
    d.warnings.push_back("no --lcm-url and no $LCM_DEFAULT_URL: using LCM's default " + d.url +
                         " on the host network (use --isolated for tests and demos)");
  }
  const LcmUrl u = parseLcmUrl(d.url);
  if (!u.valid) {
    d.errors.push_back("LCM URL: " + u.error);
    return d;
  }
  if (u.provider != "udpm") {
    d.errors.push_back("LCM URL '" + d.url + "': separate processes need udpm:// (" +
                       (u.provider == "memq" ? std::string("memq:// only connects one process; "
                                                           "use pplvo-run")
                                             : u.provider + ":// is not a shared bus") +
                       ")");
    return d;
  }
  if (rmem_max_bytes >= 0 && d.url.find("recv_buf_size=") == std::string::npos) {
    const int64_t size = std::min<int64_t>(rmem_max_bytes, 16 << 20);
    d.url += (d.url.find('?') == std::string::npos ? "?" : "&");
    d.url += "recv_buf_size=" + std::to_string(size);
    if (size < kMinCompressedRecvBufBytes) {
      d.compress = true;
      d.warnings.push_back(
          "net.core.rmem_max is only " + std::to_string(rmem_max_bytes) +
          " bytes: 640x480 frames and depth maps will lose UDP fragments even compressed "
          "(measured: 1 MiB needed); raise it, e.g. sysctl -w net.core.rmem_max=4194304");
    } else if (size < kMinRawRecvBufBytes) {
      d.compress = true;
      d.warnings.push_back("net.core.rmem_max is only " + std::to_string(rmem_max_bytes) +
                           " bytes: raw frames would lose UDP fragments, so images and depth "
                           "maps are sent compressed (lossless; raise rmem_max to avoid this)");
    }
  }
  if (!o.single_url) {
    std::string error;
    d.routes = frameChannelRoutes(d.url, &error);
    if (!error.empty()) d.errors.push_back(error + " (or use --single-url)");
  }
  if (o.isolated && u.ttl > 0) {
    d.errors.push_back("--isolated needs a loopback URL (udpm with ttl=0), not '" + d.url + "'");
  } else if (!o.isolated && u.ttl > 0) {
    d.warnings.push_back("LCM URL '" + d.url + "' has ttl=" + std::to_string(u.ttl) +
                         ": traffic leaves this host (use --isolated for tests and demos)");
  }
  return d;
}

std::vector<std::string> frameChannelRoutes(const std::string& udpm_url, std::string* error) {
  const LcmUrl u = parseLcmUrl(udpm_url);
  if (!u.valid || u.provider != "udpm") {
    *error = "frame channel routes need a udpm URL, not '" + udpm_url + "'";
    return {};
  }
  // Channel and port offset; both feature channels go to the estimator (one group).
  const std::pair<const char*, int> channels[] = {{channels::kRgbd, 1},
                                                  {channels::kDepthCgm, 2},
                                                  {channels::kDepthFused, 3},
                                                  {channels::kFeatures, 4},
                                                  {channels::kFeatures3d, 4}};
  if (u.port + 4 > 65535) {
    *error = "port " + std::to_string(u.port) + " leaves no room for the frame channels' ports";
    return {};
  }
  const size_t q = udpm_url.find('?');
  const std::string options = q == std::string::npos ? "" : udpm_url.substr(q);
  std::vector<std::string> routes;
  for (const auto& [channel, offset] : channels) {
    routes.push_back(std::string(channel) + "=udpm://" + u.address + ":" +
                     std::to_string(u.port + offset) + options);
  }
  return routes;
}

std::vector<ProcessSpec> buildProcessSpecs(const LaunchOptions& o, const UrlDecision& url,
                                           const std::string& bin_dir, const std::string& log_dir) {
  auto make = [&](const std::string& name) {
    ProcessSpec s;
    s.name = name;
    s.path = bin_dir + "/" + name;
    s.args = {"--lcm-url", url.url};
    // Every process: one that never touches a routed channel never joins its port.
    for (const std::string& r : url.routes) s.args.insert(s.args.end(), {"--route", r});
    s.env["LCM_DEFAULT_URL"] = url.url;
    if (!log_dir.empty()) s.log_path = log_dir + "/" + name + ".log";
    return s;
  };
  std::vector<ProcessSpec> specs;
  ProcessSpec df = make(kDepthFilter);
  if (!o.depth_model.empty()) df.args.insert(df.args.end(), {"--depth-model", o.depth_model});
  if (o.compress) df.args.push_back("--compress");
  if (!o.config.empty()) df.args.insert(df.args.end(), {"--config", o.config});
  for (const std::string& kv : o.set) df.args.insert(df.args.end(), {"--set", kv});
  // Lockstep bounds the frames in flight and promises pplvo-run's trajectory: no shedding.
  if (o.lockstep) df.args.insert(df.args.end(), {"--overload-backlog", "0"});
  specs.push_back(df);
  for (const char* name : {kFrontend, kEstimator}) {
    ProcessSpec s = make(name);
    if (!o.config.empty()) s.args.insert(s.args.end(), {"--config", o.config});
    if (!o.features.empty()) s.args.insert(s.args.end(), {"--features", o.features});
    for (const std::string& kv : o.set) s.args.insert(s.args.end(), {"--set", kv});
    specs.push_back(s);
  }
  ProcessSpec lg = make(kLogger);
  lg.args.insert(lg.args.end(), {"--trajectory", o.output, "--no-progress"});
  if (!o.log.empty()) lg.args.insert(lg.args.end(), {"--output", o.log, "--force"});
  if (!o.summary.empty()) lg.args.insert(lg.args.end(), {"--summary", o.summary});
  specs.push_back(lg);
  ProcessSpec pl = make(kPlayer);
  pl.args.insert(pl.args.end(),
                 {"--dataset", o.dataset_dir, "--rate", fmtDouble(o.rate), "--no-progress"});
  if (o.lockstep) {
    pl.args.insert(pl.args.end(),
                   {"--lockstep", "--lockstep-timeout", fmtDouble(o.lockstep_timeout_s),
                    "--lockstep-in-flight", std::to_string(o.lockstep_in_flight)});
  }
  if (o.max_frames > 0)
    pl.args.insert(pl.args.end(), {"--max-frames", std::to_string(o.max_frames)});
  if (o.fps > 0) pl.args.insert(pl.args.end(), {"--fps", fmtDouble(o.fps)});
  if (o.preload.value_or(!o.lockstep)) pl.args.push_back("--preload");
  if (o.compress) {
    pl.args.insert(pl.args.end(), {"--rgb-encoding", "png", "--depth-encoding", "zlib"});
  }
  specs.push_back(pl);
  return specs;
}

std::optional<NodeCounts> parseDoneLine(const std::string& log_text, const std::string& node) {
  std::optional<NodeCounts> found;
  std::istringstream in(log_text);
  const std::regex done("\\[" + node +
                        "\\] done: in (-?[0-9]+) out (-?[0-9]+) dropped (-?[0-9]+) skipped "
                        "(-?[0-9]+).*");
  const std::regex player(node + ": published ([0-9]+) frames, skipped ([0-9]+).*");
  for (std::string line; std::getline(in, line);) {
    std::smatch m;
    if (std::regex_match(line, m, done)) {
      NodeCounts c;
      c.frames_in = std::stoll(m[1].str());
      c.frames_out = std::stoll(m[2].str());
      c.frames_dropped = std::stoll(m[3].str());
      c.frames_skipped = std::stoll(m[4].str());
      c.known = true;
      c.source = "done line";
      found = c;
    } else if (std::regex_match(line, m, player)) {
      NodeCounts c;
      c.frames_out = std::stoll(m[1].str());
      c.frames_skipped = std::stoll(m[2].str());
      c.frames_in = c.frames_out + c.frames_skipped;
      c.known = true;
      c.source = "done line";
      found = c;
    }
  }
  return found;
}

bool DrainMonitor::drained(double now_s, int64_t poses, int64_t published) {
  if (poses != last_poses_) {
    last_poses_ = poses;
    last_change_s_ = now_s;
  }
  if (published >= 0 && poses >= published) {
    all_posed_ = true;
    return true;
  }
  return now_s - last_change_s_ >= idle_s_;
}

int64_t parseOverloadFusions(const std::string& log_text) {
  int64_t n = -1;
  std::istringstream in(log_text);
  const std::regex overload("\\[" + std::string(kDepthFilter) + "\\] overload: ([0-9]+) .*");
  for (std::string line; std::getline(in, line);) {
    std::smatch m;
    if (std::regex_match(line, m, overload)) n = std::stoll(m[1].str());
  }
  return n;
}

int64_t LaunchReport::droppedTotal() const {
  int64_t n = 0;
  for (const Process& p : processes) {
    if (p.has_counts && p.counts.known) n += p.counts.frames_dropped;
  }
  return n;
}

std::string LaunchReport::text() const {
  std::ostringstream out;
  char buf[512];
  std::snprintf(buf, sizeof buf, "pplvo-launch report (%s, %s, %.2f s wall)\n",
                lockstep ? "lockstep" : "free-running", url.c_str(), wall_s);
  out << buf;
  std::snprintf(buf, sizeof buf, "  %-20s %-34s %7s %7s %8s %8s %7s\n", "process", "ended", "in",
                "out", "dropped", "skipped", "errors");
  out << buf;
  for (const Process& p : processes) {
    std::string ended = p.exit ? p.exit->text() : "still running";
    if (p.killed)
      ended += " after SIGKILL";
    else if (p.stop_requested && p.exit)
      ended += " (stopped)";
    if (p.has_counts && p.counts.known) {
      std::snprintf(buf, sizeof buf, "  %-20s %-34s %7lld %7lld %8lld %8lld %7lld\n",
                    p.name.c_str(), ended.c_str(), static_cast<long long>(p.counts.frames_in),
                    static_cast<long long>(p.counts.frames_out),
                    static_cast<long long>(p.counts.frames_dropped),
                    static_cast<long long>(p.counts.frames_skipped),
                    static_cast<long long>(p.counts.errors));
    } else {
      std::snprintf(buf, sizeof buf, "  %-20s %-34s %7s %7s %8s %8s %7s\n", p.name.c_str(),
                    ended.c_str(), "-", "-", "-", "-", "-");
    }
    out << buf;
  }
  // Frames the RGB-D subscribers never received (lost in transport or not yet published).
  const Process* player = nullptr;
  for (const Process& p : processes) {
    if (p.name == kPlayer) player = &p;
  }
  int64_t not_received = 0;
  bool transport_known = false;
  if (player && player->counts.known) {
    for (const Process& p : processes) {
      if ((p.name == kDepthFilter || p.name == kFrontend) && p.counts.known) {
        not_received += std::max<int64_t>(0, player->counts.frames_out - p.counts.frames_in);
        transport_known = true;
      }
    }
  }
  out << "launch.frames_published: " << frames_published << "\n";
  out << "launch.poses_seen: " << poses_seen << "\n";
  out << "launch.trajectory_poses: " << trajectory_poses << "  # " << trajectory_path << "\n";
  out << "launch.dropped_total: " << droppedTotal()
      << "  # sum of frames_dropped over nodes (a frame dropped upstream may count again "
         "downstream)\n";
  if (frames_published >= 0 && trajectory_poses >= 0) {
    out << "launch.frames_without_pose: "
        << std::max<int64_t>(0, frames_published - trajectory_poses)
        << "  # published minus trajectory poses\n";
  }
  if (transport_known) {
    out << "launch.frames_not_received: " << not_received
        << "  # player out minus depth-filter/frontend in\n";
  }
  if (overload_fusions >= 0) {
    out << "launch.overload_fusions: " << overload_fusions
        << "  # frames the depth filter fused over a shortened window to catch up\n";
  }
  if (lockstep && player && player->counts.known) {
    out << "launch.lockstep_timeouts: " << player->counts.errors
        << "  # poses the player gave up waiting for (player errors)\n";
  }
  out << "launch.restarts: " << restarts << "\n";
  for (const std::string& f : faults()) out << "launch.fault: " << f << "\n";
  out << "launch.wall_s: " << wall_s << "\n";
  out << "launch.result: " << (ok() ? "ok" : "FAILED") << "\n";
  for (const std::string& f : failures) out << "launch.failure: " << f << "\n";
  return out.str();
}

std::vector<std::string> LaunchReport::faults() const {
  std::vector<std::string> f;
  char buf[256];
  for (const Process& p : processes) {
    if (p.pauses > 0) {
      std::snprintf(buf, sizeof buf, "%s paused %d time(s), %.1f s in all", p.name.c_str(),
                    p.pauses, p.paused_s);
      f.push_back(buf);
    }
    if (p.exit && !p.stop_requested && !p.exit->clean()) {
      f.push_back(p.name + " ended early (" + p.exit->text() + ")" +
                  (p.restarted ? ", restarted" : ""));
    }
  }
  return f;
}

int64_t LaunchReport::framesWithoutPose() const {
  if (frames_published < 0 || trajectory_poses < 0) return -1;
  return std::max<int64_t>(0, frames_published - trajectory_poses);
}

void LaunchReport::takePlayerCounts() {
  for (const auto& p : processes) {
    if (frames_published < 0 && p.name == kPlayer && p.counts.known) {
      frames_published = p.counts.frames_out;
    }
  }
  if (lockstep) {
    // A pose the player stopped waiting for was lost (UDP loss, a dead node): the lockstep
    // promise (trajectory equal to pplvo-run's) no longer holds, so the launch fails.
    for (const auto& p : processes) {
      if (p.name == kPlayer && p.counts.known && p.counts.errors > 0) {
        failures.push_back(std::to_string(p.counts.errors) +
                           " lockstep timeout(s): poses lost (receive buffers too small? see "
                           "docs/launch.md)");
      }
    }
  }
}

void LaunchReport::checkFramesLostToFaults() {
  const std::vector<std::string> f = faults();
  const int64_t lost = framesWithoutPose();
  if (f.empty() || lost == 0) return;
  std::string why = f.front();
  for (size_t i = 1; i < f.size(); ++i) why += "; " + f[i];
  failures.push_back("frames lost to a fault: " +
                     (lost < 0 ? std::string("unknown number") : std::to_string(lost)) + " of " +
                     std::to_string(frames_published) + " published frames without pose (" + why +
                     ")");
}

int64_t countTrajectoryLines(const std::string& path) {
  std::ifstream in(path);
  if (!in) return -1;
  int64_t n = 0;
  for (std::string line; std::getline(in, line);) {
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    ++n;
  }
  return n;
}

std::string tailOfFile(const std::string& path, int max_lines) {
  std::ifstream in(path);
  if (!in) return {};
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) {
    lines.push_back(line);
    if (static_cast<int>(lines.size()) > max_lines) lines.erase(lines.begin());
  }
  std::string s;
  for (const std::string& l : lines) s += l + "\n";
  return s;
}

}  // namespace pplvo::launch
