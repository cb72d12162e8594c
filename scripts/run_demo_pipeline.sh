#!/usr/bin/env bash
# Runs the pipeline as separate processes on a TUM-layout folder with groundtruth.txt and prints
# ATE and RPE: pplvo-launch --isolated --lockstep (player, depth filter, frontend, estimator and
# logger in a private network namespace, nothing on the host network), then pplvo-eval.
# Usage: scripts/run_demo_pipeline.sh DATASET_DIR OUTDIR [extra pplvo-launch args...]
# Writes OUTDIR/trajectory.txt, OUTDIR/launch_report.txt, OUTDIR/eval.txt. Where the kernel
# refuses private namespaces (pplvo-launch exit 4) it says so and runs pplvo-run (one process,
# memq://) instead; it never uses the host network.
# Programs are taken from $PPLVO_BIN_DIR (default: build/bin of this repository).
set -euo pipefail
if [ $# -lt 2 ]; then
  echo "usage: $0 DATASET_DIR OUTDIR [extra pplvo-launch args...]" >&2
  exit 2
fi
dataset=$1
outdir=$2
shift 2
root=$(cd "$(dirname "$0")/.." && pwd)
bin=${PPLVO_BIN_DIR:-$root/build/bin}
for p in pplvo-launch pplvo-eval; do
  [ -x "$bin/$p" ] || { echo "$0: $bin/$p is missing: build it (cmake --build build --target $p)" >&2; exit 1; }
done
[ -f "$dataset/groundtruth.txt" ] || { echo "$0: $dataset/groundtruth.txt is missing" >&2; exit 1; }
mkdir -p "$outdir"

# Integer frame stamps (ICL-NUIM) are frame indices: 30 Hz for both the player and the evaluator.
index=$dataset/associations.txt
[ -f "$index" ] || index=$dataset/rgb.txt
fps=()
if awk '!/^#/ && NF >= 2 { if ($1 !~ /^[0-9]+$/) bad = 1; n++ } END { exit (n > 0 && !bad) ? 0 : 1 }' "$index"; then
  fps=(--fps 30)
fi

traj=$outdir/trajectory.txt
rm -f "$traj"
echo "== pplvo-launch --isolated --lockstep on $dataset" >&2
set +e
"$bin/pplvo-launch" --isolated --lockstep --dataset "$dataset" --output "$traj" ${fps[@]+"${fps[@]}"} "$@" \
  | tee "$outdir/launch_report.txt"
rc=${PIPESTATUS[0]}
set -e
if [ "$rc" -eq 4 ]; then
  # No private network namespace on this machine (unprivileged user namespaces disabled): never
  # fall back to the host network; run the same nodes in one process over memq:// instead.
  echo "note: private network namespaces are unavailable here (see above), so the pipeline runs" \
       "in one process (pplvo-run, memq://) instead of separate processes" >&2
  [ -x "$bin/pplvo-run" ] || { echo "$0: $bin/pplvo-run is missing" >&2; exit 1; }
  "$bin/pplvo-run" --dataset "$dataset" --output "$traj" ${fps[@]+"${fps[@]}"} \
    | tee "$outdir/launch_report.txt"
elif [ "$rc" -ne 0 ]; then
  exit "$rc"
fi
# RPE uses the TUM benchmark's fixed 1 s delta; a sequence shorter than 2 s gets a third of its
# length instead (said on stderr), so that short test sequences still give an RPE figure.
div=1
[ ${#fps[@]} -gt 0 ] && div=30
span=$(awk -v d="$div" '!/^#/ && NF >= 8 { if (n == 0) a = $1; b = $1; n++ } END { printf "%.6f", n ? (b - a) / d : 0 }' "$traj")
delta=()
if awk -v s="$span" 'BEGIN { exit (s > 0 && s < 2) ? 0 : 1 }'; then
  delta=(--delta "$(awk -v s="$span" 'BEGIN { printf "%.3f", s / 3 }')")
  echo "note: the estimate spans only ${span} s: RPE with ${delta[*]} instead of 1 s" >&2
fi
echo "== pplvo-eval $dataset/groundtruth.txt $traj ${fps[*]+${fps[*]}} ${delta[*]+${delta[*]}}" >&2
"$bin/pplvo-eval" "$dataset/groundtruth.txt" "$traj" ${fps[@]+"${fps[@]}"} ${delta[@]+"${delta[@]}"} \
  | tee "$outdir/eval.txt"
