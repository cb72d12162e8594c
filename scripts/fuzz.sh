#!/usr/bin/env bash
# Builds the libFuzzer harnesses (tests/fuzz) with clang, AddressSanitizer and
# UndefinedBehaviorSanitizer in their own build folder and runs each for a given time.
#
#   scripts/fuzz.sh [SECONDS_PER_HARNESS] [BUILD_DIR]     # defaults: 60, build-fuzz
#   PPLVO_FUZZ_HARNESSES="fuzz_lcm_decode fuzz_png_decode" scripts/fuzz.sh 10   # a subset
#
# Seeds: the shared sequences' PNG images, index files and calib_params.xml when
# ../shared/data is there (copied into BUILD_DIR/corpus, never into the repository), the
# camera YAML example of docs/player.md, config/pplvo.yaml's values, and small image_t planes (zlib
# label, depth and float planes, raw planes) made here, and JPEGs written from a few colour
# frames by make_jpeg_seeds (two with an Exif block); the LCM harness starts from nothing
# (libFuzzer's comparison tracing finds the type hashes). Each harness's corpus is
# kept in BUILD_DIR/corpus/NAME between runs. A crash leaves BUILD_DIR/crash-* and makes the
# script exit 1; turn each into a regression test with its input. Prints per harness the
# inputs run. Needs: clang, libclang-rt-14-dev (scripts/install_deps.sh).
set -euo pipefail

seconds=${1:-60}
root=$(cd "$(dirname "$0")/.." && pwd)
build=${2:-$root/build-fuzz}
# PPLVO_FUZZ_HARNESSES (space-separated) picks a subset; .ci/run leaves out the configuration
# harness, whose sanitizer build of the odometry libraries would double the CI step's time.
if [ -n "${PPLVO_FUZZ_HARNESSES:-}" ]; then
  read -r -a harnesses <<<"$PPLVO_FUZZ_HARNESSES"
else
  harnesses=(fuzz_lcm_decode fuzz_png_decode fuzz_index_file fuzz_image_decode fuzz_camera_file
    fuzz_pipeline_config fuzz_jpeg_decode)
fi
targets=("${harnesses[@]}")
# The JPEG harness's seeds are written by make_jpeg_seeds (OpenCV's encoder, from the build).
case " ${harnesses[*]} " in *" fuzz_jpeg_decode "*) targets+=(make_jpeg_seeds) ;; esac

export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$root}
launcher=()
if command -v ccache >/dev/null; then
  launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
fi
mkdir -p "$build"
san="-fsanitize=address,undefined,fuzzer-no-link -fno-sanitize-recover=undefined"
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ "${launcher[@]}" \
  -DCMAKE_C_FLAGS="$san" -DCMAKE_CXX_FLAGS="$san" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" \
  -DPPLVO_BUILD_FUZZERS=ON -DPPLVO_BUILD_BENCHMARKS=OFF >"$build/fuzz-cmake.log" 2>&1 ||
  { cat "$build/fuzz-cmake.log"; exit 1; }
start=$(date +%s)
cmake --build "$build" -j"$(nproc)" --target "${targets[@]}" >"$build/fuzz-build.log" 2>&1 ||
  { tail -40 "$build/fuzz-build.log"; exit 1; }
echo "fuzz harnesses built in $(($(date +%s) - start)) s ($build)"

data=$root/../shared/data
mkdir -p "$build/corpus"
# Every seeded corpus folder, also for a subset of harnesses (the seeding below fills them all).
for h in "${harnesses[@]}" fuzz_png_decode fuzz_index_file fuzz_camera_file fuzz_image_decode \
  fuzz_pipeline_config fuzz_jpeg_decode; do
  mkdir -p "$build/corpus/$h"
