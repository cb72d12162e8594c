#!/usr/bin/env bash
# ctest python_log_to_tum (issue 22): the Python message package generated at build time
# (build/python/pplvo_msgs) and examples/python/pplvo_log_to_tum.py read the LCM log of
# pplvo-run in pure Python (no LCM module); the trajectory must be pplvo-run's own (--output),
# and --list-channels must count every pose.
# Usage: test_python.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
src=$(cd "$1" && pwd)
build=$(cd "$2" && pwd)
tmp=$(mktemp -d /tmp/pplvo_python_test_XXXXXX)
trap 'rm -rf "$tmp"' EXIT
fail() {
  echo "FAIL: $*" >&2
  exit 1
}
[[ -f $build/python/pplvo_msgs/pose_t.py ]] || fail "no generated Python package in $build/python"
if python3 -c 'import lcm' 2> /dev/null; then
  echo "note: a Python lcm module is installed; the example does not use it"
fi

export LCM_DEFAULT_URL=memq://
"$build/bin/pplvo-synth" --output "$tmp/seq" --frames 40 --seed 11 --scene lines > /dev/null
"$build/bin/pplvo-run" --dataset "$tmp/seq" --log "$tmp/run.lcm" --output "$tmp/run.txt" \
  --quiet 2> "$tmp/run.err" || { cat "$tmp/run.err" >&2; fail "pplvo-run"; }
poses=$(grep -vc '^#' "$tmp/run.txt")

export PYTHONPATH=$build/python
script=$src/examples/python/pplvo_log_to_tum.py
python3 "$script" "$tmp/run.lcm" --output "$tmp/py.txt" --covariance "$tmp/py_cov.txt"
python3 "$src/tests/install/compare_tum.py" "$tmp/run.txt" "$tmp/py.txt" --min-poses 35
[[ $(grep -vc '^#' "$tmp/py_cov.txt") -eq $poses ]] || fail "covariance lines != poses"
[[ $(awk '!/^#/ { print NF }' "$tmp/py_cov.txt" | sort -u) == 37 ]] ||
  fail "covariance lines must have a stamp and 36 values"

python3 "$script" "$tmp/run.lcm" --list-channels > "$tmp/channels.txt"
cat "$tmp/channels.txt"
grep -qx "PPLVO_POSE $poses pose_t" "$tmp/channels.txt" || fail "--list-channels: PPLVO_POSE"
grep -q "^PPLVO_FEATURES_3D [0-9]* features_t$" "$tmp/channels.txt" ||
  fail "--list-channels: PPLVO_FEATURES_3D"

# A log cut in the middle of its last pose event (a recorder killed mid-write) is read up to
# the cut: one pose fewer.
last_pose=$(python3 - "$tmp/run.lcm" << 'EOF'
import struct, sys
data = open(sys.argv[1], "rb").read()
offset, last = 0, -1
while offset + 28 <= len(data):
    _, _, _, channel_len, data_len = struct.unpack(">IqqII", data[offset:offset + 28])
    if data[offset + 28:offset + 28 + channel_len] == b"PPLVO_POSE":
        last = offset
    offset += 28 + channel_len + data_len
print(last)
EOF
)
[[ $last_pose -gt 0 ]] || fail "no pose event found in the log"
head -c $((last_pose + 60)) "$tmp/run.lcm" > "$tmp/cut.lcm"
python3 "$script" "$tmp/cut.lcm" --output "$tmp/cut.txt"
cut_poses=$(grep -vc '^#' "$tmp/cut.txt")
[[ $cut_poses -eq $((poses - 1)) ]] || fail "cut log: $cut_poses poses, not $((poses - 1))"
echo "PASS: $poses poses"
