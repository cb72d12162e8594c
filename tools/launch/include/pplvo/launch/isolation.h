#pragma once
/// A private network namespace for a launch (--isolated): what scripts/isolated.sh does, in
/// process.
#include <string>

namespace pplvo::launch {

/// Result of entering a private network namespace.
struct IsolationResult {
  bool ok = false;
  bool unavailable = false;  ///< the kernel refused the namespace (EPERM/EINVAL/ENOSPC...)
  std::string detail;        ///< what was done or why it failed
};

/// Moves the calling (single-threaded!) process into a new network namespace whose only
/// interface, lo, is up with multicast on and a 224.0.0.0/4 route: what scripts/isolated.sh
/// does with `unshare -rn` + `ip`, but in-process (unshare(2) + ioctl), so no external tool is
/// needed. As root only CLONE_NEWNET is used; otherwise (or if that is refused) a user
/// namespace mapping the caller's own uid/gid comes with it. Children inherit both.
IsolationResult enterIsolatedNetwork();

}  // namespace pplvo::launch
