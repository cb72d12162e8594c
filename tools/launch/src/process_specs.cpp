#include "pplvo/launch/process_specs.h"

#include "pplvo/msgs/channels.h"
#include "text_numbers.h"

namespace pplvo::launch {

using detail::fmtDouble;

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
  if (!o.log.empty() && o.compact_log) {
    lg.args.insert(lg.args.end(), {"--channels", channels::kCompactLogChannels});
  }
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
  if (!o.camera_file.empty()) pl.args.insert(pl.args.end(), {"--camera", o.camera_file});
  if (o.max_frames > 0)
    pl.args.insert(pl.args.end(), {"--max-frames", std::to_string(o.max_frames)});
  if (o.fps > 0) pl.args.insert(pl.args.end(), {"--fps", fmtDouble(o.fps)});
  if (o.preload.value_or(!o.lockstep)) pl.args.push_back("--preload");
  if (o.compact_log) {  // the frames the pipeline runs on are those the log keeps
    pl.args.insert(pl.args.end(), {"--rgb-encoding", "jpeg", "--depth-encoding", "zlib"});
  } else if (o.compress) {
    pl.args.insert(pl.args.end(), {"--rgb-encoding", "png", "--depth-encoding", "zlib"});
  }
  specs.push_back(pl);
  return specs;
}

}  // namespace pplvo::launch
