#include "pplvo/msgs/bus.h"

#include <poll.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

#include "pplvo/msgs/node_runtime.h"

namespace pplvo::msgs {

std::string parseChannelRoute(const std::string& text, ChannelRoute* route) {
  const size_t eq = text.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == text.size()) {
    return "expected CHANNEL=URL, got '" + text + "'";
  }
  ChannelRoute r{text.substr(0, eq), text.substr(eq + 1)};
  if (isChannelPattern(r.channel)) {
    return "a route needs one channel name, not a pattern: '" + r.channel + "'";
  }
  if (r.url.find("://") == std::string::npos) {
    return "route of " + r.channel + ": '" + r.url + "' is not an LCM URL (provider://...)";
  }
  *route = r;
  return "";
}

namespace {

/// Adds `route`, replacing an earlier route of the same channel (the later one wins).
void setRoute(std::vector<ChannelRoute>* routes, const ChannelRoute& route) {
  auto same = std::find_if(routes->begin(), routes->end(),
                           [&](const ChannelRoute& o) { return o.channel == route.channel; });
  if (same != routes->end()) {
    *same = route;
  } else {
    routes->push_back(route);
  }
}

}  // namespace

ArgParser& addRouteOption(ArgParser& parser, std::vector<ChannelRoute>* routes) {
  return parser.option("--route", [routes](const std::string& text) -> std::string {
    ChannelRoute r;
    const std::string error = parseChannelRoute(text, &r);
    if (!error.empty()) return "--route: " + error;
    setRoute(routes, r);
    return "";
  });
}

bool BlockedPublishLog::record(const std::string& channel, double elapsed_ms) {
  if (!(elapsed_ms > kBlockedPublishMs)) return false;
  std::lock_guard<std::mutex> lock(mutex_);
  BlockedPublishes& b = channels_[channel];
  if (b.count == 0) {
    b.channel = channel;
    std::fprintf(stderr,
                 "warning: publishing %s blocked for %.0f ms: the link or a receiver is slower "
                 "than the data (counted in the status as %s)\n",
                 channel.c_str(), elapsed_ms, blockedPublishStage(channel).c_str());
  }
  ++b.count;
  b.last_ms = elapsed_ms;
  b.total_ms += elapsed_ms;
  b.max_ms = std::max(b.max_ms, elapsed_ms);
  return true;
}

std::vector<BlockedPublishes> BlockedPublishLog::channels() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<BlockedPublishes> out;
  for (const auto& [channel, b] : channels_) out.push_back(b);
  return out;
}

std::string blockedPublishStage(const std::string& channel) {
  return "publish_blocked:" + channel;
}

void appendBlockedPublishes(const Bus& bus, pplvo_msgs::node_status_t* status) {
  for (const BlockedPublishes& b : bus.blockedPublishes()) {
    pplvo_msgs::stage_timing_t t;
    t.name = blockedPublishStage(b.channel);
    t.count = b.count;
    t.last_ms = b.last_ms;
    t.mean_ms = b.total_ms / static_cast<double>(b.count);
    t.max_ms = b.max_ms;
    status->stages.push_back(t);
  }
  status->n_stages = static_cast<int32_t>(status->stages.size());
}

void Bus::notePublishTime(const std::string& channel,
                          std::chrono::steady_clock::time_point start) const {
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  routing_->blocked.record(channel, ms);
}

bool isChannelPattern(const std::string& channel) {
  return channel.find_first_of(".*+?[](){}|^$\\") != std::string::npos;
}

Bus::Bus(lcm::LCM& lcm) : routing_(std::make_shared<Routing>()) { routing_->fallback = &lcm; }

void Bus::route(const std::string& channel, lcm::LCM& lcm) { routing_->routes[channel] = &lcm; }

lcm::LCM& Bus::instanceFor(const std::string& channel) const {
  auto it = routing_->routes.find(channel);
  return it == routing_->routes.end() ? *routing_->fallback : *it->second;
}

std::vector<lcm::LCM*> Bus::receiveOn(const std::string& channel) const {
  std::vector<lcm::LCM*> on;
  if (isChannelPattern(channel)) {
    on.push_back(routing_->fallback);
    for (const auto& [name, l] : routing_->routes) {
      if (std::find(on.begin(), on.end(), l) == on.end()) on.push_back(l);
    }
  } else {
    on.push_back(&instanceFor(channel));
  }
  for (lcm::LCM* l : on) {
    auto& r = routing_->receiving;
    if (std::find(r.begin(), r.end(), l) != r.end()) continue;
    r.push_back(l);
    // On udpm this joins the instance's group: the caller subscribes on it right after.
    routing_->wait_fds.push_back({l->getFileno(), POLLIN, 0});
  }
  return on;
}

