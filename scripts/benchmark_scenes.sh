#!/usr/bin/env bash
# Where points fail (issue 41): the paper's ablation by feature set on pplvo-synth's structured
# scenes, with the peers a user would pick instead on the same frames.
#
#   scripts/benchmark_scenes.sh --markdown FILE [--build DIR] [--out DIR] [--frames N]
#                               [--scenes "A B ..."] [--variants "hand_held clean"]
#                               [--peers DIR] [--orb-runs N]
#
# Scenes (docs/synthetic.md): structure_near, structure_far (structure without texture),
# texture_wall (texture without structure), cabinet (a plain cabinet circled), corridor
# (degenerate: translation along it unobservable) and textureless (plain room); each generated
# into OUT/scenes when missing (N frames, default 600, seed 3), in two variants: `hand_held`
# with a Kinect v1's effects (fr1 lens, 25 ms rolling shutter, 8 ms blur, colour/depth
# offsets) and `clean` (global shutter, no lens, depth at the colour instant).
# pplvo rows: points / points+lines / points+planes / lines+planes / all, against keyframes
# (the default), all with the local map and all frame to frame (the paper), every one with the
# defaults (the per-frame shared error estimated online; docs/estimator.md). Peers: OpenCV's
# RgbdOdometry, ICPOdometry and RgbdICPOdometry frame to frame and RgbdICP against keyframes
# (pplvo-peer-odometry), fovis and ORB-SLAM2 --vo (median of --orb-runs, default 3) from --peers
# (default ~/.cache/pplvo-peers; ../shared/peers/build.sh).
# A peer that crashes, never initialises or poses fewer than half the frames is reported so.
# Every row: frames posed and, for pplvo, frames tracked (not on the velocity model, not lost)
# and the NEES of its relative-pose covariance (mean, share inside the 95 % bound).
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build="$here/build"
out=""
markdown=""
frames=600
scenes="structure_near structure_far texture_wall cabinet corridor textureless"
variants="hand_held clean"
peers_dir="${HOME}/.cache/pplvo-peers"
orb_runs=3
while [ $# -gt 0 ]; do
  case "$1" in
    --build) build="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --markdown) markdown="$2"; shift 2 ;;
    --frames) frames="$2"; shift 2 ;;
    --scenes) scenes="$2"; shift 2 ;;
    --variants) variants="$2"; shift 2 ;;
    --peers) peers_dir="$2"; shift 2 ;;
    --orb-runs) orb_runs="$2"; shift 2 ;;
    -h|--help) sed -n 2,23p "$0"; exit 0 ;;
    *) echo "benchmark_scenes.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
[ -n "$markdown" ] || { echo "benchmark_scenes.sh: --markdown FILE is required (where the table goes)" >&2; exit 2; }
bin="$build/bin"
# shellcheck source=benchmark_sequences.sh
. "$here/scripts/benchmark_sequences.sh"
benchmark_require_tools benchmark_scenes.sh "$bin" pplvo-run pplvo-eval pplvo-synth pplvo-peer-odometry
out="${out:-$build/benchmark_scenes}"
mkdir -p "$out/scenes" "$out/runs"

# shellcheck disable=SC2054  # the commas are pplvo-synth's list syntax
effects=(--distortion fr1 --rolling-shutter-ms 25 --exposure-ms 8 --exposure-samples 4
  --depth-offset-ms -15,-13,16,-16,-12)

rows=()
row() { rows+=("$1"); echo "$1" >&2; }
for scene in $scenes; do
  for variant in $variants; do
    n="${scene}_${variant}"
    d="$out/scenes/$n"
    if [ ! -f "$d/groundtruth.txt" ]; then
      echo "generating $n ($frames frames)" >&2
      extra=()
      [ "$variant" = hand_held ] && extra=("${effects[@]}")
      "$bin/pplvo-synth" --output "$d" --scene "$scene" --frames "$frames" --seed 3 "${extra[@]}" \
        > "$d.log"
    fi
    total=$(awk '!/^#/ && NF' "$d/rgb.txt" | wc -l)

    pplvo_row() {  # pplvo_row LABEL ARGS...
      local label=$1; shift
      local base tracked
      base="$out/runs/$n.$(echo "$label" | tr -c 'a-z0-9' _)"
      if ! "$bin/pplvo-run" --dataset "$d" "$@" --output "$base.txt" \
           --covariance "$base.cov" --no-progress > "$base.log" 2>&1; then
        row "| $n | $label | failed (see $base.log) | | | | | |"; return
      fi
      tracked=$(sed -n 's/^frames: .*tracking \([0-9]*\).*/\1/p' "$base.log")
      read -r a t r p < <(eval_line "$d/groundtruth.txt" "$base.txt" 0)
      read -r nm ns < <(nees_cell "$d/groundtruth.txt" "$base.cov" 0 1)
      row "| $n | $label | $a | $t | $r | $p / $total | $tracked | $nm / $ns |"
    }
    for families in points points,lines points,planes lines,planes points,lines,planes; do
      label="pplvo $families"
      [ "$families" = points,lines,planes ] && label="pplvo all features (keyframe)"
      pplvo_row "$label" --features "$families"
    done
    pplvo_row "pplvo all features, local map" --set odometry.reference=local_map
    pplvo_row "pplvo all features, frame to frame (paper)" --set odometry.reference=frame

    peer_rows "$n" "$d" 0 "$out/runs" "$peers_dir" "$orb_runs" \
      "rgbd|OpenCV RgbdOdometry;icp|OpenCV ICPOdometry;rgbd_icp|OpenCV RgbdICPOdometry;rgbd_icp --keyframes|OpenCV RgbdICPOdometry (keyframes)" \
      "--vo|ORB-SLAM2 --vo"
  done
done

{
  echo "# Structured scenes without texture (scripts/benchmark_scenes.sh)"
  echo
  echo "Commit $(git -C "$here" rev-parse --short HEAD 2>/dev/null || echo unknown), $(date -u +%Y-%m-%d), $(nproc) cores;"
  echo "$frames frames per scene (pplvo-synth, seed 3, 640x480). ATE m after SE(3) alignment, RPE over 1 s"
  echo "(pplvo-eval); tracked: frames pplvo tracked (neither velocity model nor lost); NEES of"
  echo "pplvo's relative-pose covariance (mean, share inside the 95 % bound; 6 is ideal)."
  echo
  echo "| sequence | system | ATE m | RPE m/s | RPE deg/s | frames posed | tracked | NEES / inside 95 % |"
  echo "|---|---|---|---|---|---|---|---|"
  printf '%s\n' "${rows[@]}"
} > "$markdown"
echo "benchmark_scenes.sh: table written to $markdown" >&2
