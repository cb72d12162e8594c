// msgs::Bus: channel routes over several LCM instances (memq:// here: one process).
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <lcm/lcm-cpp.hpp>
#include <optional>
#include <pplvo_msgs/node_status_t.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "pplvo/core/args.h"
#include "pplvo/msgs/bus.h"
#include "pplvo/msgs/node_runtime.h"

namespace pplvo::msgs {
namespace {

struct Received {
  std::vector<std::string> channels;
  void onStatus(const lcm::ReceiveBuffer*, const std::string& channel,
                const pplvo_msgs::node_status_t*) {
    channels.push_back(channel);
  }
  void onRaw(const lcm::ReceiveBuffer*, const std::string& channel) { channels.push_back(channel); }
  NodeCounters counters;
};

/// A handler that throws out of itself on every message (what nodes never do: guarded()).
struct Throwing {
  int calls = 0;
  NodeCounters counters;
  void onStatus(const lcm::ReceiveBuffer*, const std::string&, const pplvo_msgs::node_status_t*) {
    ++calls;
    throw std::runtime_error("handler failed");
  }
};

pplvo_msgs::node_status_t status() { return toStatusMsg("test", NodeCounters{}, {}, 1); }

int drain(const Bus& bus) {
  int n = 0;
  for (int rc; (rc = bus.handleTimeout(0)) > 0;) n += rc;
  return n;
}

TEST(ChannelRoute, ParseAndOption) {
  ChannelRoute r;
  EXPECT_EQ(parseChannelRoute("PPLVO_RGBD=udpm://239.255.76.67:7668?ttl=0", &r), "");
  EXPECT_EQ(r.channel, "PPLVO_RGBD");
  EXPECT_EQ(r.url, "udpm://239.255.76.67:7668?ttl=0");  // '=' in the URL's options stay
  EXPECT_NE(parseChannelRoute("PPLVO_RGBD", &r), "");
  EXPECT_NE(parseChannelRoute("=memq://", &r), "");
  EXPECT_NE(parseChannelRoute("PPLVO_RGBD=", &r), "");
  EXPECT_NE(parseChannelRoute("PPLVO_.*=memq://", &r).find("pattern"), std::string::npos);
  EXPECT_NE(parseChannelRoute("PPLVO_RGBD=239.255.76.67", &r).find("URL"), std::string::npos);

  std::vector<ChannelRoute> routes;
  ArgParser p;
  addRouteOption(p, &routes);
  p.parse({"--route", "A=memq://", "--route", "B=udpm://239.255.76.67:7668", "--route",
           "A=udpm://239.255.76.67:7669", "--route", "bad"});
  ASSERT_EQ(p.errors().size(), 1u);
  EXPECT_NE(p.errors()[0].find("--route"), std::string::npos);
  ASSERT_EQ(routes.size(), 2u);  // the later route of A replaced the earlier one
  EXPECT_EQ(routes[0].channel, "A");
  EXPECT_EQ(routes[0].url, "udpm://239.255.76.67:7669");
  EXPECT_EQ(routes[1].channel, "B");
}

TEST(Bus, OneInstanceCarriesEverything) {
  lcm::LCM lcm("memq://");
  Bus bus(lcm);
  EXPECT_EQ(bus.instanceCount(), 1u);
  Received r;
  const BusSubscription s = bus.subscribe("A", &Received::onStatus, &r, r.counters, "test");
  const auto m = status();
  bus.publish("A", &m);
  lcm.publish("A", &m);  // the same instance
  EXPECT_EQ(drain(bus), 2);
  EXPECT_EQ(r.channels.size(), 2u);
  bus.unsubscribe(s);
  bus.publish("A", &m);
  drain(bus);
  EXPECT_EQ(r.channels.size(), 2u);
}

// A send held up by a slow link is counted per channel and reaches the node's status.
TEST(BlockedPublishLog, CountsOnlyPublishesSlowerThanTheBound) {
  BlockedPublishLog log;
  EXPECT_FALSE(log.record("PPLVO_RGBD", 3.0));  // a frame on loopback
  EXPECT_FALSE(log.record("PPLVO_RGBD", kBlockedPublishMs));
  EXPECT_TRUE(log.channels().empty());
  EXPECT_TRUE(log.record("PPLVO_RGBD", 250.0));
  EXPECT_TRUE(log.record("PPLVO_RGBD", 150.0));
  EXPECT_TRUE(log.record("PPLVO_DEPTH_CGM", 400.0));
  const std::vector<BlockedPublishes> c = log.channels();
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c[1].channel, "PPLVO_RGBD");
  EXPECT_EQ(c[1].count, 2);
  EXPECT_DOUBLE_EQ(c[1].max_ms, 250.0);
  EXPECT_DOUBLE_EQ(c[1].last_ms, 150.0);
  EXPECT_DOUBLE_EQ(c[1].total_ms, 400.0);
  EXPECT_EQ(c[0].count, 1);
}

TEST(BlockedPublishLog, AnUnblockedBusAddsNoStage) {
  lcm::LCM lcm("memq://");
  const Bus bus(lcm);
  pplvo_msgs::node_status_t status;
  status.n_stages = 0;
  appendBlockedPublishes(bus, &status);
  EXPECT_EQ(status.n_stages, 0);  // nothing published, nothing blocked
  EXPECT_EQ(blockedPublishStage("PPLVO_RGBD"), "publish_blocked:PPLVO_RGBD");
}

TEST(Bus, RoutedChannelTravelsOnItsOwnInstance) {
  lcm::LCM main_lcm("memq://"), frames("memq://");
  Bus bus(main_lcm);
  bus.route("FRAMES", frames);
  EXPECT_EQ(&bus.instanceFor("FRAMES"), &frames);
  EXPECT_EQ(&bus.instanceFor("POSE"), &main_lcm);
  EXPECT_EQ(bus.instanceCount(), 2u);

  // A copy shares the routing table and the set of instances to wait on.
  const Bus copy = bus;
  Received r;
  copy.subscribe("FRAMES", &Received::onStatus, &r, r.counters, "test");
  bus.subscribe("POSE", &Received::onStatus, &r, r.counters, "test");
  const auto m = status();
  bus.publish("FRAMES", &m);
  bus.publish("POSE", &m);
  EXPECT_EQ(drain(bus), 2);  // both instances were waited on
  EXPECT_EQ(r.channels, (std::vector<std::string>{"FRAMES", "POSE"}));

  // A pattern listens on every instance.
  Received all;
  const BusSubscription s = bus.subscribe(".*", &Received::onRaw, &all);
  EXPECT_EQ(s.parts.size(), 2u);
  bus.publish("FRAMES", &m);
  bus.publish("POSE", &m);
  drain(bus);
  EXPECT_EQ(all.channels.size(), 2u);
}

TEST(Bus, InstancesOnlyPublishedOnAreNotWaitedOn) {
  // On udpm, waiting on an instance joins its multicast group: a process that only publishes
  // frames must never receive them. Here: a message on the publish-only instance stays queued.
  lcm::LCM main_lcm("memq://"), frames("memq://"), other("memq://");
  Bus bus(main_lcm);
  bus.route("FRAMES", frames);
  bus.route("OTHER", other);
  Received r;
  bus.subscribe("POSE", &Received::onStatus, &r, r.counters, "test");
  bus.subscribe("OTHER", &Received::onStatus, &r, r.counters, "test");
  Received direct;  // behind the bus's back (memq drops messages nobody subscribed to)
  frames.subscribe("FRAMES", &Received::onStatus, &direct);
  const auto m = status();
  bus.publish("FRAMES", &m);
  bus.publish("OTHER", &m);
  EXPECT_EQ(drain(bus), 1);
  EXPECT_TRUE(direct.channels.empty());   // the bus never handled that instance
  EXPECT_EQ(frames.handleTimeout(0), 1);  // still queued there
}

TEST(Bus, RoutedBusWithoutSubscriptionsOnlyWaits) {
  lcm::LCM main_lcm("memq://"), frames("memq://");
  Bus bus(main_lcm);
  bus.route("FRAMES", frames);
  Received direct;
  main_lcm.subscribe("STATUS", &Received::onStatus, &direct);  // behind the bus's back
  const auto m = status();
  bus.publish("STATUS", &m);
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(bus.handleTimeout(30), 0);  // waited, handled nothing, joined nothing
  EXPECT_GE(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(25));
  EXPECT_TRUE(direct.channels.empty());
  EXPECT_EQ(main_lcm.handleTimeout(0), 1);  // still queued

  // Without routes the one instance is handled, as lcm::LCM would (pplvo-run's player).
  Bus single(main_lcm);
  bus.publish("STATUS", &m);
  EXPECT_EQ(single.handleTimeout(0), 1);
  EXPECT_EQ(direct.channels.size(), 2u);
}

TEST(Bus, SpinHandlesEveryInstanceUntilDone) {
  lcm::LCM main_lcm("memq://"), frames("memq://");
  Bus bus(main_lcm);
  bus.route("FRAMES", frames);
  Received r;
  bus.subscribe("FRAMES", &Received::onStatus, &r, r.counters, "test");
  bus.subscribe("POSE", &Received::onStatus, &r, r.counters, "test");
  const auto m = status();
  for (int i = 0; i < 3; ++i) {
    bus.publish("FRAMES", &m);
    bus.publish("POSE", &m);
  }
  int periodic = 0;
  spin(
      bus, [&] { return r.channels.size() >= 6; }, [&] { ++periodic; }, 10.0);
  EXPECT_EQ(r.channels.size(), 6u);
  EXPECT_EQ(periodic, 1);  // once at the end
}

/// A node whose worker finishes between messages asks spin() for short waits; without that it
/// waits kSpinWaitMs for a message before checking done() again. The waits are recorded by a
/// fake wait function: what spin() asks for, not how long the machine took.
TEST(Bus, SpinWaitsForAMessageAtMostWhatItIsAsked) {
  const auto waitsOfFiveChecks = [](const std::function<int()>& wait_ms) {
    std::vector<int> waits;
    int checks = 0;
    const int64_t handled = spinOn(
        [&](int timeout_ms) {
          waits.push_back(timeout_ms);
          return waits.size() % 2 == 0 ? 1 : 0;  // a message every other wait
        },
        [&] { return ++checks > 5; }, {}, 10.0, wait_ms);
    EXPECT_EQ(handled, 2);
    return waits;
  };
  EXPECT_EQ(waitsOfFiveChecks({}), std::vector<int>(5, kSpinWaitMs));
  EXPECT_EQ(waitsOfFiveChecks([] { return 2; }), std::vector<int>(5, 2));
  int asked = 3;
  EXPECT_EQ(waitsOfFiveChecks([&] { return asked--; }), (std::vector<int>{3, 2, 1, 0, 0}));
  // spin() on a real bus waits on it: a published message is handled within the first wait.
  lcm::LCM lcm("memq://");
  Bus bus(lcm);
  Received r;
  bus.subscribe("X", &Received::onStatus, &r, r.counters, "test");
  const pplvo_msgs::node_status_t m = status();
  bus.publish("X", &m);
  int checks = 0;
  const auto after_one_wait = [&] { return ++checks > 1; };
  EXPECT_EQ(spin(bus, after_one_wait, {}, 10.0, [] { return 0; }), 1);
  EXPECT_EQ(r.channels, std::vector<std::string>{"X"});
}

/// Sets an environment variable for the scope of one test.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const char* value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    ::setenv(name, value, 1);
  }
  ~ScopedEnv() {
    if (old_) {
      ::setenv(name_, old_->c_str(), 1);
    } else {
      ::unsetenv(name_);
    }
  }

 private:
  const char* name_;
  std::optional<std::string> old_;
};

