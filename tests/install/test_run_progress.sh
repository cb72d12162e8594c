#!/usr/bin/env bash
# ctest run_progress_line (issue 22): pplvo-run's progress line (frames done, frames/s, ETA) is
# on stderr when stderr is a terminal (a pseudo-terminal from script(1)) or with --progress,
# and not when stderr is a file, with --no-progress, or with --quiet.
# Usage: test_run_progress.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
build=$(cd "$2" && pwd)
tmp=$(mktemp -d /tmp/pplvo_progress_test_XXXXXX)
trap 'rm -rf "$tmp"' EXIT
fail() {
  echo "FAIL: $*" >&2
  exit 1
}
command -v script > /dev/null || fail "script(1) (bsdutils) is not installed"
export LCM_DEFAULT_URL=memq://
"$build/bin/pplvo-synth" --output "$tmp/seq" --frames 12 --seed 4 --width 320 --height 240 \
  > /dev/null
run=("$build/bin/pplvo-run" --dataset "$tmp/seq" --output "$tmp/traj.txt")
line='\[pplvo-player\] [0-9]+/12 frames, [0-9.]+ frames/s, ETA [0-9-]+:[0-9-]+, skipped 0'

"${run[@]}" > /dev/null 2> "$tmp/file.err"
if grep -Eq "$line" "$tmp/file.err"; then fail "progress line on a non-terminal stderr"; fi
"${run[@]}" --progress > /dev/null 2> "$tmp/forced.err"
grep -Eq "$line" "$tmp/forced.err" || fail "--progress: no progress line"
grep -Eq '12/12 frames' "$tmp/forced.err" || fail "--progress: the last line is not 12/12"

# On a terminal: script(1) runs the command on a pseudo-terminal and copies what it writes.
script -qec "${run[*]}" /dev/null > "$tmp/tty.out" < /dev/null
grep -Eq "$line" "$tmp/tty.out" || fail "no progress line on a terminal"
script -qec "${run[*]} --no-progress" /dev/null > "$tmp/tty_off.out" < /dev/null
if grep -Eq "$line" "$tmp/tty_off.out"; then fail "--no-progress on a terminal"; fi
script -qec "${run[*]} --quiet" /dev/null > "$tmp/tty_quiet.out" < /dev/null
if grep -Eq "$line" "$tmp/tty_quiet.out"; then fail "--quiet on a terminal"; fi
echo "PASS"
