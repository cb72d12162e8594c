// pplvo-logger: records LCM channels, the trajectory and a run summary. See docs/logger.md.
#include <unistd.h>

#include <algorithm>
#include <cstdio>

#include "pplvo/logging/logger_node.h"
#include "pplvo/msgs/node_runtime.h"

int main(int argc, char** argv) {
  using namespace pplvo;
  const std::vector<std::string> args(argv + 1, argv + argc);
  logging::LoggerParseResult parsed = logging::parseLoggerArgs(args);
  if (parsed.help) {
    std::fputs(logging::loggerUsage().c_str(), stdout);
    return logging::kExitOk;
  }
  if (!parsed.errors.empty()) {
    for (const auto& e : parsed.errors) std::fprintf(stderr, "pplvo-logger: %s\n", e.c_str());
    std::fprintf(stderr, "pplvo-logger: see --help\n");
    return logging::kExitUsage;
  }
  logging::LoggerOptions& opt = parsed.options;
  if (std::find(args.begin(), args.end(), "--progress") == args.end() &&
      std::find(args.begin(), args.end(), "--no-progress") == args.end()) {
    opt.progress = ::isatty(STDERR_FILENO) == 1;
  }
  msgs::installShutdownHandlers();
  try {
    auto lcm = msgs::openLcm(opt.lcm_url);
    logging::LoggerNode node(opt, *lcm);
    std::fprintf(stderr, "pplvo-logger: recording '%s'%s%s%s%s\n", opt.channels.c_str(),
                 opt.output.empty() ? "" : " to ", opt.output.c_str(),
                 opt.trajectory.empty() ? "" : ", trajectory to ", opt.trajectory.c_str());
    const logging::LoggerResult r = node.run();
    std::fprintf(stderr, "pplvo-logger: %s\n", r.summaryLine().c_str());
    return r.exit_code;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pplvo-logger: error: %s\n", e.what());
    return logging::kExitFailed;
  }
}
