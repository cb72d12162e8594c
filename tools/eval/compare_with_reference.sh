#!/usr/bin/env bash
# Runs pplvo-eval and the independent numpy implementation on the same pair of files and prints
# both JSON results side by side, for checking a real estimate by hand.
# usage: tools/eval/compare_with_reference.sh GT EST [--fps F] [--max-difference S] [--delta S]
# Environment: BUILD_DIR (default build).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
bin=${BUILD_DIR:-$root/build}/bin/pplvo-eval
if [[ $# -lt 2 ]]; then
  sed -n 2,5p "$0"
  exit 2
fi
[[ -x $bin ]] || { echo "no $bin: build the pplvo-eval target first" >&2; exit 2; }
echo "== pplvo-eval"
"$bin" "$@" --json || true
echo "== tum_reference_eval.py (numpy)"
/usr/bin/python3 "$here/tum_reference_eval.py" "$@" || true
