#!/usr/bin/env python3
"""Per-frame-pair errors of trajectories against TUM ground truth, for diagnosing what an
estimator's error is made of (docs/estimator.md, "The error that two independent estimators
share"; docs/depth_filter.md, "Depth at the colour instant"). Pure Python, no numpy.

  pair_errors.py shared GT A B [A.cov]    per axis: A's RMS error, the part shared with B
                                          (their cross-covariance), A's own, A's predicted sigma
  pair_errors.py clock GT TRAJ...         RMS error per pair against ground truth shifted by tau
  pair_errors.py depth-offset DATASET TRAJ...
                                          fit of each pair's error to v (offset_j - offset_i),
                                          offset = depth minus colour stamp (depth.txt)
  pair_errors.py scale GT TRAJ...         per-pair translation of TRAJ relative to the truth's
  pair_errors.py span GT TRAJ...          RMS error of the relative pose over k = 1..24 frames

Trajectories are TUM files (stamp tx ty tz qx qy qz qw, camera to world); A.cov is pplvo-run's
--covariance file. Errors are those of the relative pose between consecutive trajectory lines,
in the earlier camera's frame: translation in mm, rotation as 2 q_xyz in degrees.
"""
import bisect
import math
import sys


def qmul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)


def qconj(q):
    return (-q[0], -q[1], -q[2], q[3])


def qrot(q, v):
    return qmul(qmul(q, (v[0], v[1], v[2], 0.0)), qconj(q))[:3]


def inverse(T):
    t, q = T
    qi = qconj(q)
    ti = qrot(qi, t)
    return ((-ti[0], -ti[1], -ti[2]), qi)


def compose(A, B):
    ta, qa = A
    tb, qb = B
    r = qrot(qa, tb)
    return ((ta[0] + r[0], ta[1] + r[1], ta[2] + r[2]), qmul(qa, qb))


def load_trajectory(path):
    out = []
    for line in open(path):
        if line.startswith('#') or not line.strip():
            continue
        v = line.split()
        x = [float(f) for f in v[1:8]]
        out.append((float(v[0]), (tuple(x[:3]), tuple(x[3:7]))))
    return out


def slerp(q0, q1, a):
    d = sum(x * y for x, y in zip(q0, q1))
    if d < 0:
        q1, d = tuple(-x for x in q1), -d
    if d > 0.9995:
        q = tuple(x + a * (y - x) for x, y in zip(q0, q1))
    else:
        th = math.acos(d)
        s = math.sin(th)
        q = tuple((math.sin((1 - a) * th) * x + math.sin(a * th) * y) / s for x, y in zip(q0, q1))
    n = math.sqrt(sum(x * x for x in q))
    return tuple(x / n for x in q)


class GroundTruth:
    def __init__(self, path):
        self.samples = load_trajectory(path)
        self.stamps = [s for s, _ in self.samples]

    def at(self, stamp):
        """Pose interpolated at `stamp`, None outside or across a gap of more than 50 ms."""
        i = bisect.bisect_left(self.stamps, stamp)
        if i == 0 or i >= len(self.stamps):
            return None
        (s0, T0), (s1, T1) = self.samples[i - 1], self.samples[i]
        if s1 - s0 > 0.05:
            return None
        a = (stamp - s0) / (s1 - s0)
        return (tuple(x + a * (y - x) for x, y in zip(T0[0], T1[0])), slerp(T0[1], T1[1], a))


def pair_errors(gt, trajectory, tau=0.0):
    """{stamp of the later frame: (error [tx ty tz rx ry rz], true relative pose, dt)}."""
    out = {}
    for (s0, T0), (s1, T1) in zip(trajectory, trajectory[1:]):
        g0, g1 = gt.at(s0 + tau), gt.at(s1 + tau)
        if g0 is None or g1 is None:
            continue
        truth = compose(inverse(g0), g1)
        E = compose(inverse(truth), compose(inverse(T0), T1))
        sign = 1 if E[1][3] >= 0 else -1
        out[round(s1, 4)] = (list(E[0]) + [2 * sign * c for c in E[1][:3]], truth, s1 - s0)
    return out


AXES = ['t x', 't y', 't z', 'rot x', 'rot y', 'rot z']


def scaled(k, value):
    return value * 1000 if k < 3 else math.degrees(value)


def predicted_variances(path):
    """{stamp: variances of [t; 2 q_xyz]} from a pplvo-run --covariance file."""
    out = {}
    diagonal = [0, 6, 11, 15, 18, 20]  # of the row-major upper triangle of a 6x6
    for line in open(path):
        if line.startswith('#') or not line.strip():
            continue
        v = line.split()
        c = [float(x) for x in v[10:31]]
        out[round(float(v[0]), 4)] = [c[i] * (1 if k < 3 else 4) for k, i in enumerate(diagonal)]
    return out


