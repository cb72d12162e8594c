#pragma once
/// Channel routing over several LCM instances.
///
/// On udpm every process that joined a multicast group receives every datagram sent to it,
/// whether or not it subscribed to the channel: a 640x480 frame puts ~6.5 MB of images and
/// depth maps on the bus, and the estimator, player, logger and launcher would copy all of it
/// out of the kernel only to drop it. A route sends one channel over its own URL (another
/// multicast port), so only the processes that subscribe to that channel join it.
///
/// `Bus` is a cheap handle (copies share one routing table): nodes take a Bus, and an
/// `lcm::LCM&` converts to a Bus that carries every channel, so tests and the one-process
/// runner keep a single memq:// instance.
#include <poll.h>

#include <chrono>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include <pplvo_msgs/node_status_t.hpp>

#include "pplvo/core/args.h"
#include "pplvo/msgs/decode.h"

namespace pplvo::msgs {

struct NodeCounters;  // pplvo/msgs/convert.h

namespace detail {

/// Counts a packet on `channel` that is not the subscribed type (a skipped frame) and notes why.
void countUndecodable(NodeCounters& counters, const std::string& node, const std::string& channel,
                      const std::string& error);
/// Counts an exception that left a handler (an error): nodes catch their own (guarded()), this
/// is the last line before LCM 1.3.1's C code, through which an exception must never pass.
void countEscaped(NodeCounters& counters, const std::string& node, const std::string& what);

/// What a typed Bus subscription keeps alive while it is subscribed.
class SubscriptionAdapter {
 public:
  virtual ~SubscriptionAdapter() = default;
};

/// Receives the raw packet, decodes it with decodeMessage() and calls the node's typed handler;
/// a packet that does not decode is a counted skip, never an exception.
template <class MessageT, class Handler>
class TypedAdapter : public SubscriptionAdapter {
 public:
  using Method = void (Handler::*)(const lcm::ReceiveBuffer*, const std::string&, const MessageT*);
  TypedAdapter(Method method, Handler* handler, NodeCounters& counters, std::string node)
      : method_(method), handler_(handler), counters_(counters), node_(std::move(node)) {}

  void onRaw(const lcm::ReceiveBuffer* rbuf, const std::string& channel) noexcept {
    try {
      MessageT msg;
      const std::string error = decodeMessage(rbuf->data, rbuf->data_size, &msg);
      if (!error.empty()) {
        countUndecodable(counters_, node_, channel, error);
        return;
      }
      (handler_->*method_)(rbuf, channel, &msg);
    } catch (const std::exception& e) {
      countEscaped(counters_, node_, e.what());
    } catch (...) {
      countEscaped(counters_, node_, "unknown exception");
    }
  }

 private:
  Method method_;
  Handler* handler_;
  NodeCounters& counters_;
  std::string node_;
};

}  // namespace detail

/// A publish that took longer than this was blocked: UDP's send buffer was full because a link
/// (or a rate limit) is slower than the data. On loopback a 2.5 MB depth map takes a few ms.
inline constexpr double kBlockedPublishMs = 100.0;

/// The blocked publishes of one channel.
struct BlockedPublishes {
  std::string channel;
  int64_t count = 0;
  double last_ms = 0.0;
  double total_ms = 0.0;
  double max_ms = 0.0;
};

/// Records publishes slower than kBlockedPublishMs, per channel; thread-safe (nodes publish
/// from their workers too). The first one of a channel is said on stderr, all are counted for
/// the node's status (appendBlockedPublishes).
class BlockedPublishLog {
 public:
  /// Returns true when the publish counted as blocked.
  bool record(const std::string& channel, double elapsed_ms);
  std::vector<BlockedPublishes> channels() const;

 private:
  mutable std::mutex mutex_;
  std::map<std::string, BlockedPublishes> channels_;
};

/// The stage name under which a status reports the blocked publishes of `channel`.
std::string blockedPublishStage(const std::string& channel);

/// "CHANNEL=URL" -> {CHANNEL, URL}; empty error on success.
struct ChannelRoute {
  std::string channel;
  std::string url;
};
std::string parseChannelRoute(const std::string& text, ChannelRoute* route);

/// True when `channel` is an LCM regular expression rather than one channel name.
bool isChannelPattern(const std::string& channel);

/// The subscriptions one Bus::subscribe made (one per instance for a pattern).
struct BusSubscription {
  std::vector<std::pair<lcm::LCM*, lcm::Subscription*>> parts;
  std::shared_ptr<detail::SubscriptionAdapter> adapter;  ///< typed subscriptions: the decoder
};

/// Routes channels to LCM instances. Like lcm::LCM: subscribe and handle from one thread;
/// publishing follows LCM's own rules for its instances.
class Bus {
 public:
  /// Every channel on `lcm` (not owned).
  Bus(lcm::LCM& lcm);  // NOLINT(google-explicit-constructor): the common case, on purpose

  /// From now on `channel` goes over `lcm` (not owned). Route before subscribing.
  void route(const std::string& channel, lcm::LCM& lcm);

  /// The instance that carries `channel`.
  lcm::LCM& instanceFor(const std::string& channel) const;

