#!/usr/bin/env bash
# The documented two-host deployment (docs/networking.md, "Across hosts") on one machine:
# two private network namespaces joined by a veth pair that exists only inside them.
#
#   sensor host: pplvo-launch (player, depth filter, frontend, estimator, logger); frames,
#                depth maps and features on host-local routes (ttl=0), poses, statuses and
#                stream events on the main URL with ttl=1
#   base host:   pplvo-logger (trajectory, event log of poses/statuses/stream, summary), as a
#                robot's main computer or a monitoring station would run it
#
# The link can lose packets (a BPF program attached by tc to both ends: this kernel has no
# sch_netem) and be rate-limited (tbf). Prints key: value lines: frames, poses on each host,
# poses lost on the link, recovery after the loss stops, bytes and packets on the link, IP
# datagrams the base host had to reassemble (0: no message crossed in fragments).
#
# usage: scripts/cross_host.sh --dataset DIR --out DIR [--loss PCT] [--loss-until-pose N]
#                              [--rate-mbit R] [--bin-dir DIR] [-- pplvo-launch args...]
#   --loss PCT          share of packets dropped on the link, each direction (default 0)
#   --loss-until-pose N drop only until the sensor host has published N poses, then a clean
#                       link (default 0: the whole run); recovery is measured from that moment
#   --rate-mbit R       limit the link to R Mbit/s each direction (default: veth speed)
# Needs root (namespaces, tc, BPF) and clang for --loss; exits 77 when it cannot run here.
set -euo pipefail
cd "$(dirname "$0")/.."

DATASET="" OUT="" LOSS=0 LOSS_UNTIL_POSE=0 RATE="" BIN_DIR=${PPLVO_BIN_DIR:-build/bin}
LAUNCH_ARGS=()
while [[ $# -gt 0 ]]; do
  case $1 in
    --dataset) DATASET=$2; shift 2 ;;
    --out) OUT=$2; shift 2 ;;
    --loss) LOSS=$2; shift 2 ;;
    --loss-until-pose) LOSS_UNTIL_POSE=$2; shift 2 ;;
    --rate-mbit) RATE=$2; shift 2 ;;
    --bin-dir) BIN_DIR=$2; shift 2 ;;
    --) shift; LAUNCH_ARGS=("$@"); break ;;
    *) echo "cross_host.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done
[[ -n $DATASET && -n $OUT ]] || { sed -n 2,24p "$0" >&2; exit 2; }
BIN_DIR=$(cd "$BIN_DIR" && pwd)
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)

if [[ $(id -u) -ne 0 ]]; then
  echo "cross_host.sh: needs root (network namespaces joined by veth, tc, BPF)" >&2
  exit 77
fi
for tool in unshare nsenter ip tc python3; do
  command -v "$tool" > /dev/null || { echo "cross_host.sh: $tool not found" >&2; exit 77; }
done

# Addresses of a link that exists only between the two namespaces.
SENSOR_IF=pplvo-sensor BASE_IF=pplvo-base
SENSOR_ADDR=10.213.77.1/24 BASE_ADDR=10.213.77.2/24
MAIN_URL='udpm://239.255.76.67:7667?ttl=1'

SENSOR_NS="" BASE_NS="" BASE_LOGGER="" SENSOR_RECORDER=""
cleanup() {
  # Only what this script started, by id; the namespaces and the veth pair go with the holders.
  for pid in $BASE_LOGGER $SENSOR_RECORDER; do kill -TERM "$pid" 2> /dev/null || true; done
  for pid in $SENSOR_NS $BASE_NS; do kill "$pid" 2> /dev/null || true; done
  wait 2> /dev/null || true
}
trap cleanup EXIT

unshare -n sleep infinity & SENSOR_NS=$!
unshare -n sleep infinity & BASE_NS=$!
sleep 0.2
in_sensor() { nsenter -t "$SENSOR_NS" -n -- "$@"; }
in_base() { nsenter -t "$BASE_NS" -n -- "$@"; }

in_sensor ip link add "$SENSOR_IF" type veth peer name "$BASE_IF" netns "$BASE_NS"
setup_host() {  # namespace-runner interface address
  "$1" ip link set lo up
  "$1" ip link set "$2" up multicast on
  "$1" ip addr add "$3" dev "$2"
  "$1" ip route add 224.0.0.0/4 dev "$2"
}
setup_host in_sensor "$SENSOR_IF" "$SENSOR_ADDR"
setup_host in_base "$BASE_IF" "$BASE_ADDR"

if [[ -n $RATE ]]; then
  for pair in "in_sensor $SENSOR_IF" "in_base $BASE_IF"; do
    read -r runner dev <<< "$pair"
    $runner tc qdisc add dev "$dev" root tbf rate "${RATE}mbit" burst 64kb latency 100ms
  done
fi

attach_loss() {
  command -v clang > /dev/null || { echo "cross_host.sh: --loss needs clang" >&2; exit 77; }
  local per_million
  per_million=$(python3 -c "print(round(float('$LOSS') * 10000))")
  clang -O2 -target bpf -I"/usr/include/$(gcc -dumpmachine)" -DDROP_PER_MILLION="$per_million" \
    -c scripts/netsim/drop_packets.bpf.c -o "$OUT/drop_packets.o"
  for pair in "in_sensor $SENSOR_IF" "in_base $BASE_IF"; do
    read -r runner dev <<< "$pair"
    $runner tc qdisc add dev "$dev" clsact
    $runner tc filter add dev "$dev" egress bpf da obj "$OUT/drop_packets.o" sec classifier
  done
}
detach_loss() {
  in_sensor tc filter del dev "$SENSOR_IF" egress
  in_base tc filter del dev "$BASE_IF" egress
}
[[ $LOSS == 0 ]] || attach_loss

