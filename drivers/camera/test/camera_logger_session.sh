#!/usr/bin/env bash
# The recording recipe of docs/cameras.md, end to end and off the host network: inside a
# private network namespace (scripts/isolated.sh: loopback only, udpm ttl=0), pplvo-camera
# replays a fakenect dump of the TUM sequence over udpm while pplvo-logger records
# PPLVO_(RGBD|STREAM|STATUS) with --until-end; the log must hold all frames, START and END.
# Usage: camera_logger_session.sh CAMERA_EXE TOOL_EXE LOGGER_EXE SHARED_DATA
set -euo pipefail
if [ -z "${PPLVO_IN_NETNS:-}" ]; then
  # Re-run inside the private namespace; skip (ctest code 77) where namespaces are unavailable.
  isolated="$(cd "$(dirname "$0")/../../.." && pwd)/scripts/isolated.sh"
  if ! "$isolated" true > /dev/null 2>&1; then
    echo "cannot create a private network namespace (unshare): skipping"
    exit 77
  fi
  exec "$isolated" "$0" "$@"
fi
camera=$1 tool=$2 logger=$3 data=$4
case "${LCM_DEFAULT_URL:-}" in udpm://*ttl=0*) ;; *) echo "refusing: LCM_DEFAULT_URL=${LCM_DEFAULT_URL:-} is not udpm ttl=0" >&2; exit 1;; esac
command -v fakenect > /dev/null || { echo "fakenect not installed: skipping"; exit 77; }

dir=$(mktemp -d /tmp/pplvo_camera_session.XXXXXX)
trap 'rm -rf "$dir"' EXIT
"$tool" --dataset "$data/tum_fr3_sitting_static_short" --output "$dir/dump" --max-frames 20 \
  2> "$dir/tool.log"

"$logger" --output "$dir/session.lcmlog" --channels 'PPLVO_(RGBD|STREAM|STATUS)' \
  --until-end --drain 0.5 --idle-timeout 20 2> "$dir/logger.log" &
logger_pid=$!
sleep 1  # let the logger subscribe
fakenect "$dir/dump" "$camera" --backend freenect --rgb-encoding jpeg --depth-encoding zlib \
  > /dev/null 2> "$dir/camera.log"
wait "$logger_pid" || { echo "logger failed:"; cat "$dir/logger.log"; exit 1; }

# Count events per channel in the LCM event log (sync word, event number, utime, channel
# length, data length, channel, data; big-endian).
/usr/bin/python3 - "$dir/session.lcmlog" <<'PY'
import struct, sys, collections
counts = collections.Counter()
with open(sys.argv[1], 'rb') as f:
    while True:
        head = f.read(28)
        if len(head) < 28:
            break
        sync, _, _, clen, dlen = struct.unpack('>IqqII', head)
        assert sync == 0xEDA1DA01, 'bad sync word'
        channel = f.read(clen).decode()
        f.seek(dlen, 1)
        counts[channel] += 1
print(dict(counts))
assert counts['PPLVO_RGBD'] == 20, counts
assert counts['PPLVO_STREAM'] == 2, counts   # START and END
assert counts['PPLVO_STATUS'] >= 1, counts
PY
echo "camera -> udpm (isolated) -> pplvo-logger: OK"
