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


# The peers on one sequence, one table row each through the caller's row() (columns: name,
# label, ATE, RPE m/s, RPE deg/s, posed / total, two empty cells), as benchmark_long.sh and
# benchmark_scenes.sh print them:
#   peer_rows NAME DIR FPS RUNS_DIR PEERS_DIR ORB_RUNS OPENCV ORB
# OPENCV: ';'-separated "pplvo-peer-odometry --method arguments|label"; ORB: ';'-separated
# "flag|label" (run_orbslam2.sh's flag: --vo, or empty for the full system), each run ORB_RUNS
# times (it is multi-threaded) and shown by its median ATE. A peer that is not built in
# PEERS_DIR (../shared/peers/build.sh) is a row saying so, one that writes no trajectory
# "crashed or never initialised", one that poses under half the frames "lost".
peer_rows() {
  local n=$1 d=$2 fps=$3 runs_dir=$4 peers=$5 orb_runs=$6 opencv=$7 orb=$8
  local total entry args label flag est k a t r p results=() entries=() fpsarg=()
  [ "$fps" != 0 ] && fpsarg=(--fps "$fps")
  total=$(awk '!/^#/ && NF' "$d/rgb.txt" | wc -l)
  IFS=';' read -r -a entries <<< "$opencv"
  for entry in "${entries[@]}"; do
    args=${entry%%|*}; label=${entry#*|}
    est="$runs_dir/$n.opencv_$(echo "$args" | tr -c 'a-z_' _).txt"
    # shellcheck disable=SC2086  # the method and its options
    "$bin/pplvo-peer-odometry" --dataset "$d" --output "$est" --method $args > "$est.log" 2>&1 || true
    peer_row "$n" "$d" "$fps" "$total" "$label" "$est"
  done
  if [ -x "$peers/run_fovis.sh" ]; then
    est="$runs_dir/$n.fovis.txt"
    "$peers/run_fovis.sh" "$d" "$est" > "$est.log" 2>&1 || rm -f "$est"
    peer_row "$n" "$d" "$fps" "$total" "fovis" "$est"
  else
    row "| $n | fovis | not built ($peers; ../shared/peers/build.sh) | | | | | |"
  fi
  if [ ! -x "$peers/run_orbslam2.sh" ]; then
    row "| $n | ORB-SLAM2 | not built ($peers; ../shared/peers/build.sh) | | | | | |"
    return
  fi
  IFS=';' read -r -a entries <<< "$orb"
  for entry in "${entries[@]}"; do
    flag=${entry%%|*}; label=${entry#*|}
    results=()
    for k in $(seq 1 "$orb_runs"); do
      est="$runs_dir/$n.orbslam2${flag//-/_}.$k.txt"
      # shellcheck disable=SC2086  # no flag: the full system
      "$peers/run_orbslam2.sh" "$d" "$est" "${fpsarg[@]}" $flag > "$est.log" 2>&1 || true
      if [ -s "$est" ]; then
        read -r a t r p < <(eval_line "$d/groundtruth.txt" "$est" "$fps")
        results+=("$a $t $r $p $est")
      else
        results+=("9e9 - - 0 $est")
      fi
    done
    read -r a t r p est < <(median_by_ate "${results[@]}")
    [ "$a" = 9e9 ] && est=/nonexistent
    peer_row "$n" "$d" "$fps" "$total" "$label" "$est" " (median of $orb_runs)"
  done
}
# peer_row NAME DIR FPS TOTAL LABEL TRAJECTORY [RUNS]: one peer's row (peer_rows).
peer_row() {
  local n=$1 d=$2 fps=$3 total=$4 label=$5 est=$6 runs=${7:-} a t r p
  if [ ! -s "$est" ]; then
    row "| $n | $label | crashed or never initialised$runs | | | 0 / $total | | |"; return
  fi
  read -r a t r p < <(eval_line "$d/groundtruth.txt" "$est" "$fps")
  if [ "$p" -lt $((total / 2)) ]; then
    row "| $n | $label | lost: $p of $total frames posed$runs | | | $p / $total | | |"; return
  fi
  row "| $n | $label$runs | $a | $t | $r | $p / $total | | |"
}