def cmd_shared(gt_path, a_path, b_path, cov_path=None):
    gt = GroundTruth(gt_path)
    A = pair_errors(gt, load_trajectory(a_path))
    B = pair_errors(gt, load_trajectory(b_path))
    pred = predicted_variances(cov_path) if cov_path else {}
    keys = sorted(set(A) & set(B) & (set(pred) if pred else set(A)))
    print(f'{len(keys)} pairs; units mm and deg')
    print('axis   A rms   shared   A own   A predicted   correlation')
    for k in range(6):
        a = [A[s][0][k] for s in keys]
        b = [B[s][0][k] for s in keys]
        n = len(a)
        va, vb = sum(x * x for x in a) / n, sum(x * x for x in b) / n
        cab = sum(x * y for x, y in zip(a, b)) / n
        p = math.sqrt(sum(pred[s][k] for s in keys) / n) if pred else float('nan')
        print(f'{AXES[k]:6s} {scaled(k, math.sqrt(va)):7.3f} {scaled(k, math.sqrt(max(cab, 0))):7.3f}'
              f' {scaled(k, math.sqrt(max(va - cab, 0))):7.3f} {scaled(k, p):11.3f}'
              f' {cab / math.sqrt(va * vb):+12.2f}')


def rms_of(errors, first, last):
    n = len(errors)
    return math.sqrt(sum(sum(x * x for x in e[0][first:last]) for e in errors.values()) / n)


def cmd_clock(gt_path, *paths):
    gt = GroundTruth(gt_path)
    trajectories = [load_trajectory(p) for p in paths]
    print('tau ms  ' + '  '.join(f'[{i}] t mm  rot deg' for i in range(len(paths))))
    for tau_ms in range(-40, 41, 5):
        row = []
        for tr in trajectories:
            E = pair_errors(gt, tr, tau_ms / 1000.0)
            row.append(f'{rms_of(E, 0, 3) * 1000:8.2f} {math.degrees(rms_of(E, 3, 6)):8.3f}')
        print(f'{tau_ms:+6d}  ' + '  '.join(row))


def cmd_depth_offset(dataset, *paths):
    gt = GroundTruth(dataset + '/groundtruth.txt')
    depth = sorted(float(l.split()[0]) for l in open(dataset + '/depth.txt')
                   if l.strip() and not l.startswith('#'))

    def offset(stamp):
        i = bisect.bisect_left(depth, stamp)
        near = [depth[j] for j in (i - 1, i) if 0 <= j < len(depth)]
        return min(near, key=lambda d: abs(d - stamp)) - stamp

    for path in paths:
        tr = load_trajectory(path)
        errors, models = [], []
        E = pair_errors(gt, tr)
        stamps = [s for s, _ in tr]
        for s1, (e, truth, dt) in E.items():
            i = min(range(len(stamps)), key=lambda j: abs(stamps[j] - s1))
            s0 = stamps[i - 1]
            v = [x / dt for x in truth[0]]
            errors.append(e[:3])
            models.append([x * (offset(s1) - offset(s0)) for x in v])
        num = sum(sum(a * b for a, b in zip(e, m)) for e, m in zip(errors, models))
        den = sum(sum(b * b for b in m) for m in models)
        k = num / den
        res = sum(sum((a - k * b) ** 2 for a, b in zip(e, m)) for e, m in zip(errors, models))
        tot = sum(sum(a * a for a in e) for e in errors)
        print(f'{path}: error = k v (offset_j - offset_i): k = {k:.2f}, R^2 = {1 - res / tot:.2f}')


def cmd_scale(gt_path, *paths):
    gt = GroundTruth(gt_path)
    for path in paths:
        tr = load_trajectory(path)
        num = den = 0.0
        for (s0, T0), (s1, T1) in zip(tr, tr[1:]):
            g0, g1 = gt.at(s0), gt.at(s1)
            if g0 is None or g1 is None:
                continue
            truth = compose(inverse(g0), g1)[0]
            est = compose(inverse(T0), T1)[0]
            num += sum(a * b for a, b in zip(truth, est))
            den += sum(a * a for a in truth)
        print(f'{path}: translation per pair = {num / den:.3f} x the truth\'s')


def cmd_span(gt_path, *paths):
    """RMS error (3D translation, mm; rotation angle, deg) of the relative pose over k frames.
    An error of each frame's own (shared by its matches) gives a flat curve from k = 1 on;
    an error of each pair accumulates: the variance grows with k."""
    gt = GroundTruth(gt_path)
    spans = (1, 2, 3, 4, 6, 8, 12, 16, 24)
    for path in paths:
        tr = load_trajectory(path)
        cells = []
        for k in spans:
            et = er = 0.0
            n = 0
            for (s0, T0), (s1, T1) in zip(tr, tr[k:]):
                g0, g1 = gt.at(s0), gt.at(s1)
                if g0 is None or g1 is None:
                    continue
                E = compose(inverse(compose(inverse(g0), g1)), compose(inverse(T0), T1))
                et += sum(v * v for v in E[0])
                er += 4 * sum(v * v for v in E[1][:3])
                n += 1
            if n:
                cells.append(f'k={k}: {1e3 * math.sqrt(et / n):.2f} mm '
                             f'{math.degrees(math.sqrt(er / n)):.3f} deg')
        print(f'{path}:', ', '.join(cells))


COMMANDS = {'shared': cmd_shared, 'clock': cmd_clock, 'depth-offset': cmd_depth_offset,
            'scale': cmd_scale, 'span': cmd_span}

if __name__ == '__main__':
    if len(sys.argv) < 4 or sys.argv[1] not in COMMANDS:
        sys.exit(__doc__)
    COMMANDS[sys.argv[1]](*sys.argv[2:])
