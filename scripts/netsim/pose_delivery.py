#!/usr/bin/env python3
"""Which poses crossed the link: compares the PPLVO_POSE events recorded on the sensor host
with those recorded on the base host (standard LCM event logs, both stamped by the same
machine's clock). Prints key: value lines.

usage: pose_delivery.py SENSOR.lcmlog BASE.lcmlog [LOSS_STOPPED_UTIME]
       pose_delivery.py --count LOG.lcmlog     (poses recorded so far)
"""
import struct
import sys

SYNC = 0xEDA1DA01


def pose_events(path, partial_ok=False):
    """{seq: receive utime} of the PPLVO_POSE events in an LCM event log (seq: pose_t's
    second field, after the 8-byte fingerprint and utime)."""
    events = {}
    with open(path, "rb") as f:
        data = f.read()
    at = 0
    while at + 28 <= len(data):
        if partial_ok and at + 28 + struct.unpack_from(">I", data, at + 20)[0] + \
                struct.unpack_from(">I", data, at + 24)[0] > len(data):
            break  # the event being written
        sync, _, utime, channel_len, data_len = struct.unpack_from(">IqqII", data, at)
        if sync != SYNC:
            raise SystemExit(f"{path}: no event at byte {at} (truncated or not an LCM log)")
        at += 28
        channel = data[at:at + channel_len].decode()
        payload = data[at + channel_len:at + channel_len + data_len]
        at += channel_len + data_len
        if channel == "PPLVO_POSE" and len(payload) >= 24:
            (seq,) = struct.unpack_from(">q", payload, 16)
            events.setdefault(seq, utime)
    return events


def main():
    if len(sys.argv) == 3 and sys.argv[1] == "--count":
        try:
            print(len(pose_events(sys.argv[2], partial_ok=True)))
        except FileNotFoundError:
            print(0)
        return
    if len(sys.argv) not in (3, 4):
        raise SystemExit(__doc__)
    sensor = pose_events(sys.argv[1])
    base = pose_events(sys.argv[2])
    print(f"poses_on_sensor: {len(sensor)}")
    print(f"poses_on_base: {len(base)}")
    print(f"poses_lost_on_link: {len(set(sensor) - set(base))}")
    latencies = sorted(base[s] - sensor[s] for s in base if s in sensor)
    if latencies:
        print(f"latency_median_ms: {latencies[len(latencies) // 2] / 1000:.2f}")
    if len(sys.argv) == 4:
        stopped = int(sys.argv[3])
        after = [s for s, t in sensor.items() if t >= stopped + 1_000_000]
        missing = [s for s in after if s not in base]
        print(f"poses_published_1s_after_loss_stopped: {len(after)}")
        print(f"poses_missing_1s_after_loss_stopped: {len(missing)}")
        arrived = [base[s] for s, t in sensor.items() if t >= stopped and s in base]
        if arrived:
            print(f"first_pose_after_loss_stopped_ms: {(min(arrived) - stopped) / 1000:.1f}")


if __name__ == "__main__":
    main()
