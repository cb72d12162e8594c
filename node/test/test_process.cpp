#include <gtest/gtest.h>

#include <stdexcept>

#include "pplvo/node/process.h"

namespace pplvo::node {
namespace {

TEST(NodeProcess, ArgsExitCodes) {
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  EXPECT_EQ(argsExitCode("pplvo-x", true, {"ignored with --help"}, "usage: x\n"), 0);
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
  EXPECT_EQ(testing::internal::GetCapturedStdout(), "usage: x\n");

  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  EXPECT_EQ(argsExitCode("pplvo-x", false, {"--a: bad", "--b: worse"}, "usage: x\n"), 2);
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "pplvo-x: --a: bad\npplvo-x: --b: worse\n");
  EXPECT_EQ(testing::internal::GetCapturedStdout(), "usage: x\n");

  EXPECT_EQ(argsExitCode("pplvo-x", false, {}, "usage: x\n"), kRun);
  EXPECT_EQ(format("%s %d %.1f", "a", 3, 0.25), "a 3 0.2");
}

/// A node that stops the process on its first poll.
struct StoppingNode {
  int polls = 0;
  int statuses = 0, final_statuses = 0;
  void poll() {
    ++polls;
    msgs::requestShutdown();
  }
  void publishStatus(int64_t, bool final = false) {
    ++statuses;
    final_statuses += final ? 1 : 0;
  }
};

TEST(NodeProcess, RunsANodeUntilShutdown) {
  NodeProcess p{"pplvo-test", "memq://", {}, 0};
  // An exception while building the node: exit code 1 with the process name.
  testing::internal::CaptureStderr();
  EXPECT_EQ(
      runLcmNode<StoppingNode>(
          p, [](msgs::Bus) -> std::unique_ptr<StoppingNode> { throw std::runtime_error("no"); },
          [](const StoppingNode&) { return std::string(); }),
      1);
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "pplvo-test: no\n");

  const StoppingNode* seen = nullptr;
  testing::internal::CaptureStderr();
  EXPECT_EQ(runLcmNode<StoppingNode>(
                p, [](msgs::Bus) { return std::make_unique<StoppingNode>(); },
                [&](const StoppingNode& n) {
                  seen = &n;
                  return format("polls %d statuses %d final %d\n", n.polls, n.statuses,
                                n.final_statuses);
                }),
            0);
  EXPECT_NE(seen, nullptr);
  // Polled between messages until the shutdown; the status published by spin() on its way out
  // and once more, the final one, before the summary.
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "polls 1 statuses 2 final 1\n");
}

}  // namespace
}  // namespace pplvo::node