done
if [ -d "$data" ]; then
  # A few images of each kind (colour and 16-bit depth) and every index file.
  find "$data" -name '*.png' -size -400k | sort | awk 'NR % 40 == 1 && n++ < 8' |
    while read -r f; do cp -n "$f" "$build/corpus/fuzz_png_decode/$(echo "$f" | md5sum | cut -c1-16)"; done
  find "$data" -name '*.txt' | while read -r f; do
    head -c 4000 "$f" >"$build/corpus/fuzz_index_file/$(echo "$f" | md5sum | cut -c1-16)"
  done
  find "$data" -name 'calib_params.xml' | while read -r f; do
    cp -n "$f" "$build/corpus/fuzz_camera_file/$(echo "$f" | md5sum | cut -c1-16)"
  done
  # A few colour frames for the JPEG seeds (below).
  find "$data" -path '*rgb*' -name '*.png' -size -400k | sort | awk 'NR % 60 == 1 && n++ < 3' \
    >"$build/corpus/jpeg-sources.txt"
  # One colour PNG as an image_t plane (header: width, height, encoding 4 = png). awk reads the
  # whole list: `head -1` could exit while sort still writes, and pipefail turns that SIGPIPE
  # into exit 141 (it did in CI).
  f=$(find "$data" -path '*rgb*' -name '*.png' -size -400k | sort | awk 'NR == 1')
  if [ -n "$f" ]; then
    python3 - "$f" "$build/corpus/fuzz_image_decode/png" <<'PY'
import struct, sys
png = open(sys.argv[1], "rb").read()
w, h = struct.unpack(">II", png[16:24])
open(sys.argv[2], "wb").write(struct.pack("<iib", w, h, 4) + png)
PY
  fi
fi
printf 'fx: 535.4\nfy: 539.2\ncx: 320.1\ncy: 247.6\ndistortion: [0, 0, 0, 0, 0]\ndepth_scale: 5000\nwidth: 640\nheight: 480\n' \
  >"$build/corpus/fuzz_camera_file/camera.yaml"
# The configuration's values without its comment lines (4 KB of the 19 KB): the parse of each
# input is the harness's cost, and the comments are still read back in every round trip
# (the harness parses the full documented dump).
grep -v '^[[:space:]]*#' "$root/config/pplvo.yaml" | grep -v '^[[:space:]]*$' \
  >"$build/corpus/fuzz_pipeline_config/pplvo-values.yaml"
# JPEGs: colour frames (a synthetic gradient without ../shared/data) scaled to 160x120 as
# baseline, progressive, restart-interval and grey files, and two with an Exif block.
if [ -x "$build/bin/make_jpeg_seeds" ]; then
  touch "$build/corpus/jpeg-sources.txt"
  # shellcheck disable=SC2046
  "$build/bin/make_jpeg_seeds" "$build/corpus/fuzz_jpeg_decode" $(cat "$build/corpus/jpeg-sources.txt")
fi
# image_t planes: zlib u8 labels, u16 depth, f32, and the raw encodings, 8x6 pixels each.
python3 - "$build/corpus/fuzz_image_decode" <<'PY'
import os, struct, sys, zlib
out = sys.argv[1]
w, h = 8, 6
for enc, bpp in ((11, 1), (6, 2), (9, 4)):
    plane = bytes((i * 37 + 11) % 256 for i in range(w * h * bpp))
    open(os.path.join(out, "zlib%d" % enc), "wb").write(struct.pack("<iib", w, h, enc) + zlib.compress(plane))
for enc, bpp in ((1, 3), (2, 1), (5, 2), (8, 4), (10, 1)):
    open(os.path.join(out, "raw%d" % enc), "wb").write(struct.pack("<iib", w, h, enc) + bytes(w * h * bpp))
PY

status=0
cd "$build"
for h in "${harnesses[@]}"; do
  log="$build/$h.log"
  if "$build/bin/$h" -max_total_time="$seconds" -rss_limit_mb=2048 -max_len=65536 \
    -print_final_stats=1 "$build/corpus/$h" >"$log" 2>&1; then
    result="no crash"
  else
    result="CRASH (see $log and $build/crash-*)"
    status=1
  fi
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo '?')
  printf '%-18s %12s inputs in %s s: %s\n' "$h" "$runs" "$seconds" "$result"
done
exit $status
