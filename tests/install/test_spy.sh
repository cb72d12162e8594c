#!/usr/bin/env bash
# ctest pplvo_spy (issue 22): scripts/pplvo-spy starts LCM's lcm.spy.Spy on this Debian's JDK
# (no -Xincgc, jchart2d from libjchart2d-java) with pplvo's types, under Xvfb, and its window
# lists every channel of a replayed pplvo log with its pplvo_msgs type.
#  - pplvo-run --log records a short synthetic run (160x120, 20 frames);
#  - the channels of the log and their types are read with the Python package (--list-channels);
#  - inside a private network namespace (scripts/isolated.sh: loopback only, multicast routed to
#    it, ttl=0: nothing reaches the host's network) and a private X server (xvfb-run),
#    pplvo-spy starts with a Java agent (SpyChannels.java) that reads the rows of Spy's channel
#    table; once the window is up, lcm-logplayer replays the log onto the namespace's udpm://;
#  - the test passes when Spy's table shows every channel of the log with its type.
# Usage: test_spy.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
src=$(cd "$1" && pwd)
build=$(cd "$2" && pwd)
tmp=$(mktemp -d /tmp/pplvo_spy_test_XXXXXX)
trap 'rm -rf "$tmp"' EXIT
fail() {
  echo "FAIL: $*" >&2
  exit 1
}
for tool in java javac jar xvfb-run lcm-logplayer unshare ip; do
  command -v $tool > /dev/null || fail "$tool is not installed (scripts/install_deps.sh)"
done
[[ -f $build/lib/pplvo_msgs.jar ]] || fail "no $build/lib/pplvo_msgs.jar"

# The agent jar.
mkdir -p "$tmp/classes"
javac -nowarn -d "$tmp/classes" "$src/tests/install/SpyChannels.java"
printf 'Premain-Class: SpyChannels\n' > "$tmp/manifest"
jar cfm "$tmp/spy_channels.jar" "$tmp/manifest" -C "$tmp/classes" .

# A pplvo log and the channels it holds.
# 160x120: each message fits the JVM's default socket receive buffer (Spy sets none), so none is
# lost in fragments on the namespace's loopback.
LCM_DEFAULT_URL=memq:// "$build/bin/pplvo-synth" --output "$tmp/seq" --frames 20 --seed 2 \
  --width 160 --height 120 > /dev/null
LCM_DEFAULT_URL=memq:// "$build/bin/pplvo-run" --dataset "$tmp/seq" --log "$tmp/run.lcm" \
  --quiet 2> "$tmp/run.err" || { cat "$tmp/run.err" >&2; fail "pplvo-run"; }
PYTHONPATH=$build/python python3 "$src/examples/python/pplvo_log_to_tum.py" "$tmp/run.lcm" \
  --list-channels > "$tmp/channels.txt"
expected=$(awk '{ printf "%s%s=%s", (NR > 1 ? "," : ""), $1, $3 }' "$tmp/channels.txt")
[[ $expected == *PPLVO_POSE=pose_t* ]] || fail "no PPLVO_POSE in the log: $expected"
echo "log channels: $expected"

cat > "$tmp/inside.sh" << 'EOF'
# Runs in the private network namespace and X server.
set -u
tmp=$1
pplvo_spy=$2
"$pplvo_spy" > "$tmp/spy.out" 2> "$tmp/spy.err" &
spy=$!
for _ in $(seq 1 120); do
  grep -q SPY_READY "$tmp/spy.out" && break
  kill -0 $spy 2> /dev/null || break
  sleep 0.5
done
if grep -q SPY_READY "$tmp/spy.out"; then
  # Replayed until Spy has seen every channel (the agent then ends Spy) or 5 times.
  for _ in 1 2 3 4 5; do
    kill -0 $spy 2> /dev/null || break
    lcm-logplayer -s 1 "$tmp/run.lcm" > /dev/null
  done
fi
wait $spy
EOF
export JAVA_TOOL_OPTIONS="-javaagent:$tmp/spy_channels.jar=60;$expected"
export PPLVO_MSGS_JAR=$build/lib/pplvo_msgs.jar
export LCM_DEFAULT_URL_ISOLATED='udpm://239.255.76.67:7667?ttl=0'
rc=0
timeout 180 "$src/scripts/isolated.sh" xvfb-run -a -s "-screen 0 1280x800x24" \
  bash "$tmp/inside.sh" "$tmp" "$src/scripts/pplvo-spy" || rc=$?
cat "$tmp/spy.out"
grep -v '^Picked up JAVA_TOOL_OPTIONS' "$tmp/spy.err" || true
if grep -q 'Xincgc' "$tmp/spy.err"; then fail "the JVM refused -Xincgc"; fi
[[ $rc -eq 0 ]] || fail "pplvo-spy did not list every channel (exit $rc)"
n_types=$(find "$src/lcmtypes" -maxdepth 1 -name '*.lcm' | wc -l)
grep -q "^Found $n_types LCM types" "$tmp/spy.out" || fail "Spy did not find pplvo's $n_types types"
while read -r channel _ type; do
  grep -qx "CHANNEL $channel $type [0-9]*" "$tmp/spy.out" || fail "Spy does not list $channel"
done < "$tmp/channels.txt"
echo "PASS: Spy lists $(wc -l < "$tmp/channels.txt") channels"
