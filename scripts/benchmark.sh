#!/usr/bin/env bash
# Accuracy and speed benchmark of the pipeline (issue 6), in the shape of the paper's tables:
# RPE (m/s, deg/s) and ATE (m) for points / points+lines / points+planes / all, for the sensor
# model / C-GM / O-GM depth, per-stage ms/frame, end-to-end frames/s of pplvo-run, and OpenCV's
# cv::rgbd odometries (Rgbd, RgbdICP, ICP; each frame to frame and against keyframes, issue 17)
# measured in the same run on the same frames (pplvo-peer-odometry, docs/peer_odometry.md).
#
#   scripts/benchmark.sh [--build DIR] [--out DIR] [--docs FILE] [--frames N] [--quick]
#                        [--speed-pairs N]
#
# Sequences: every folder of ../shared/data (or $PPLVO_SHARED_DATA) with a groundtruth.txt, plus
# a synthetic one generated here (pplvo-synth, room scene, 150 frames, seed 1).
# --docs FILE writes the tables as Markdown (with the machine and the commit) to FILE and the
# trajectory plots next to it (images/benchmark_<sequence>.png). --quick: two pplvo configurations
# and three peers (Rgbd frame to frame, Rgbd and RgbdICP with keyframes). --speed-pairs N: pairs
# per sequence of the speed-to-peer measurement (scripts/benchmark_speed.sh; default 3, 0 skips).
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build="$here/build"
out=""
docs=""
synth_frames=150
quick=0
speed_pairs=3
while [ $# -gt 0 ]; do
  case "$1" in
    --build) build="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --docs) docs="$2"; shift 2 ;;
    --frames) synth_frames="$2"; shift 2 ;;
    --quick) quick=1; shift ;;
    --speed-pairs) speed_pairs="$2"; shift 2 ;;
    -h|--help) sed -n 2,17p "$0"; exit 0 ;;
    *) echo "benchmark.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
bin="$build/bin"
# shellcheck source=benchmark_sequences.sh
. "$here/scripts/benchmark_sequences.sh"
benchmark_require_tools benchmark.sh "$bin" pplvo-run pplvo-eval pplvo-synth pplvo-peer-odometry pplvo-plot
shared="${PPLVO_SHARED_DATA:-$here/../shared/data}"
out="${out:-$build/benchmark}"
mkdir -p "$out"

# Sequences: name -> folder; ICL-NUIM stamps are frame indices (30 Hz).
declare -a names dirs fpss
benchmark_sequences "$bin" "$out/synth_room" "$synth_frames" "$shared"

# Configurations: label | pplvo-run arguments (the peer rows are handled separately).
configs=(
  "points|--features points"
  "points+lines|--features points,lines"
  "points+planes|--features points,planes"
  "all|--features points,lines,planes"
  "all, sensor model|--depth-model sensor"
  "all, C-GM|--depth-model cgm"
  "all, alpha=1|--set odometry.tracker.estimator.plane_scale_alpha=1"
  "all, frame to frame (paper)|--set odometry.reference=frame"
  "all, keyframe without landmark fusion|--set odometry.keyframe.fuse_landmarks=false"
)
[ "$quick" = 1 ] && configs=("points|--features points" "all|--features points,lines,planes")

# Peers: label | pplvo-peer-odometry arguments | label in the plot (empty: not plotted; the
# plot's legend is one row, room for two short peer labels at 1600 px). Keyframe mode: a new keyframe beyond 10 cm or
# 10 deg from it, or when only the previous frame tracks (DVO, Fovis).
peers=(
  "OpenCV RgbdOdometry|--method rgbd|Rgbd"
  "OpenCV RgbdICPOdometry|--method rgbd_icp|"
  "OpenCV ICPOdometry|--method icp|"
  "OpenCV RgbdOdometry (keyframes)|--method rgbd --keyframes|"
  "OpenCV RgbdICPOdometry (keyframes)|--method rgbd_icp --keyframes|RgbdICP kf"
  "OpenCV ICPOdometry (keyframes)|--method icp --keyframes|"
)
[ "$quick" = 1 ] && peers=("${peers[0]}" "${peers[3]}" "${peers[4]}")