rm -f "$OUT"/base.lcmlog "$OUT"/sensor_poses.lcmlog
# nsenter execs the program: $! is the logger itself (a shell function would fork a subshell
# that ignores the signal meant for it).
nsenter -t "$BASE_NS" -n -- "$BIN_DIR/pplvo-logger" --lcm-url "$MAIN_URL" --trajectory "$OUT/base_trajectory.txt" \
  --output "$OUT/base.lcmlog" --channels 'PPLVO_(POSE|STATUS|STREAM)' \
  --summary "$OUT/base_summary.yaml" > "$OUT/base_logger.log" 2>&1 & BASE_LOGGER=$!
# What the sensor host published, with the same clock: the reference for the base host.
nsenter -t "$SENSOR_NS" -n -- "$BIN_DIR/pplvo-logger" --lcm-url "$MAIN_URL" --output "$OUT/sensor_poses.lcmlog" \
  --channels PPLVO_POSE > "$OUT/sensor_recorder.log" 2>&1 & SENSOR_RECORDER=$!
sleep 0.5

read_link() {  # bytes and packets sent by the sensor host's end
  in_sensor cat /proc/net/dev | awk -v d="$SENSOR_IF:" '$1 == d { print $10, $11 }'
}
read -r tx_bytes0 tx_packets0 <<< "$(read_link)"

nsenter -t "$SENSOR_NS" -n -- "$BIN_DIR/pplvo-launch" --dataset "$DATASET" --output "$OUT/sensor_trajectory.txt" \
  --lcm-url "$MAIN_URL" --bin-dir "$BIN_DIR" --quiet "${LAUNCH_ARGS[@]}" \
  > "$OUT/launch_report.txt" 2> "$OUT/launch.err" & LAUNCH=$!
LOSS_STOPPED=""
if [[ $LOSS != 0 && $LOSS_UNTIL_POSE != 0 ]]; then
  # Poses, not seconds: the same share of the run is lossy on a fast or a loaded machine.
  while kill -0 "$LAUNCH" 2> /dev/null; do
    published=$(python3 scripts/netsim/pose_delivery.py --count "$OUT/sensor_poses.lcmlog")
    if [[ $published -ge $LOSS_UNTIL_POSE ]]; then
      detach_loss
      LOSS_STOPPED=$(date +%s%6N)
      break
    fi
    sleep 0.05
  done
  [[ -n $LOSS_STOPPED ]] || echo "cross_host.sh: the launch ended before pose $LOSS_UNTIL_POSE" >&2
fi
launch_rc=0
wait "$LAUNCH" || launch_rc=$?
read -r tx_bytes1 tx_packets1 <<< "$(read_link)"
# The last poses and final statuses reach the base host: wait until its log stops growing
# (checked every 0.5 s, at least 1 s, at most 20 s: only a hang reaches the bound), so that a
# loaded machine does not cut the base logger short.
base_poses=-1
for half_seconds in $(seq 40); do
  sleep 0.5
  now=$(python3 scripts/netsim/pose_delivery.py --count "$OUT/base.lcmlog")
  [[ $now -eq $base_poses && $half_seconds -ge 2 ]] && break
  base_poses=$now
done
kill -TERM "$BASE_LOGGER" "$SENSOR_RECORDER"
wait "$BASE_LOGGER" || true
wait "$SENSOR_RECORDER" || true
BASE_LOGGER="" SENSOR_RECORDER=""

frames=$(awk '/^launch.frames_published:/ { print $2 }' "$OUT/launch_report.txt")
echo "launch_exit: $launch_rc"
echo "launch_result: $(awk '/^launch.result:/ { print $2 }' "$OUT/launch_report.txt")"
echo "frames_published: ${frames:-0}"
echo "loss_percent: $LOSS"
echo "rate_mbit: ${RATE:-unlimited}"
python3 scripts/netsim/pose_delivery.py "$OUT/sensor_poses.lcmlog" "$OUT/base.lcmlog" \
  ${LOSS_STOPPED:+"$LOSS_STOPPED"}
echo "base_trajectory_poses: $(grep -vc '^#' "$OUT/base_trajectory.txt" || true)"
link_bytes=$((tx_bytes1 - tx_bytes0))
echo "link_bytes_sensor_to_base: $link_bytes"
echo "link_packets_sensor_to_base: $((tx_packets1 - tx_packets0))"
if [[ ${frames:-0} -gt 0 ]]; then
  echo "link_bytes_per_frame: $((link_bytes / frames))"
  echo "link_kbit_s_at_30hz: $((link_bytes * 30 * 8 / frames / 1000))"
fi
# IP datagrams that arrived in fragments (each would pin reassembly memory when one is lost).
# shellcheck disable=SC2016  # awk's own $ fields
echo "base_ip_reassembly_requests: $(in_base awk '/^Ip:/ {
  if (!n++) { for (i = 2; i <= NF; i++) if ($i == "ReasmReqds") col = i } else print $col }' \
  /proc/net/snmp)"
