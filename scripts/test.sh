#!/usr/bin/env bash
# Builds pplvo (Release) and runs the whole test suite with ctest. Usage: scripts/test.sh
# Environment: BUILD_DIR (default build), JOBS (default: number of cores).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build}
JOBS=${JOBS:-$(nproc)}
cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=Release > "$BUILD_DIR.configure.log" 2>&1 || {
  cat "$BUILD_DIR.configure.log"; exit 1; }
cmake --build "$BUILD_DIR" -j "$JOBS"
# LCM traffic from tests stays in-process: memq:// unless a test builds its own namespace.
export LCM_DEFAULT_URL=memq://
ctest --test-dir "$BUILD_DIR" --output-on-failure -j "$JOBS" "$@"