eval_line() {  # eval_line GT EST FPS -> "rpe_t rpe_r ate pairs trans_scale"
  local fpsarg=()
  [ "$3" != 0 ] && fpsarg=(--fps "$3")
  "$bin/pplvo-eval" "$1" "$2" "${fpsarg[@]}" | awk '
    /^ate.rmse_m /{a=$2} /^rpe.trans_rmse_m_per_s /{t=$2} /^rpe.rot_rmse_deg_per_s /{r=$2}
    /^ate.pairs /{p=$2} /^rpe.trans_scale /{s=$2}
    END{printf "%.4f %.3f %.4f %d %.2f\n", t, r, a, p, s}'
}
# nees_cell GT COV EXACT -> "mean6 (mean_t, mean_r); share inside the 95 % bound" of the relative
# pose covariances (pplvo-eval --nees, issue 18); EXACT=1 takes the ground truth as exact
# (synthetic, ICL-NUIM), else its noise is estimated from its samples and its clock offset from
# the rotation error (docs/evaluation.md).
nees_cell() {
  local exact=(--gt-offset-ms auto)
  [ "$3" = 1 ] && exact=(--exact-gt)
  "$bin/pplvo-eval" --nees "$1" "$2" "${fpsarg[@]}" "${exact[@]}" 2>/dev/null | awk '
    /^nees.mean /{m=$2} /^nees.t_mean /{t=$2} /^nees.r_mean /{r=$2} /^nees.share_inside_95 /{s=$2}
    END{ if (m == "") print "-"; else printf "%.3g (%.3g, %.3g); %.2f\n", m, t, r, s }'
}

yaml_value() { awk -v k="$2:" '$1==k{print $2; exit}' "$1"; }
# median_range X...: "median (min-max)" of the numbers, one decimal (two for values under 10).
median_range() {
  printf '%s\n' "$@" | sort -g | awk '{ v[NR] = $1 } END {
    f = (v[NR] < 10) ? "%.2f" : "%.1f"
    printf f " (" f "-" f ")\n", v[int((NR + 1) / 2)], v[1], v[NR] }'
}

table="$out/table.md"
stages="$out/stages.md"
{
  echo "| sequence | configuration | RPE (m/s) | RPE (deg/s) | ATE (m) | motion scale | tracked | frames/s | NEES 6 (t, r); inside 95 % |"
  echo "|---|---|---|---|---|---|---|---|---|"
} > "$table"
{
  echo "| sequence | depth filter decode+cgm+ogm | points | lines | planes (C-GM + fused) | lift | matching | pose | node I/O | pipeline ms/frame | pplvo-run frames/s, median (range) of 3 | same, frames decoded beforehand | machine probe s |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
} > "$stages"