TEST(BusConnections, RoutesFromTheEnvironmentOnlyWithTheEnvironmentsUrl) {
  std::vector<std::string> errors;
  const auto parsed = parseRoutesVariable(" A=memq://?a=1 ;;B=memq://?b=1;bad", &errors);
  ASSERT_EQ(parsed.size(), 2u);
  EXPECT_EQ(parsed[0].channel, "A");
  EXPECT_EQ(parsed[0].url, "memq://?a=1");
  EXPECT_EQ(parsed[1].channel, "B");
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find(kRoutesVariable), std::string::npos);
  // A later entry of the same channel wins, as with --route.
  const auto twice = parseRoutesVariable("A=memq://?a=1;B=memq://;A=memq://?a=2", &errors);
  ASSERT_EQ(twice.size(), 2u);
  EXPECT_EQ(twice[0].channel, "A");
  EXPECT_EQ(twice[0].url, "memq://?a=2");
  EXPECT_EQ(errors.size(), 1u);

  ScopedEnv url("LCM_DEFAULT_URL", "memq://");
  ScopedEnv routes(kRoutesVariable, "FRAMES=memq://?frames=1;MAPS=memq://?maps=1");
  {
    // URL and routes from the environment; an explicit route overrides one of them.
    BusConnections c("", {{"MAPS", "memq://"}});
    EXPECT_EQ(c.bus().instanceCount(), 2u);
    EXPECT_NE(&c.bus().instanceFor("FRAMES"), &c.defaultInstance());
    EXPECT_EQ(&c.bus().instanceFor("MAPS"), &c.defaultInstance());  // same URL: shared
  }
  {
    // An explicit URL (a replay, say) is never mixed with the environment's bus.
    BusConnections c("memq://", {});
    EXPECT_EQ(c.bus().instanceCount(), 1u);
  }
  ScopedEnv bad(kRoutesVariable, "FRAMES");
  try {
    BusConnections c("", {});
    FAIL() << "a bad variable must be refused";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(kRoutesVariable), std::string::npos) << e.what();
  }
}

