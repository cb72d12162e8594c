#!/usr/bin/env bash
# ctest fusion_with_wheel_odometry (issue 40): run_fusion_demo.sh on 300 frames of the robot
# sequence. The fused estimate must beat both inputs (ATE), its covariance must be neither
# overconfident nor useless (mean NEES in [1, 12]), the wheel-error states must matter (fused
# without them is worse), and the yaw-rate bias the simulator put in (0.005 rad/s) must be
# found within 0.003 rad/s. Deterministic: fixed seeds, pplvo-run in one process.
# Usage: test_fusion_demo.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
src=$(cd "$1" && pwd)
build=$(cd "$2" && pwd)
tmp=$(mktemp -d /tmp/pplvo_fusion_test_XXXXXX)
trap 'rm -rf "$tmp"' EXIT
PPLVO_BIN_DIR=$build/bin bash "$src/examples/fusion/run_fusion_demo.sh" "$tmp/out" --frames 300 \
  > "$tmp/table.md"
cat "$tmp/table.md"
col() { awk -F'|' -v r="$1" -v c="$2" '{ gsub(/ /, "", $2) } $2 == r { gsub(/ /, "", $c); print $c }' "$tmp/table.md"; }
python3 - "$(col pplvo 3)" "$(col wheels 3)" "$(col fused 3)" "$(col fused 6)" \
  "$(col fused_without_wheel_error_states 3)" \
  "$(awk '/yaw_rate_bias/ { print $4 }' "$tmp/table.md")" <<'PY'
import sys
pplvo, wheels, fused, nees, without, bias = map(float, sys.argv[1:])
errors = []
if not fused < pplvo: errors.append(f"fused ATE {fused} mm not below pplvo's {pplvo}")
if not fused < wheels: errors.append(f"fused ATE {fused} mm not below the wheels' {wheels}")
if not 1.0 <= nees <= 12.0: errors.append(f"fused NEES {nees} outside [1, 12]")
if not fused < without: errors.append(f"the wheel-error states do not help ({fused} vs {without})")
if abs(bias - 0.005) > 0.003: errors.append(f"yaw-rate bias estimated {bias}, put in 0.005")
if errors:
    sys.exit("FAIL: " + "; ".join(errors))
print("PASS")
PY