void Bus::unsubscribe(const BusSubscription& s) const {
  for (const auto& [l, sub] : s.parts) {
    if (sub) l->unsubscribe(sub);
  }
  auto& adapters = routing_->adapters;
  adapters.erase(std::remove(adapters.begin(), adapters.end(), s.adapter), adapters.end());
}

size_t Bus::instanceCount() const {
  std::vector<lcm::LCM*> all{routing_->fallback};
  for (const auto& [name, l] : routing_->routes) {
    if (std::find(all.begin(), all.end(), l) == all.end()) all.push_back(l);
  }
  return all.size();
}

int Bus::handleTimeout(int timeout_ms) const {
  const std::vector<lcm::LCM*>& receiving = routing_->receiving;
  if (receiving.empty() && !routing_->routes.empty()) {
    // Nothing subscribed on a routed bus (a free-running player): just wait, joining no group.
    ::poll(nullptr, 0, timeout_ms);
    return 0;
  }
  // Nothing subscribed on one instance: handle it anyway, as before routes existed (in one
  // process over memq:// the player's handling dispatches every node's messages).
  if (receiving.size() <= 1) {
    return (receiving.empty() ? routing_->fallback : receiving.front())->handleTimeout(timeout_ms);
  }
  std::vector<pollfd>& fds = routing_->wait_fds;
  const int ready = ::poll(fds.data(), fds.size(), timeout_ms);
  if (ready <= 0) return ready;  // 0 timeout, -1 error or EINTR (a signal: shutdown)
  int handled = 0;
  for (size_t i = 0; i < fds.size(); ++i) {
    if (!(fds[i].revents & (POLLIN | POLLERR | POLLHUP))) continue;
    const int rc = receiving[i]->handleTimeout(0);
    if (rc < 0) return rc;
    handled += rc;
  }
  return handled;
}

std::vector<ChannelRoute> parseRoutesVariable(const std::string& value,
                                              std::vector<std::string>* errors) {
  std::vector<ChannelRoute> routes;
  size_t begin = 0;
  while (begin <= value.size()) {
    const size_t end = std::min(value.find(';', begin), value.size());
    std::string entry = value.substr(begin, end - begin);
    const size_t first = entry.find_first_not_of(" \t\n");
    const size_t last = entry.find_last_not_of(" \t\n");
    entry = first == std::string::npos ? "" : entry.substr(first, last - first + 1);
    if (!entry.empty()) {
      ChannelRoute r;
      const std::string error = parseChannelRoute(entry, &r);
      if (error.empty()) {
        setRoute(&routes, r);
      } else {
        errors->push_back(std::string(kRoutesVariable) + ": " + error);
      }
    }
    begin = end + 1;
  }
  return routes;
}

namespace {

/// `explicit_routes` over those of the environment when the URL comes from there too.
std::vector<ChannelRoute> effectiveRoutes(const std::string& default_url,
                                          const std::vector<ChannelRoute>& explicit_routes) {
  const char* env = default_url.empty() ? std::getenv(kRoutesVariable) : nullptr;
  if (env == nullptr) return explicit_routes;
  std::vector<std::string> errors;
  std::vector<ChannelRoute> routes = parseRoutesVariable(env, &errors);
  if (!errors.empty()) throw std::runtime_error(errors.front());
  for (const ChannelRoute& r : explicit_routes) setRoute(&routes, r);
  return routes;
}

}  // namespace

BusConnections::BusConnections(const std::string& default_url,
                               const std::vector<ChannelRoute>& explicit_routes)
    : instances_([&] {
        std::vector<std::pair<std::string, std::unique_ptr<lcm::LCM>>> v;
        // Keyed by the URL actually used, so that a route to the same URL shares the instance.
        const char* env = std::getenv("LCM_DEFAULT_URL");
        const std::string key = default_url.empty() && env != nullptr ? env : default_url;
        v.emplace_back(key, openLcm(default_url));
        return v;
      }()),
      bus_(*instances_.front().second) {
  for (const ChannelRoute& r : effectiveRoutes(default_url, explicit_routes)) {
    auto it = std::find_if(instances_.begin(), instances_.end(),
                           [&](const auto& i) { return i.first == r.url; });
    if (it == instances_.end()) {
      instances_.emplace_back(r.url, openLcm(r.url));
      it = std::prev(instances_.end());
    }
    bus_.route(r.channel, *it->second);
  }
}

}  // namespace pplvo::msgs