for i in "${!names[@]}"; do
  n="${names[$i]}"; d="${dirs[$i]}"; fps="${fpss[$i]}"
  fpsarg=()
  [ "$fps" != 0 ] && fpsarg=(--fps "$fps")
  # Rendered sequences (the synthetic room, ICL-NUIM) have exact ground truth (pplvo-eval
  # --exact-gt). Every sequence runs with the same options: the per-frame shared error is
  # estimated online (odometry.tracker.frame_error_online, docs/estimator.md).
  exact=0
  { [ "$n" = synth_room ] || [ "$fps" != 0 ]; } && exact=1
  ests=(); labels=()
  for c in "${configs[@]}"; do
    label="${c%%|*}"; args="${c#*|}"
    tag="$(echo "$label" | tr -c 'a-zA-Z0-9\n' '_')"
    est="$out/$n.$tag.txt"
    [ "$label" = "all" ] && probe="$(benchmark_probe)"
    # shellcheck disable=SC2086
    "$bin/pplvo-run" --dataset "$d" --output "$est" --summary "$out/$n.$tag.yaml" --quiet $args \
      --covariance "$out/$n.$tag.cov" "${fpsarg[@]}" 2>"$out/$n.$tag.log"
    read -r t r a p sc < <(eval_line "$d/groundtruth.txt" "$est" "$fps")
    nees="$(nees_cell "$d/groundtruth.txt" "$out/$n.$tag.cov" "$exact")"
    tracked="$(awk '/^status:/{gsub(/[{},]/," "); for(i=1;i<=NF;i++) if($i=="tracking:") print $(i+1)}' "$out/$n.$tag.yaml")"
    poses="$(yaml_value "$out/$n.$tag.yaml" poses)"
    f="$(yaml_value "$out/$n.$tag.yaml" frames_per_s)"
    speed="$(printf '%.1f' "$f")"
    if [ "$label" = "all" ]; then
      ests+=("$est"); labels+=("pplvo (all)")
      # Throughput varies with the other tenants of this machine: three runs end to end and
      # three with the PNGs decoded before the first frame (as from a camera, and as the peer's
      # figure), each printed as "median (min-max)"; every trajectory must equal the first.
      fs=("$f"); fps_pre=(); probes=("$probe")
      for rep in 1 2 3; do
        if [ "$rep" -gt 1 ]; then
          probes+=("$(benchmark_probe)")
          # shellcheck disable=SC2086
          "$bin/pplvo-run" --dataset "$d" --output "$out/$n.$tag.$rep.txt" --quiet $args \
            --summary "$out/$n.$tag.$rep.yaml" "${fpsarg[@]}" 2>"$out/$n.$tag.$rep.log"
          cmp -s "$est" "$out/$n.$tag.$rep.txt" || echo "benchmark.sh: $n: run $rep changed the trajectory" >&2
          fs+=("$(yaml_value "$out/$n.$tag.$rep.yaml" frames_per_s)")
        fi
        # shellcheck disable=SC2086
        "$bin/pplvo-run" --dataset "$d" --output "$out/$n.$tag.preload.txt" --preload --quiet $args \
          --summary "$out/$n.$tag.preload.yaml" "${fpsarg[@]}" 2>"$out/$n.$tag.preload.log"
        cmp -s "$est" "$out/$n.$tag.preload.txt" || echo "benchmark.sh: $n: --preload changed the trajectory" >&2
        fps_pre+=("$(yaml_value "$out/$n.$tag.preload.yaml" frames_per_s)")
      done
      speed="$(median_range "${fs[@]}")"
      fp="$(median_range "${fps_pre[@]}")"
      probe="$(median_range "${probes[@]}")"
    fi
    printf "| %s | %s | %s | %s | %s | %s | %s/%s | %s | %s |\n" "$n" "$label" "$t" "$r" "$a" "$sc" "$tracked" "$poses" "$speed" "$nees" >> "$table"
    echo "$n / $label: RPE $t m/s $r deg/s, ATE $a m, $speed frames/s" >&2
    if [ "$label" = "all" ]; then
      # Per-stage means from the summary (ms per call; planes run twice per frame).
      awk -v seq="$n" -v fps="$speed" -v fpspre="$fp" -v probe="$probe" '
        /^  pplvo-/{node=$1} /stages_mean_ms:/{s=1; next}
        s && $1 ~ /:$/ && NF==2 {k=node $1; v[k]=$2}
        /^  pplvo-/{s=0}
        END{
          df=v["pplvo-depth-filter:decode:"]+v["pplvo-depth-filter:cgm:"]+v["pplvo-depth-filter:ogm:"];
          io=3*v["pplvo-frontend:decode:"]+2*v["pplvo-frontend:encode:"]+2*v["pplvo-estimator:decode:"]+v["pplvo-estimator:encode:"];
          m=v["pplvo-estimator:match_points:"]+v["pplvo-estimator:match_lines:"]+v["pplvo-estimator:match_planes:"];
          tot=df+v["pplvo-frontend:points:"]+v["pplvo-frontend:lines:"]+2*v["pplvo-frontend:planes:"]+v["pplvo-frontend:lift:"]+m+v["pplvo-estimator:pose:"]+io;
          printf "| %s | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %s | %s | %s |\n", seq, df,
            v["pplvo-frontend:points:"], v["pplvo-frontend:lines:"], 2*v["pplvo-frontend:planes:"],
            v["pplvo-frontend:lift:"], m, v["pplvo-estimator:pose:"], io, tot, fps, fpspre, probe}' "$out/$n.$tag.yaml" >> "$stages"
    elif [ "$label" = "points" ]; then
      ests+=("$est"); labels+=("pplvo (points)")
    fi
  done
  # The peers, on the same frames.
  for pc in "${peers[@]}"; do
    label="${pc%%|*}"; rest="${pc#*|}"; args="${rest%|*}"; plot_label="${rest##*|}"
    # Files: opencv_<method>[_kf] (opencv_rgbd is the frame-to-frame RgbdOdometry, as before).
    tag="opencv_$(echo "$args" | awk '{ m = $2; kf = ""; for (i = 1; i <= NF; i++) if ($i == "--keyframes") kf = "_kf"; print m kf }')"
    peer="$out/$n.$tag.txt"
    # shellcheck disable=SC2086
    "$bin/pplvo-peer-odometry" --dataset "$d" --output "$peer" $args >"$out/$n.$tag.log" 2>&1
    read -r t r a _ sc < <(eval_line "$d/groundtruth.txt" "$peer" "$fps")
    pf="$(grep -Eo '[0-9.]+ frames/s' "$out/$n.$tag.log" | tail -1 | awk '{print $1}')"
    tracked="$(awk '/^frames: /{ print $4 "/" $2 }' "$out/$n.$tag.log")"
    kfs="$(awk '/^keyframes: /{ print $2 }' "$out/$n.$tag.log")"
    if [ -n "$kfs" ]; then tracked="$tracked ($kfs keyframe$([ "$kfs" = 1 ] || echo s))"; fi
    printf "| %s | %s | %s | %s | %s | %s | %s | %s (odometry only) | - |\n" "$n" "$label" "$t" "$r" "$a" "$sc" "${tracked:--}" "${pf:--}" >> "$table"
    echo "$n / $label: RPE $t m/s $r deg/s, ATE $a m${kfs:+, $kfs keyframes}" >&2
    if [ -n "$plot_label" ]; then ests+=("$peer"); labels+=("$plot_label"); fi
  done
  if [ -n "$docs" ]; then
    mkdir -p "$(dirname "$docs")/images"
    "$bin/pplvo-plot" "$d/groundtruth.txt" "${ests[@]}" --labels "$(IFS=,; echo "${labels[*]}")" \
      "${fpsarg[@]}" --title "$n" --size 1600x900 --output "$(dirname "$docs")/images/benchmark_$n.png" >/dev/null 2>&1 || \
      echo "benchmark.sh: plot of $n failed" >&2
  fi
