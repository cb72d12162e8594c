#!/usr/bin/env bash
# One command on a fresh Debian machine: installs the Debian packages, builds pplvo (Release),
# generates the embedded default synthetic sequence (ray-cast room, Kinect-like depth noise,
# known ground truth), runs the pipeline on it as separate processes (player, depth filter,
# frontend, estimator, logger) inside a private network namespace, and prints ATE and RPE.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh
mkdir -p build
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release > build/configure.log 2>&1 || { cat build/configure.log; exit 1; }
cmake --build build -j "$(nproc)"
out=build/demo
mkdir -p "$out"
rm -rf "$out/synth_room"
build/bin/pplvo-synth --output "$out/synth_room" --frames 90 --seed 1 --scene room
scripts/run_demo_pipeline.sh "$out/synth_room" "$out/run"
echo "demo: trajectory $out/run/trajectory.txt, processes' report $out/run/launch_report.txt," \
     "errors $out/run/eval.txt (plot: build/bin/pplvo-plot $out/synth_room/groundtruth.txt" \
     "$out/run/trajectory.txt --output $out/run/trajectory.png)"
