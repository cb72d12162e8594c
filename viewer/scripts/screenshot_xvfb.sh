#!/bin/bash
# Shows pplvo-viewer in a real X window under Xvfb and takes a screenshot of the X display.
#
#   viewer/scripts/screenshot_xvfb.sh [BUILD_DIR] [OUT.png]
#
# 1. pplvo-player writes the first frames of the shared TUM sequence into an LCM log through
#    the file:// provider (no network traffic at all).
# 2. pplvo-viewer --replay LOG runs under xvfb-run (a private X server), showing its window.
# 3. xshot.py grabs the X root window with XGetImage (libX11 via ctypes; neither `import` nor
#    `xwd` is installed) while the window is up, writes OUT.png, and checks that the window area
#    shows, pixel for pixel, the last canvas the viewer saved itself (--save-window, PPM).
# Only frames are in the log (no features, poses or fused depth: those come from other nodes),
# so the colour and raw-depth panels and the player's status are what the screenshot shows.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:-$root/build}
out=${2:-$root/docs/images/viewer_screenshot.png}
data=${PPLVO_SHARED_DATA:-$root/../shared/data}/tum_fr3_sitting_static_short
for bin in pplvo-player pplvo-viewer; do
  [[ -x $build/bin/$bin ]] || { echo "missing $build/bin/$bin (build it first)" >&2; exit 1; }
done
command -v xvfb-run > /dev/null || { echo "xvfb-run is not installed" >&2; exit 1; }
tmp=$(mktemp -d /tmp/pplvo_viewer_shot_XXXXXX)
trap 'rm -rf "$tmp"' EXIT

"$build/bin/pplvo-player" --dataset "$data" --lcm-url "file://$tmp/tum.lcmlog?mode=w" \
  --rate 0 --max-frames 90 --rgb-encoding jpeg --depth-encoding png --no-progress

# Inside the private X server: the viewer replays the log in real time (90 frames = 3 s) and
# keeps its window up until --timeout; the screenshot is taken after the replay.
xvfb-run -a -s "-screen 0 1600x960x24" bash -c '
  set -e
  "$1/bin/pplvo-viewer" --replay "$2/tum.lcmlog" --replay-speed 1 --max-fps 15 --timeout 7 \
    --depth-range 0.5,4.0 --save-window "$2/self.ppm" &
  viewer=$!
  sleep 5
  /usr/bin/python3 "$3/xshot.py" "$4" --compare "$2/self.ppm"
  wait $viewer
' _ "$build" "$tmp" "$(dirname "$0")" "$out"
echo "screenshot: $out"