done

# Speed as a ratio to the peer, interleaved pairs of whole processes (issue 21).
speed="$out/speed.md"
rm -f "$speed"
if [ "$speed_pairs" != 0 ]; then
  "$here/scripts/benchmark_speed.sh" --build "$build" --out "$out" --pairs "$speed_pairs" \
    --frames "$synth_frames" --markdown "$speed" > /dev/null
fi

cat "$table"
echo
cat "$stages"
if [ -f "$speed" ]; then echo; cat "$speed"; fi
if [ -n "$docs" ]; then
  commit="$(git -C "$here" rev-parse --short HEAD 2>/dev/null || echo unknown)"
  cpu="$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')"
  mem="$(awk '/MemTotal/ { printf "%.0f GiB", $2 / 1048576 }' /proc/meminfo)"
  {
    echo "# Benchmark"
    echo
    echo "Generated by scripts/benchmark.sh --docs docs/benchmark.md on $(date -u +%Y-%m-%d), commit"
    echo "$commit, on this machine: $(nproc) cores of $cpu, $mem, $(uname -sr)."
    echo "The machine is shared and virtualised: timings vary by up to 2x between runs."
    cat <<'TEXT'

Every pplvo row is one `pplvo-run` (all processes over memq://, every frame, deterministic);
errors by `pplvo-eval` (TUM definitions: ATE RMSE after SE(3) alignment, RPE RMSE over 1 s
pairs, in m/s and deg/s). The peers are OpenCV 4.6's `cv::rgbd` odometries run by
`pplvo-peer-odometry` on the same frames (docs/peer_odometry.md): `RgbdOdometry`
(photometric), `ICPOdometry` (point-to-plane ICP on depth) and `RgbdICPOdometry` (both), each
frame to frame and against keyframes ("keyframes": a frame becomes the keyframe when its motion
from the keyframe passes 10 cm or 10 deg, or when only the previous frame could track it, as
in DVO and Fovis). "tracked" counts frames
whose pose came from an accepted estimate (the first frame is the origin). "motion scale" is
`rpe.trans_scale`: the least-squares scale of the estimated 1 s relative translations against
the ground truth's (1 = unbiased; below 1 = motion under-estimated, see docs/pipeline.md on
ICL-NUIM). "NEES" is the consistency of the published relative-pose covariance
(`pplvo-eval --nees` on `pplvo-run --covariance`, docs/evaluation.md): the mean over frame
pairs of the 6-dof NEES (ideal 6) with the translation and rotation blocks (ideal 3 each), and
the share of pairs inside the chi-square 95 % bound (ideal 0.95); the ground truth is taken as
exact on the synthetic room and ICL-NUIM (every sequence runs with the same options: the
per-frame shared error is estimated online, docs/estimator.md), its noise estimated from
its samples and its clock offset from the rotation error on TUM (`--gt-offset-ms auto`); the
peers publish no covariance. frames/s is end to end: reading and decoding the PNGs (in the player's loader
thread) included; for 'all', the median and range of three runs. The per-stage table's "frames decoded beforehand" is the same run with the
frames decoded before the first is published (`pplvo-run --preload`, as from a camera, which
delivers decoded frames; the peer's figure leaves the reading out too); its trajectory is the
same. "machine probe s", measured just before each of the three 'all' runs, is the time two fixed
loads took at once, one per core (scripts/benchmark_sequences.sh): about 1.1 s when both cores
are free, more when other tenants of this shared machine were using them.

## Accuracy
TEXT
    echo
    cat "$table"
    echo
    echo "## Per-stage time (ms/frame, configuration 'all', O-GM_10)"
    echo
    echo "Wall time of each stage while it runs. The frames are pipelined (the next frame's points,"
    echo "lines and planes are extracted while this one is fused and lifted: docs/pipeline.md), so"
    echo "stages share the two cores and their sum is more than the time per frame."
    echo
    cat "$stages"
    echo
    if [ -f "$speed" ]; then
      cat <<'TEXT'
## Speed against the peer (whole process, interleaved)

scripts/benchmark_speed.sh (issue 21): on each sequence, pairs of whole-process runs one after
the other -- `pplvo-run` in its default configuration (all features, O-GM_10), then
`pplvo-peer-odometry` in its default mode (OpenCV RgbdOdometry, frame to frame) on the same
frames -- each timed from start to exit (start-up, reading and decoding the PNGs included):
wall time, and CPU time (user + system) from the shell's `times`. The ratio is pplvo-run's
time over the peer's in the same pair, so a slow period of this shared machine moves both;
the table gives its median over the pairs with [min, max], and next to it the absolute frames/s
of each (frames processed / wall time; median [min, max]). The issue's target is a wall ratio
of at most 1.0 and at least 30 frames/s on every sequence.

TEXT
      cat "$speed"
      echo
    fi
    echo "## Trajectories"
    echo
    echo "'Rgbd' is OpenCV's RgbdOdometry frame to frame, 'RgbdICP kf' its RgbdICPOdometry against"
    echo "keyframes; the other peers are in the accuracy table only."
    echo
    for n in "${names[@]}"; do echo "![$n](images/benchmark_$n.png)"; echo; done
  } > "$docs"
  echo "wrote $docs" >&2
fi
