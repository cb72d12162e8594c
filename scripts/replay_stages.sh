#!/usr/bin/env bash
# Records a run of the pipeline to an LCM event log, then replays each stage (depth filter,
# frontend, estimator) from that log and compares its output with the recorded one.
#
#   scripts/replay_stages.sh DATASET_DIR [OUT_DIR] [pplvo-run options, e.g. --max-frames 30]
#   scripts/replay_stages.sh --log LOG [pplvo-replay options, e.g. --depth-model cgm]
#
# With the recording's configuration every stage reproduces its output byte for byte; pass
# another configuration (--set KEY=VALUE, --depth-model ...) to see which outputs change.
# Exit status: 0 if every stage reproduced the recording, 1 otherwise.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
bin="${PPLVO_BIN:-$here/build/bin}"
if [ "${1:-}" = "--log" ]; then
  log="$2"; shift 2
  replay_args=("$@")
else
  [ $# -ge 1 ] || { sed -n 2,10p "$0"; exit 2; }
  dataset="$1"; shift
  out="${1:-$here/build/replay}"; [ $# -ge 1 ] && shift
  mkdir -p "$out"
  log="$out/run.lcmlog"
  rm -f "$log"
  "$bin/pplvo-run" --dataset "$dataset" --log "$log" --output "$out/trajectory.txt" --quiet "$@"
  echo "recorded $log"
  replay_args=()
fi
status=0
for stage in depth-filter frontend estimator; do
  echo "== $stage"
  "$bin/pplvo-replay" --log "$log" --stage "$stage" "${replay_args[@]}" || status=1
done
exit $status
