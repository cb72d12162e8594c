#!/usr/bin/env bash
# Fits the per-frame shared error of a camera (odometry.tracker.frame_error_sigma_t_m and
# frame_error_sigma_rot_deg; docs/estimator.md, "The per-frame shared error") on sequences with
# ground truth: runs pplvo-run on each with the error set to 0 and asks
# `pplvo-eval --fit-frame-error` for the per-axis std that brings the mean translation and
# rotation NEES of all frame pairs, pooled, to 3 each. The ground truth's clock offset is
# estimated per sequence (--gt-offset-ms auto) and its white noise from its samples.
#
#   scripts/fit_frame_error.sh DATASET [DATASET ...]        # TUM layout, groundtruth.txt
#   PPLVO_BUILD=build PPLVO_RUN_ARGS="--set odometry.reference=frame" scripts/fit_frame_error.sh ...
#
# Prints the pooled fit, each sequence's own fit (how much the figure depends on the
# sequence) and each sequence's NEES with the pooled fit. Fit on several sequences of the
# same camera; rendered sequences (exact poses) need none.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${PPLVO_BUILD:-$root/build}
[ $# -ge 1 ] || { sed -n 2,16p "$0"; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
pairs=()
i=0
for ds in "$@"; do
  [ -f "$ds/groundtruth.txt" ] || { echo "fit_frame_error: $ds has no groundtruth.txt" >&2; exit 2; }
  i=$((i + 1))
  cov="$work/$i-$(basename "$ds").cov"
  # shellcheck disable=SC2086
  "$build/bin/pplvo-run" --dataset "$ds" --output "$work/$i.txt" --covariance "$cov" --quiet \
    --no-progress --set odometry.tracker.frame_error_online=false \
    --set odometry.tracker.frame_error_sigma_t_m=0 \
    --set odometry.tracker.frame_error_sigma_rot_deg=0 ${PPLVO_RUN_ARGS:-} >/dev/null
  pairs+=("$ds/groundtruth.txt" "$cov")
done
"$build/bin/pplvo-eval" --fit-frame-error "${pairs[@]}" --gt-offset-ms auto
