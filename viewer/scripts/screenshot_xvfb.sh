#!/bin/bash
# Shows pplvo-viewer in a real X window under Xvfb and takes a screenshot of the X display.
#
#   viewer/scripts/screenshot_xvfb.sh [BUILD_DIR] [OUT.png]
#
# OUT.png defaults to BUILD_DIR/viewer_screenshot.png; the one in docs/images is only replaced
# when it is named.
# 1. pplvo-run runs the whole pipeline (player, depth filter, frontend, estimator, in one
#    process on memq://) on the first 150 frames of the shared TUM sequence and records every
#    message into an LCM log (--log; no network traffic at all).
# 2. pplvo-viewer --replay LOG runs under xvfb-run (a private X server), showing its window.
# 3. xshot.py grabs the X root window with XGetImage (libX11 via ctypes; neither `import` nor
#    `xwd` is installed) while the window is up, writes OUT.png, and checks that the window area
#    shows, pixel for pixel, the last canvas the viewer saved itself (--save-window, PPM).
# The log holds every channel (frames, C-GM and fused depth, 2D/3D features, poses, status), so
# every panel shows data; the trajectory views have the sequence's ground truth (--groundtruth).
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:-$root/build}
out=${2:-$build/viewer_screenshot.png}
data=${PPLVO_SHARED_DATA:-$root/../shared/data}/tum_fr3_sitting_static_short
for bin in pplvo-run pplvo-viewer; do
  [[ -x $build/bin/$bin ]] || { echo "missing $build/bin/$bin (build it first)" >&2; exit 1; }
done
command -v xvfb-run > /dev/null || { echo "xvfb-run is not installed" >&2; exit 1; }
tmp=$(mktemp -d /tmp/pplvo_viewer_shot_XXXXXX)
trap 'rm -rf "$tmp"' EXIT

"$build/bin/pplvo-run" --dataset "$data" --max-frames 150 --log "$tmp/tum.lcmlog" --quiet \
  --no-progress

# Inside the private X server: the viewer replays the log as fast as it reads it (about 3 s) and
# keeps its window up until --timeout; the screenshot is taken after the replay.
xvfb-run -a -s "-screen 0 1600x960x24" bash -c '
  set -e
  "$1/bin/pplvo-viewer" --replay "$2/tum.lcmlog" --replay-speed 0 --max-fps 15 --timeout 9 \
    --depth-range 0.5,4.0 --groundtruth "$5/groundtruth.txt" --save-window "$2/self.ppm" &
  viewer=$!
  sleep 7
  /usr/bin/python3 "$3/xshot.py" "$4" --compare "$2/self.ppm"
  wait $viewer
' _ "$build" "$tmp" "$(dirname "$0")" "$out" "$data"
echo "screenshot: $out"