  /// Subscribes on the channel's instance; a pattern subscribes on every instance. Packets are
  /// decoded here, not by LCM (which prints and drops what does not decode, uncounted): one
  /// that is not a MessageT (corrupt, truncated, another type) counts as a skipped frame in
  /// `counters` with the reason as its last warning, and an exception that leaves `method`
  /// counts as an error; neither reaches LCM. `counters` must outlive the subscription.
  template <class MessageT, class Handler>
  BusSubscription subscribe(const std::string& channel,
                            void (Handler::*method)(const lcm::ReceiveBuffer*, const std::string&,
                                                    const MessageT*),
                            Handler* handler, NodeCounters& counters,
                            const std::string& node) const {
    using Adapter = detail::TypedAdapter<MessageT, Handler>;
    auto adapter = std::make_shared<Adapter>(method, handler, counters, node);
    BusSubscription s;
    s.adapter = adapter;
    routing_->adapters.push_back(adapter);
    for (lcm::LCM* l : receiveOn(channel)) {
      s.parts.emplace_back(l, l->subscribe(channel, &Adapter::onRaw, adapter.get()));
    }
    return s;
  }
  /// Raw subscription (undecoded bytes).
  template <class Handler>
  BusSubscription subscribe(const std::string& channel,
                            void (Handler::*method)(const lcm::ReceiveBuffer*, const std::string&),
                            Handler* handler) const {
    BusSubscription s;
    for (lcm::LCM* l : receiveOn(channel)) {
      s.parts.emplace_back(l, l->subscribe(channel, method, handler));
    }
    return s;
  }
  void unsubscribe(const BusSubscription& s) const;

  /// Publishes on the channel's instance; a publish that blocks (kBlockedPublishMs) is
  /// recorded in blockedPublishes().
  template <class MessageT>
  int publish(const std::string& channel, const MessageT* msg) const {
    const auto start = std::chrono::steady_clock::now();
    const int rc = instanceFor(channel).publish(channel, msg);
    notePublishTime(channel, start);
    return rc;
  }
  int publish(const std::string& channel, const void* data, unsigned int size) const {
    const auto start = std::chrono::steady_clock::now();
    const int rc = instanceFor(channel).publish(channel, data, size);
    notePublishTime(channel, start);
    return rc;
  }
  /// The publishes of this process that blocked, per channel.
  std::vector<BlockedPublishes> blockedPublishes() const {
    return routing_->blocked.channels();
  }

  /// Waits up to `timeout_ms` for a message on any instance this process subscribed on and
  /// handles what is ready (one message per ready instance). Returns the number handled, 0 on
  /// timeout, < 0 on error (as lcm::LCM::handleTimeout; EINTR is an error, as there).
  /// Instances that were only published on are never waited on: on udpm, asking for their
  /// file descriptor would join their multicast group. With routes and no subscription at all
  /// it only waits; without routes it handles the one instance as lcm::LCM would.
  int handleTimeout(int timeout_ms) const;

  /// Number of distinct instances (1 without routes).
  size_t instanceCount() const;

 private:
  struct Routing {
    lcm::LCM* fallback = nullptr;
    std::map<std::string, lcm::LCM*> routes;
    std::vector<lcm::LCM*> receiving;  // in order of first subscription
    std::vector<pollfd> wait_fds;      // one per receiving instance, for handleTimeout
    // Decoders of the typed subscriptions, alive until unsubscribed (LCM holds raw pointers).
    std::vector<std::shared_ptr<detail::SubscriptionAdapter>> adapters;
    BlockedPublishLog blocked;
  };
  void notePublishTime(const std::string& channel,
                       std::chrono::steady_clock::time_point start) const;
  std::vector<lcm::LCM*> receiveOn(const std::string& channel) const;
  std::shared_ptr<Routing> routing_;
};

/// Adds the bus's blocked publishes to a node's status, one stage per channel
/// (blockedPublishStage(): count, last, mean and max ms), so that the launcher and a viewer see
/// which sends a slow link held up.
void appendBlockedPublishes(const Bus& bus, pplvo_msgs::node_status_t* status);

/// The environment variable with the routes of the bus, as LCM_DEFAULT_URL is its URL:
/// "CHANNEL=URL;CHANNEL=URL..." (scripts/isolated.sh sets both).
inline constexpr const char* kRoutesVariable = "PPLVO_LCM_ROUTES";

/// Parses a kRoutesVariable value (';'-separated "CHANNEL=URL", blanks around entries
/// ignored); errors are appended to `errors`.
std::vector<ChannelRoute> parseRoutesVariable(const std::string& value,
                                              std::vector<std::string>* errors);

/// The LCM instances of one process: the default URL and one instance per distinct routed
/// URL, opened together and closed together.
class BusConnections {
 public:
  /// Opens `default_url` and each route's URL; a route whose URL is the default's, or another
  /// route's, shares that instance. An empty `default_url` takes the bus from the environment:
  /// $LCM_DEFAULT_URL and the routes of $PPLVO_LCM_ROUTES (`routes` override those of the
  /// same channel). An explicit URL ignores $PPLVO_LCM_ROUTES, so that e.g. a file:// replay
  /// is never mixed with a live bus. Throws std::runtime_error naming the URL or the variable
  /// that failed.
  BusConnections(const std::string& default_url, const std::vector<ChannelRoute>& routes);
  BusConnections(const BusConnections&) = delete;
  BusConnections& operator=(const BusConnections&) = delete;

  const Bus& bus() const { return bus_; }
  lcm::LCM& defaultInstance() { return *instances_.front().second; }

 private:
  std::vector<std::pair<std::string, std::unique_ptr<lcm::LCM>>> instances_;  // url, instance
  Bus bus_;
};

/// Declares the repeatable `--route CHANNEL=URL` option of every process: each one is checked
/// and appended to `routes` (a later route of the same channel replaces the earlier one).
ArgParser& addRouteOption(ArgParser& parser, std::vector<ChannelRoute>* routes);

/// The usage lines of --route, for the processes' help texts (options in column 28).
inline constexpr const char* kRouteUsage =
    "  --route CHANNEL=URL      carry CHANNEL over URL instead of --lcm-url (repeatable;\n"
    "                           docs/channels.md: per-frame data on ports of its own)\n";

}  // namespace pplvo::msgs
