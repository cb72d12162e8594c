#!/usr/bin/env bash
# Runs a command inside a private network namespace whose only interface is loopback, with
# multicast routed to it. LCM's udpm:// traffic of the command then never reaches the host's
# network. Usage: scripts/isolated.sh COMMAND [ARGS...]
# Inside, LCM_DEFAULT_URL defaults to udpm://239.255.76.67:7667?ttl=0 (loopback only) with
# recv_buf_size = min(net.core.rmem_max, 16 MiB) (LCM's default, the kernel's 208 KiB, loses
# the fragments of 640x480 frames), and PPLVO_LCM_ROUTES puts the per-frame data channels on
# ports 7668-7671, as pplvo-launch does (docs/channels.md: only their subscribers receive them).
# LCM_DEFAULT_URL_ISOLATED replaces the URL (and then no routes are set unless
# PPLVO_LCM_ROUTES is given).
set -euo pipefail
if [ -z "${PPLVO_IN_NETNS:-}" ]; then
  userns=()
  if [ "$(id -u)" -ne 0 ]; then userns=(-r); fi  # map to root in a user namespace
  exec unshare "${userns[@]}" -n env PPLVO_IN_NETNS=1 "$0" "$@"
fi
ip link set lo up
ip link set lo multicast on
ip route add 224.0.0.0/4 dev lo 2>/dev/null || true
if [ -n "${LCM_DEFAULT_URL_ISOLATED:-}" ]; then
  export LCM_DEFAULT_URL="$LCM_DEFAULT_URL_ISOLATED"
else
  rmem_max=$(cat /proc/sys/net/core/rmem_max 2> /dev/null || echo 0)
  options="?ttl=0"
  if [ "$rmem_max" -gt 0 ]; then
    options="$options&recv_buf_size=$((rmem_max < 16777216 ? rmem_max : 16777216))"
  fi
  group="udpm://239.255.76.67"
  export LCM_DEFAULT_URL="$group:7667$options"
  if [ -z "${PPLVO_LCM_ROUTES+set}" ]; then
    routes="PPLVO_RGBD=$group:7668$options;PPLVO_DEPTH_CGM=$group:7669$options"
    routes="$routes;PPLVO_DEPTH_FUSED=$group:7670$options"
    routes="$routes;PPLVO_FEATURES=$group:7671$options;PPLVO_FEATURES_3D=$group:7671$options"
    export PPLVO_LCM_ROUTES="$routes"
  fi
fi
exec "$@"
