#!/usr/bin/env bash
# Speed of pplvo-run as a ratio to the peer measured in the same run (issue 21): on every
# benchmark sequence, N interleaved pairs (pplvo-run in its default configuration -- all
# features, O-GM_10 -- then pplvo-peer-odometry in its default mode, OpenCV RgbdOdometry frame
# to frame, on the same frames), each timed as a whole process (start-up, reading and decoding
# the images included) by bash's `times` of the child. A slow period of this shared machine
# moves both members of a pair, so the ratio varies less than the absolute figures.
#
#   scripts/benchmark_speed.sh [--build DIR] [--out DIR] [--pairs N] [--frames N] [--markdown FILE]
#
# Sequences as scripts/benchmark.sh (scripts/benchmark_sequences.sh): the synthetic room and every
# folder of ../shared/data (or $PPLVO_SHARED_DATA) with a groundtruth.txt. --pairs: pairs per
# sequence (default 3). --markdown FILE: the table in Markdown (default OUT/speed.md).
# Per sequence it prints the median pplvo/peer ratio of wall time and of CPU time (user +
# system) over the pairs with [min, max], and the median frames/s of both (frames processed /
# wall time) with [min, max]. Exit 1 when a run fails.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build="$here/build"
out=""
pairs=3
synth_frames=150
markdown=""
while [ $# -gt 0 ]; do
  case "$1" in
    --build) build="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --pairs) pairs="$2"; shift 2 ;;
    --frames) synth_frames="$2"; shift 2 ;;
    --markdown) markdown="$2"; shift 2 ;;
    -h|--help) sed -n 2,16p "$0"; exit 0 ;;
    *) echo "benchmark_speed.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
case "$pairs" in ''|*[!0-9]*|0) echo "benchmark_speed.sh: --pairs takes a positive integer" >&2; exit 2 ;; esac
bin="$build/bin"
# shellcheck source=benchmark_sequences.sh
. "$here/scripts/benchmark_sequences.sh"
benchmark_require_tools benchmark_speed.sh "$bin" pplvo-run pplvo-synth pplvo-peer-odometry
shared="${PPLVO_SHARED_DATA:-$here/../shared/data}"
out="${out:-$build/benchmark}"
markdown="${markdown:-$out/speed.md}"
mkdir -p "$out/speed"

declare -a names dirs fpss
benchmark_sequences "$bin" "$out/synth_room" "$synth_frames" "$shared"

# timed LOG CMD...: runs CMD with stdout and stderr to LOG; prints "wall_s cpu_s" of the child:
# wall from bash's $EPOCHREALTIME around it, CPU = user + system of the waited-for child from
# bash's `times` (children's totals of this subshell, which runs nothing else; written to a
# file, since `times` in a pipe or $(...) would run in a fresh process with no children).
timed() {
  local log=$1; shift
  (
    t0=$EPOCHREALTIME
    "$@" > "$log" 2>&1 || { echo "benchmark_speed.sh: failed ($*), see $log" >&2; exit 1; }
    t1=$EPOCHREALTIME
    times > "$log.times"
    # Second line: the children's user and system time as NmN.NNNs.
    awk -v a="$t0" -v b="$t1" 'NR == 2 {
      split($1, u, /[ms]/); split($2, s, /[ms]/)
      printf "%.3f %.3f\n", b - a, u[1] * 60 + u[2] + s[1] * 60 + s[2] }' "$log.times"
  )
}
# stats X...: "median min max" of the numbers.
stats() {
  printf '%s\n' "$@" | sort -g | awk '{ v[NR] = $1 } END {
    m = (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2
    print m, v[1], v[NR] }'
}

{
  echo "| sequence | frames | wall ratio pplvo/peer, median [min, max] | CPU ratio pplvo/peer, median [min, max] | pplvo-run frames/s, median [min, max] | peer frames/s, median [min, max] | pairs |"
  echo "|---|---|---|---|---|---|---|"
} > "$markdown"

for i in "${!names[@]}"; do
  n="${names[$i]}"; d="${dirs[$i]}"; fps="${fpss[$i]}"
  fpsarg=()
  [ "$fps" != 0 ] && fpsarg=(--fps "$fps")
  rw=(); rc=(); fa=(); fb=()
  for ((p = 1; p <= pairs; p++)); do
    aw=""; bw=""
    base="$out/speed/$n.$p"
    read -r aw ac < <(timed "$base.pplvo.log" "$bin/pplvo-run" --dataset "$d" "${fpsarg[@]}" \
      --output "$base.pplvo.txt" --summary "$base.pplvo.yaml" --quiet --no-progress)
    read -r bw bc < <(timed "$base.peer.log" "$bin/pplvo-peer-odometry" --dataset "$d" \
      --output "$base.peer.txt")
    # A failed run printed its error (timed) and no times.
    [ -n "${aw:-}" ] && [ -n "${bw:-}" ] || exit 1
    na="$(awk '$1 == "frames_published:" { print $2; exit }' "$base.pplvo.yaml")"
    nb="$(awk '$1 == "frames:" { print $2; exit }' "$base.peer.log")"
    rw+=("$(awk -v a="$aw" -v b="$bw" 'BEGIN { print a / b }')")
    rc+=("$(awk -v a="$ac" -v b="$bc" 'BEGIN { print a / b }')")
    fa+=("$(awk -v n="$na" -v t="$aw" 'BEGIN { print n / t }')")
    fb+=("$(awk -v n="$nb" -v t="$bw" 'BEGIN { print n / t }')")
    echo "$n pair $p: pplvo-run ${aw} s wall ${ac} s CPU ($na frames), peer ${bw} s wall ${bc} s CPU ($nb frames)" >&2
  done
  read -r rwm rwl rwh < <(stats "${rw[@]}")
  read -r rcm rcl rch < <(stats "${rc[@]}")
  read -r fam fal fah < <(stats "${fa[@]}")
  read -r fbm fbl fbh < <(stats "${fb[@]}")
  printf "| %s | %s | %.2f [%.2f, %.2f] | %.2f [%.2f, %.2f] | %.1f [%.1f, %.1f] | %.1f [%.1f, %.1f] | %d |\n" \
    "$n" "$na" "$rwm" "$rwl" "$rwh" "$rcm" "$rcl" "$rch" "$fam" "$fal" "$fah" "$fbm" "$fbl" "$fbh" \
    "$pairs" >> "$markdown"
done
cat "$markdown"
