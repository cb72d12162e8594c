#!/usr/bin/env python3
"""Compares two TUM trajectories pose by pose: the same stamps in the same order, positions
and orientations equal within --tol (a quaternion and its negative are the same rotation).
Exit 0 when they agree, 1 (with the first difference) when not.

    compare_tum.py A B [--tol 1e-8] [--min-poses N]
"""
import argparse
import sys


def read(path):
    rows = []
    with open(path) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            parts = line.split()
            if len(parts) != 8:
                raise ValueError("%s: not a TUM line: %r" % (path, line))
            rows.append((parts[0], [float(v) for v in parts[1:]]))
    return rows


def main():
    p = argparse.ArgumentParser()
    p.add_argument("a")
    p.add_argument("b")
    p.add_argument("--tol", type=float, default=1e-8)
    p.add_argument("--min-poses", type=int, default=1)
    a = p.parse_args()
    ta, tb = read(a.a), read(a.b)
    if len(ta) != len(tb):
        print("different pose counts: %d in %s, %d in %s" % (len(ta), a.a, len(tb), a.b))
        return 1
    if len(ta) < a.min_poses:
        print("only %d poses (fewer than %d)" % (len(ta), a.min_poses))
        return 1
    for i, ((sa, va), (sb, vb)) in enumerate(zip(ta, tb)):
        if sa != sb:
            print("pose %d: stamps %s and %s" % (i, sa, sb))
            return 1
        dt = max(abs(x - y) for x, y in zip(va[:3], vb[:3]))
        dq = min(max(abs(x - y) for x, y in zip(va[3:], vb[3:])),
                 max(abs(x + y) for x, y in zip(va[3:], vb[3:])))
        if dt > a.tol or dq > a.tol:
            print("pose %d (%s): position differs by %g, quaternion by %g" % (i, sa, dt, dq))
            return 1
    print("%d poses agree within %g" % (len(ta), a.tol))
    return 0


if __name__ == "__main__":
    sys.exit(main())
