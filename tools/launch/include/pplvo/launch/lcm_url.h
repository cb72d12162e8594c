#pragma once
/// The LCM URL policy of a launch: which URL every process gets, the per-frame data channels on
/// ports of their own, and the receive buffers the kernel allows (docs/launch.md,
/// docs/channels.md).
#include <cstdint>
#include <string>
#include <vector>

#include "pplvo/launch/launch_args.h"

namespace pplvo::launch {

/// The LCM URL used inside an isolated namespace when --lcm-url is not given
/// (LCM's default group and port, ttl=0: multicast looped back on lo only).
inline constexpr const char* kIsolatedUrl = "udpm://239.255.76.67:7667?ttl=0";

/// An LCM provider URL taken apart (only what the policy needs).
struct LcmUrl {
  std::string provider;  ///< "udpm", "memq", "file", ...
  std::string address;   ///< udpm: multicast group, e.g. 239.255.76.67
  int port = 0;          ///< udpm: port (LCM's default 7667)
  int ttl = 0;           ///< udpm: ttl option (LCM's default 0)
  bool valid = false;
  std::string error;
};
LcmUrl parseLcmUrl(const std::string& url);

/// The URL policy. Separate processes need udpm (memq:// is one process, file:// is not a
/// bus). With --isolated the URL must be a udpm multicast group with ttl=0 (a "loopback"
/// URL: traffic stays on lo of the private namespace); otherwise a ttl > 0 gives a warning.
struct UrlDecision {
  std::string url;  ///< URL handed to every process
  /// "CHANNEL=URL" for each per-frame data channel (see frameChannelRoutes); empty with
  /// --single-url.
  std::vector<std::string> routes;
  bool compress = false;              ///< the receive buffers are too small for raw frames
  std::vector<std::string> errors;    ///< refuse to run
  std::vector<std::string> warnings;  ///< print and run
};
/// A udpm URL without `recv_buf_size` gets one: min(`rmem_max_bytes`, 16 MiB) (the kernel
/// caps SO_RCVBUF at net.core.rmem_max; LCM's default, the kernel's 208 KiB, loses the
/// fragments of 1.5 MB frames). Below 2 MiB compression is switched on (`compress`).
/// `rmem_max_bytes` < 0: unknown, the URL is left alone.
UrlDecision decideLcmUrl(const LaunchOptions& o, const char* env_lcm_default_url,
                         int64_t rmem_max_bytes = -1);
/// The per-frame data channels on ports of their own in `udpm_url`'s group, with the same
/// options except ttl=0 (host-local: pplvo-launch runs every stage on this host, so only the
/// main URL's poses, statuses and stream events, each one datagram, may cross a network), as
/// "CHANNEL=URL": PPLVO_RGBD on port + 1, PPLVO_DEPTH_CGM + 2, PPLVO_DEPTH_FUSED
/// + 3, PPLVO_FEATURES and PPLVO_FEATURES_3D + 4. Only the processes that subscribe to a
/// channel join its port: the estimator, player, logger and launcher then never receive the
/// ~6.5 MB of images and depth maps of a 640x480 frame, nor the depth filter its own maps or
/// the ~290 KB of features; the main URL keeps poses, statuses and stream events. Empty with
/// an error when the ports would pass 65535.
std::vector<std::string> frameChannelRoutes(const std::string& udpm_url, std::string* error);

/// net.core.rmem_max of the current network namespace (-1 if unreadable).
int64_t readRmemMax();
/// Receive buffer below which raw 640x480 frames lose fragments (measured: 2 MiB worked,
/// 1 MiB lost frames in lockstep).
inline constexpr int64_t kMinRawRecvBufBytes = 2 << 20;
/// Below this even compressed 640x480 frames lose fragments (1 MiB worked, 512 KiB did not).
inline constexpr int64_t kMinCompressedRecvBufBytes = 1 << 20;

}  // namespace pplvo::launch
