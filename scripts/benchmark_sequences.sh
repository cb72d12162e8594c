# Sourced by scripts/benchmark.sh, benchmark_launch.sh, benchmark_long.sh and
# benchmark_scenes.sh: their tool check, the benchmark's sequences and the evaluation cells.
#   benchmark_sequences BIN SYNTH_DIR SYNTH_FRAMES SHARED_DIR
# fills the arrays names, dirs and fpss: the synthetic room (generated into SYNTH_DIR by
# pplvo-synth, seed 1, when missing) and every folder of SHARED_DIR with a groundtruth.txt; fps
# is 30 for ICL-NUIM-style integer stamps (frame indices), 0 for real stamps.
# benchmark_require_tools SCRIPT BIN TOOL...: exits 1 naming the first TOOL missing from BIN.
benchmark_require_tools() {
  local script=$1 bin=$2 tool
  shift 2
  for tool in "$@"; do
    [ -x "$bin/$tool" ] || { echo "$script: $bin/$tool missing (build first: cmake --build build)" >&2; exit 1; }
  done
}

benchmark_sequences() {
  local bin=$1 synth=$2 synth_frames=$3 shared=$4 d fps
  names=(); dirs=(); fpss=()
  if [ ! -f "$synth/groundtruth.txt" ]; then
    mkdir -p "$(dirname "$synth")"
    "$bin/pplvo-synth" --output "$synth" --frames "$synth_frames" --seed 1 > /dev/null
  fi
  names+=(synth_room); dirs+=("$synth"); fpss+=(0)
  for d in "$shared"/*/; do
    [ -f "$d/groundtruth.txt" ] || continue
    fps=0
    # Integer stamps in the first data line of groundtruth.txt: frame indices at 30 Hz.
    if awk '!/^#/ && NF { exit !($1 ~ /^[0-9]+$/) }' "$d/groundtruth.txt"; then fps=30; fi
    names+=("$(basename "$d")"); dirs+=("${d%/}"); fpss+=("$fps")
  done
}

# benchmark_probe: seconds two fixed CPU loads take when run at once, one per core (md5sum of
# 400 MB of zeros each; about 1.1 s on this machine when both cores are free). The machine is
# shared: other tenants slow one or both cores by up to 2-3x for seconds to minutes, and a
# single-thread probe does not see a busy second core. Printed next to the figures it explains.
benchmark_probe() {
  local start end
  start=$(date +%s.%N)
  head -c 400M /dev/zero | md5sum > /dev/null &
  head -c 400M /dev/zero | md5sum > /dev/null
  wait
  end=$(date +%s.%N)
  awk -v a="$start" -v b="$end" 'BEGIN { printf "%.2f\n", b - a }'
}

# The evaluation cells of benchmark_long.sh and benchmark_scenes.sh (they use $bin):
#   eval_line GT EST FPS -> "ate rpe_t rpe_r pairs" (pplvo-eval; "- - - 0" without pairs)
#   nees_cell GT COV FPS EXACT -> "mean share" (EXACT 1: rendered ground truth)
#   median_by_ate LINE... -> the line with the median ATE (failed runs, 9e9, last)
eval_line() {  # eval_line GT EST FPS -> "ate rpe_t rpe_r pairs"
  local fpsarg=()
  [ "$3" != 0 ] && fpsarg=(--fps "$3")
  "$bin/pplvo-eval" "$1" "$2" "${fpsarg[@]}" 2>/dev/null | awk '
    /^ate.rmse_m /{a=$2} /^rpe.trans_rmse_m_per_s /{t=$2} /^rpe.rot_rmse_deg_per_s /{r=$2} /^ate.pairs /{p=$2}
    END{ if (p == "") print "- - - 0"; else printf "%.4f %.4f %.3f %d\n", a, t, r, p }'
}
nees_cell() {  # nees_cell GT COV FPS EXACT -> "mean share"
  local fpsarg=() exact=(--gt-offset-ms auto)
  [ "$3" != 0 ] && fpsarg=(--fps "$3")
  [ "$4" = 1 ] && exact=(--exact-gt)
  "$bin/pplvo-eval" --nees "$1" "$2" "${fpsarg[@]}" "${exact[@]}" 2>/dev/null |
    awk '/^nees.mean /{m=$2} /^nees.share_inside_95 /{s=$2} END{ if (m == "") print "- -"; else printf "%.2f %.2f\n", m, s }'
}
median_by_ate() {  # median_by_ate LINE... -> the line with the median ATE (failed runs last)
  printf '%s\n' "$@" | sort -t' ' -k1,1g | awk '{ l[NR] = $0 } END { print l[int((NR + 1) / 2)] }'
}

