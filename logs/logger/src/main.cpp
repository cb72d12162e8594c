// pplvo-logger: records LCM channels, the trajectory and a run summary. See docs/logger.md.
#include <cstdio>

#include "pplvo/core/allocator.h"
#include "pplvo/core/args.h"
#include "pplvo/logging/logger_node.h"
#include "pplvo/msgs/node_runtime.h"

int main(int argc, char** argv) {
  pplvo::keepFrameBuffersMapped();  // frame-sized buffers: no page faults per frame
  using namespace pplvo;
  const std::vector<std::string> args = argsFromArgv(argc, argv);
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
  opt.progress = progressEnabled(args, opt.progress);  // default: stderr is a terminal
  msgs::installShutdownHandlers();
  try {
    msgs::BusConnections lcm(opt.lcm_url, opt.routes);
    logging::LoggerNode node(opt, lcm.bus());
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
