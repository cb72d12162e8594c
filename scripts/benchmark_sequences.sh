# Sourced by scripts/benchmark.sh and scripts/benchmark_launch.sh: their tool check and the
# benchmark's sequences.
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
