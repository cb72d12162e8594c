#!/usr/bin/env bash
# Two hosts on one machine (scripts/cross_host.sh): the pipeline on a sensor host, a logger on a
# base host, over links that lose packets or are rate-limited; once with the launch's layout
# (frames, depth maps and features host-local, ttl=0) and once with every channel on the LAN
# (--single-url with ttl=1: what a deployment without routes does). Free-running at the
# camera's rate, as on a robot. Prints a markdown table: frames published, posed on the sensor
# host, poses at the base host, bytes a frame on the link, blocked publishes.
#
# usage: scripts/benchmark_cross_host.sh DATASET [--fps HZ] [--out DIR]   (root; ~5-10 min)
set -euo pipefail
cd "$(dirname "$0")/.."
DATASET=${1:?usage: benchmark_cross_host.sh DATASET [--fps HZ] [--out DIR]}
shift
FPS=() OUT=""
while [[ $# -gt 0 ]]; do
  case $1 in
    --fps) FPS=(--fps "$2"); shift 2 ;;
    --out) OUT=$2; shift 2 ;;
    *) echo "unknown argument $1" >&2; exit 2 ;;
  esac
done

[[ -n $OUT ]] || OUT=$(mktemp -d /tmp/pplvo_cross_host_bench_XXXXXX)
mkdir -p "$OUT"
value() { awk -v k="$1:" '$1 == k { print $2 }' "$2"; }
echo "| layout | link | frames | posed (sensor) | poses at base | link bytes/frame | blocked publishes | result |"
echo "|---|---|---|---|---|---|---|---|"
for layout in host-local all-on-lan; do
  extra=()
  [[ $layout == all-on-lan ]] && extra=(--single-url)
  for link in clean "loss 1" "loss 5" "rate 100" "rate 20"; do
    read -r kind amount <<< "$link"
    opts=()
    case $kind in
      loss) opts=(--loss "$amount") ;;
      rate) opts=(--rate-mbit "$amount") ;;
    esac
    name="${layout}_${kind}${amount:-}"
    rc=0
    timeout 600 scripts/cross_host.sh --dataset "$DATASET" --out "$OUT/$name" "${opts[@]}" \
      -- --rate 1 "${FPS[@]}" "${extra[@]}" > "$OUT/$name.txt" 2> "$OUT/$name.err" || rc=$?
    [[ $rc -eq 77 ]] && { cat "$OUT/$name.err" >&2; exit 77; }
    r=$OUT/$name.txt
    blocked=$({ grep '^launch.fault:' "$OUT/$name/launch_report.txt" |
      grep -o '[0-9]* publish(es) blocked, up to [0-9]* ms' || true; } | awk '{ n += $1; if ($6 > m) m = $6 } END {
        if (n) printf "%d (up to %d ms)", n, m; else print 0 }')
    label=$link
    [[ $kind == loss ]] && label="$amount % loss"
    [[ $kind == rate ]] && label="$amount Mbit/s"
    echo "| $layout | $label | $(value frames_published "$r") | $(value poses_on_sensor "$r") |" \
      "$(value poses_on_base "$r") | $(value link_bytes_per_frame "$r") | $blocked |" \
      "$(value launch_result "$r") |"
  done
done
echo
echo "(outputs in $OUT)"
