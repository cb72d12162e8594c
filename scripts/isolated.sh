#!/usr/bin/env bash
# Runs a command inside a private network namespace whose only interface is loopback, with
# multicast routed to it. LCM's udpm:// traffic of the command then never reaches the host's
# network. Usage: scripts/isolated.sh COMMAND [ARGS...]
# Inside, LCM_DEFAULT_URL defaults to udpm://239.255.76.67:7667?ttl=0 (loopback only).
set -euo pipefail
if [ -z "${PPLVO_IN_NETNS:-}" ]; then
  userns=()
  if [ "$(id -u)" -ne 0 ]; then userns=(-r); fi  # map to root in a user namespace
  exec unshare "${userns[@]}" -n env PPLVO_IN_NETNS=1 "$0" "$@"
fi
ip link set lo up
ip link set lo multicast on
ip route add 224.0.0.0/4 dev lo 2>/dev/null || true
export LCM_DEFAULT_URL="${LCM_DEFAULT_URL_ISOLATED:-udpm://239.255.76.67:7667?ttl=0}"
exec "$@"
