#!/usr/bin/env bash
# pplvo fused with a wheel odometry, end to end (examples/fusion/README.md):
#  1. pplvo-synth --motion robot: a wheeled robot's camera (0.5 m high, 0.1 m ahead of the
#     robot's origin, pitched 6 deg down) driving figures of eight; --effects adds a hand-held
#     Kinect v1's lens, rolling shutter, blur and colour/depth offsets;
#  2. pplvo-run with that mounting (odometry.body) records PPLVO_ODOMETRY;
#  3. simulate_wheel_odometry: a differential drive's odometry of the same intervals from the
#     ground truth (speed scale error and slip, yaw-rate bias, noise);
#  4. fuse_odometry: pplvo alone, wheels alone, both (wheel errors estimated), both without
#     the wheel-error states, and both with pplvo's covariance replaced by a constant of the
#     same median size; pplvo-eval of each against base_link's ground truth; NEES of each.
# Prints a markdown table. usage: run_fusion_demo.sh OUTDIR [--frames N] [--effects] [--seed S]
# Programs from $PPLVO_BIN_DIR (default build/bin).
set -euo pipefail
cd "$(dirname "$0")/../.."
OUT=${1:?usage: run_fusion_demo.sh OUTDIR [--frames N] [--effects] [--seed S]}
shift
FRAMES=900 SEED=5 EFFECTS=()
while [[ $# -gt 0 ]]; do
  case $1 in
    --frames) FRAMES=$2; shift 2 ;;
    --seed) SEED=$2; shift 2 ;;
    --effects) EFFECTS=(--distortion fr1 --rolling-shutter-ms 25 --exposure-ms 8
                        --depth-offset-ms "-15,-13,16,-16,-12"); shift ;;
    *) echo "unknown argument $1" >&2; exit 2 ;;
  esac
done
B=${PPLVO_BIN_DIR:-build/bin}
mkdir -p "$OUT"
MOUNT=0.1,0,0.5,0,6,0  # GroundRobotMotion::T_base_camera
if [[ ! -f $OUT/sequence/groundtruth.txt ]]; then
  "$B/pplvo-synth" --output "$OUT/sequence" --frames "$FRAMES" --seed "$SEED" --motion robot \
    "${EFFECTS[@]}" > "$OUT/synth.log"
fi
"$B/pplvo-run" --dataset "$OUT/sequence" --output "$OUT/camera_trajectory.txt" --quiet \
  --set odometry.body.x_m=0.1 --set odometry.body.z_m=0.5 --set odometry.body.pitch_deg=6 \
  --log "$OUT/pplvo.lcmlog" --log-channels 'PPLVO_(POSE|ODOMETRY)' > "$OUT/run.log"
"$B/simulate_wheel_odometry" --run-log "$OUT/pplvo.lcmlog" --groundtruth "$OUT/sequence/groundtruth.txt" \
  --mount "$MOUNT" --seed "$SEED" --output "$OUT/odometry.lcmlog" \
  --groundtruth-base "$OUT/groundtruth_base.txt" > "$OUT/wheels.log"

sigma=$("$B/fuse_odometry" --log "$OUT/odometry.lcmlog" --use pplvo --output /dev/null |
  awk '/^pplvo_twist_sigma_median:/ { printf "%s,%s", $2, $4 }')
echo "| input | ATE mm | RPE mm/s | RPE deg/s | NEES (mean) | share inside 95 % |"
echo "|---|---|---|---|---|---|"
row() {  # name, fuse_odometry options...
  local name=$1
  shift
  "$B/fuse_odometry" --log "$OUT/odometry.lcmlog" --output "$OUT/$name.txt" \
    --groundtruth-base "$OUT/groundtruth_base.txt" "$@" > "$OUT/$name.fuse.txt"
  "$B/pplvo-eval" "$OUT/groundtruth_base.txt" "$OUT/$name.txt" > "$OUT/$name.eval.txt"
  awk -v name="$name" '
    /^ate.rmse_m/ { ate = $2 * 1000 } /^rpe.trans_rmse_m_per_s/ { rt = $2 * 1000 }
    /^rpe.rot_rmse_deg_per_s/ { rr = $2 } /^nees_mean:/ { nees = $2 }
    /^nees_share_inside_95:/ { share = $2 }
    END { printf "| %s | %.2f | %.2f | %.3f | %.2f | %.2f |\n", name, ate, rt, rr, nees, share }' \
    "$OUT/$name.eval.txt" "$OUT/$name.fuse.txt"
}
row pplvo --use pplvo
row wheels --use wheel --no-wheel-errors  # as their node reports them
row fused --use both
row fused_without_wheel_error_states --use both --no-wheel-errors
row fused_constant_pplvo_covariance --use both --pplvo-constant-sigma "$sigma"
grep -E '^wheel_' "$OUT/fused.fuse.txt" | sed 's/^/# estimated /'
echo "# pplvo's median twist sigma (m/s, rad/s), the constant: $sigma"