TEST(BusConnections, SameUrlSharesOneInstance) {
  BusConnections c("memq://", {{"FRAMES", "memq://"}, {"MAPS", "memq://?x=1"}});
  EXPECT_EQ(c.bus().instanceCount(), 2u);  // FRAMES shares the default instance
  EXPECT_EQ(&c.bus().instanceFor("FRAMES"), &c.defaultInstance());
  EXPECT_NE(&c.bus().instanceFor("MAPS"), &c.defaultInstance());
  EXPECT_THROW(BusConnections("nonsense://", {}), std::runtime_error);
}

TEST(Bus, CorruptPacketsAreCountedSkipsAndTheNextMessageIsHandled) {
  lcm::LCM lcm("memq://");
  Bus bus(lcm);
  Received r;
  bus.subscribe("A", &Received::onStatus, &r, r.counters, "test");
  auto m = status();
  m.node = "a node";
  std::vector<uint8_t> good(static_cast<size_t>(m.getEncodedSize()));
  ASSERT_EQ(m.encode(good.data(), 0, static_cast<int>(good.size())), static_cast<int>(good.size()));
  // The `node` string's length field follows the 8-byte hash and utime: negative, zero, huge.
  for (const uint32_t length : {0xffffffffu, 0u, 0x7fffffffu, 0x80000000u}) {
    std::vector<uint8_t> bad = good;
    for (int i = 0; i < 4; ++i) bad[16 + i] = static_cast<uint8_t>(length >> (24 - 8 * i));
    lcm.publish("A", bad.data(), static_cast<unsigned>(bad.size()));
    lcm.publish("A", good.data(), static_cast<unsigned>(good.size()));
  }
  lcm.publish("A", good.data(), 10);  // truncated
  lcm.publish("A", good.data(), static_cast<unsigned>(good.size()));
  drain(bus);
  EXPECT_EQ(r.channels.size(), 5u);  // every good one, after each bad one
  // Packets, not frames: an undecodable one has no seq to put it in a node's frame ledger.
  EXPECT_EQ(r.counters.messages_skipped, 5);
  EXPECT_EQ(r.counters.frames_skipped, 0);
  EXPECT_EQ(r.counters.errors, 0);
  EXPECT_NE(r.counters.last_warning.find("undecodable packet on A"), std::string::npos)
      << r.counters.last_warning;
}

TEST(Bus, AnExceptionLeavingAHandlerIsCountedAndLcmKeepsHandling) {
  // In LCM 1.3.1 an exception through lcm_handle leaves its mutex locked: the next handle()
  // would hang. The bus's decoder catches it; a second message proves handle() still works.
  lcm::LCM lcm("memq://");
  Bus bus(lcm);
  Throwing t;
  bus.subscribe("A", &Throwing::onStatus, &t, t.counters, "test");
  const auto m = status();
  bus.publish("A", &m);
  bus.publish("A", &m);
  EXPECT_EQ(drain(bus), 2);
  EXPECT_EQ(t.calls, 2);
  EXPECT_EQ(t.counters.errors, 2);
  EXPECT_NE(t.counters.last_warning.find("handler failed"), std::string::npos);
}

}  // namespace
}  // namespace pplvo::msgs
