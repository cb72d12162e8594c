#pragma once
/// The skeleton every pplvo process main shares (docs/architecture.md, "Processes"):
///
///   int main(int argc, char** argv) {
///     pplvo::keepFrameBuffersMapped();
///     const nodes::DepthFilterArgs a = nodes::parseDepthFilterArgs(argsFromArgv(argc, argv));
///     if (const int code = node::argsExitCode(kName, a.help, a.errors, usage); code != node::kRun)
///       return code;                                      // --help: 0; bad arguments: 2
///     return node::runLcmNode<DepthFilterNode>(process, make, summary);  // 0, or 1 on error
///   }
///
/// Each process keeps a testable parse function (arguments -> options, help, errors) beside its
/// node class; the main only wires it to this runtime.
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "pplvo/core/allocator.h"
#include "pplvo/core/stage_timer.h"
#include "pplvo/msgs/bus.h"
#include "pplvo/msgs/node_runtime.h"

namespace pplvo::node {

/// argsExitCode(): the arguments are fine, run the process.
inline constexpr int kRun = -1;

/// The common handling of a parsed command line: with --help, `usage` on stdout and 0; with
/// errors, each as "NAME: error" on stderr, then `usage` on stdout, and 2; otherwise kRun.
int argsExitCode(const std::string& name, bool help, const std::vector<std::string>& errors,
                 const std::string& usage);

/// What every LCM node process has on its command line besides its own options.
struct NodeProcess {
  std::string name;                        ///< "pplvo-depth-filter": prefix of every line
  std::string lcm_url;                     ///< --lcm-url (empty: $LCM_DEFAULT_URL)
  std::vector<msgs::ChannelRoute> routes;  ///< --route
  int prefault_mb = 64;                    ///< --prefault-mb
};

namespace detail {
template <class N, class = void>
struct HasPoll : std::false_type {};
template <class N>
struct HasPoll<N, std::void_t<decltype(std::declval<N&>().poll())>> : std::true_type {};
template <class N, class = void>
struct HasPollWait : std::false_type {};
template <class N>
struct HasPollWait<N, std::void_t<decltype(std::declval<const N&>().pollWaitMs())>>
    : std::true_type {};
}  // namespace detail

/// Runs an LCM node until SIGINT/SIGTERM: maps the heap (prefault), installs the shutdown
/// handlers, opens the bus (URL and routes), builds the node with `make(bus)` (which may print
/// its start-up line), handles messages, calling node.poll() between messages when the node
/// has one (waiting at most node.pollWaitMs() for a message when it has that) and
/// node.publishStatus() about once a second, publishes a final status and prints
/// `summary(node)` on stderr. Any exception: "NAME: what" on stderr and exit code 1; else 0.
template <class Node>
int runLcmNode(const NodeProcess& process,
               const std::function<std::unique_ptr<Node>(msgs::Bus)>& make,
               const std::function<std::string(const Node&)>& summary) {
  prefaultForStreaming(static_cast<size_t>(process.prefault_mb));  // before the LCM threads
  try {
    msgs::installShutdownHandlers();
    msgs::BusConnections lcm(process.lcm_url, process.routes);
    std::unique_ptr<Node> node = make(lcm.bus());
    msgs::spin(
        lcm.bus(),
        [&] {
          if constexpr (detail::HasPoll<Node>::value) node->poll();
          return false;
        },
        [&] { node->publishStatus(hostUtime()); }, 1.0,
        [&] {
          if constexpr (detail::HasPollWait<Node>::value) return node->pollWaitMs();
          return 50;
        });
    node->publishStatus(hostUtime(), /*final=*/true);
    std::fputs(summary(*node).c_str(), stderr);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: %s\n", process.name.c_str(), e.what());
    return 1;
  }
  return 0;
}

/// printf into a std::string (the processes' start-up and summary lines).
std::string format(const char* fmt, ...) __attribute__((format(printf, 1, 2)));

}  // namespace pplvo::node
