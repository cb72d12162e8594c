#include "pplvo/launch/lcm_url.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <regex>
#include <sstream>

#include "pplvo/msgs/channels.h"
#include "text_numbers.h"

namespace pplvo::launch {

using detail::toInt;

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
    d.warnings.push_back(
        "LCM URL '" + d.url + "' has ttl=" + std::to_string(u.ttl) + ": " +
        (o.single_url ? std::string("every channel leaves this host, frames and depth maps "
                                    "included (~6.8 MB a 640x480 frame)")
                      : std::string("poses, statuses and stream events leave this host; "
                                    "frames, depth maps and features stay on it (ttl=0)")) +
        " (use --isolated for tests and demos)");
  }
  return d;
}

namespace {
/// The URL options with ttl=0: pplvo-launch starts every stage on this host, so the per-frame
/// data (~6.8 MB a 640x480 frame) never needs to leave it, whatever the main URL's ttl.
/// Returns "" or "?options".
std::string hostLocalOptions(const std::string& query) {
  // Without a ttl option LCM's default, 0, applies already.
  std::string out;
  std::istringstream qs(query);
  for (std::string kv; std::getline(qs, kv, '&');) {
    if (kv.empty()) continue;
    if (kv.rfind("ttl=", 0) == 0) kv = "ttl=0";
    out += (out.empty() ? "?" : "&") + kv;
  }
  return out;
}
}  // namespace

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
  const std::string options =
      hostLocalOptions(q == std::string::npos ? "" : udpm_url.substr(q + 1));
  std::vector<std::string> routes;
  for (const auto& [channel, offset] : channels) {
    routes.push_back(std::string(channel) + "=udpm://" + u.address + ":" +
                     std::to_string(u.port + offset) + options);
  }
  return routes;
}

}  // namespace pplvo::launch
