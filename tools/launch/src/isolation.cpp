// Private network namespace for pplvo-launch --isolated (see isolation.h and docs/launch.md).
#include "pplvo/launch/isolation.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <net/if.h>
#include <net/route.h>
#include <netinet/in.h>
#include <sched.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>

namespace pplvo::launch {

namespace {

bool writeFile(const std::string& path, const std::string& text, std::string* error) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd < 0) {
    *error = "open " + path + ": " + std::strerror(errno);
    return false;
  }
  const ssize_t n = ::write(fd, text.data(), text.size());
  const int e = errno;
  ::close(fd);
  if (n != static_cast<ssize_t>(text.size())) {
    *error = "write " + path + ": " + std::strerror(e);
    return false;
  }
  return true;
}

/// lo up with multicast, and 224.0.0.0/4 routed to it (`ip link set lo up multicast on;
/// ip route add 224.0.0.0/4 dev lo`).
bool setUpLoopback(std::string* error) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    *error = std::string("socket: ") + std::strerror(errno);
    return false;
  }
  struct ifreq ifr {};
  std::strncpy(ifr.ifr_name, "lo", IFNAMSIZ - 1);
  bool ok = ::ioctl(fd, SIOCGIFFLAGS, &ifr) == 0;
  if (ok) {
    ifr.ifr_flags = static_cast<short>(ifr.ifr_flags | IFF_UP | IFF_RUNNING | IFF_MULTICAST);
    ok = ::ioctl(fd, SIOCSIFFLAGS, &ifr) == 0;
  }
  if (!ok) {
    *error = std::string("bringing lo up: ") + std::strerror(errno);
    ::close(fd);
    return false;
  }
  struct rtentry rt {};
  auto* dst = reinterpret_cast<sockaddr_in*>(&rt.rt_dst);
  dst->sin_family = AF_INET;
  dst->sin_addr.s_addr = htonl(0xE0000000u);  // 224.0.0.0
  auto* mask = reinterpret_cast<sockaddr_in*>(&rt.rt_genmask);
  mask->sin_family = AF_INET;
  mask->sin_addr.s_addr = htonl(0xF0000000u);  // /4
  auto* gw = reinterpret_cast<sockaddr_in*>(&rt.rt_gateway);
  gw->sin_family = AF_INET;
  char dev[] = "lo";
  rt.rt_dev = dev;
  rt.rt_flags = RTF_UP;
  if (::ioctl(fd, SIOCADDRT, &rt) != 0 && errno != EEXIST) {
    *error = std::string("route 224.0.0.0/4 dev lo: ") + std::strerror(errno);
    ::close(fd);
    return false;
  }
  ::close(fd);
  return true;
}

}  // namespace

IsolationResult enterIsolatedNetwork() {
  IsolationResult r;
  const uid_t uid = ::geteuid();
  const gid_t gid = ::getegid();
  bool with_user = true;
  if (uid == 0 && ::unshare(CLONE_NEWNET) == 0) {
    with_user = false;
  } else if (::unshare(CLONE_NEWUSER | CLONE_NEWNET) != 0) {
    const int e = errno;
    r.unavailable = true;
    r.detail = std::string("unshare(CLONE_NEWUSER|CLONE_NEWNET): ") + std::strerror(e) +
               (e == EPERM || e == ENOSPC || e == EUSERS
                    ? " (unprivileged user namespaces are disabled here: see "
                      "/proc/sys/kernel/unprivileged_userns_clone, "
                      "/proc/sys/user/max_user_namespaces, AppArmor's "
                      "kernel.apparmor_restrict_unprivileged_userns)"
                    : "");
    if (e == EINVAL) r.detail += " (a multi-threaded caller cannot enter a user namespace)";
    return r;
  }
  std::string error;
  if (with_user) {
    // Keep our own identity inside (files created stay ours); `unshare -r` would map to root.
    if (!writeFile("/proc/self/setgroups", "deny", &error) ||
        !writeFile("/proc/self/uid_map", std::to_string(uid) + " " + std::to_string(uid) + " 1\n",
                   &error) ||
        !writeFile("/proc/self/gid_map", std::to_string(gid) + " " + std::to_string(gid) + " 1\n",
                   &error)) {
      r.detail = "user namespace maps: " + error;
      return r;
    }
  }
  if (!setUpLoopback(&error)) {
    r.detail = error;
    return r;
  }
  r.ok = true;
  r.detail = std::string(with_user ? "user + network namespace" : "network namespace") +
             ", lo up with multicast, 224.0.0.0/4 via lo";
  return r;
}

}  // namespace pplvo::launch
