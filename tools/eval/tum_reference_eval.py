#!/usr/bin/python3
"""Independent numpy implementation of the TUM RGB-D benchmark's ATE (evaluate_ate.py) and
RPE (evaluate_rpe.py --fixed_delta --delta 1 --delta_unit s) definitions, written from the
definitions in docs/evaluation.md, used to cross-check the C++ pplvo-eval program.

usage: /usr/bin/python3 tum_reference_eval.py GT EST [--fps F] [--max-difference S] [--delta S]
Prints one JSON object with the same keys as `pplvo-eval --json` (ate.*, rpe.*).
Exit status 2 on errors, 3 when numpy is missing.
"""
import argparse
import json
import math
import sys

try:
    import numpy as np
except ImportError:
    sys.stderr.write("tum_reference_eval.py: numpy is missing for %s: install python3-numpy "
                     "(scripts/install_deps.sh)\n" % sys.executable)
    sys.exit(3)


def load_rows(path, fps):
    """All data lines as float lists, stamps divided by fps when given."""
    with open(path) as handle:
        text = handle.read()
    rows = []
    for raw in text.replace(",", " ").replace("\t", " ").split("\n"):
        if not raw or raw[0] == "#":
            continue
        values = [float(tok) for tok in raw.split()]
        if len(values) < 2:
            continue
        if fps:
            values[0] = values[0] / fps
        rows.append(values)
    return rows


def ate_positions(rows):
    """stamp -> position (dict semantics: last line wins); NaN rows are ignored."""
    out = {}
    for r in rows:
        if not all(math.isfinite(v) for v in r[0:4]):
            continue
        out[r[0]] = np.array(r[1:4], dtype=float)
    return out


def greedy_association(gt_stamps, est_stamps, max_difference):
    a = np.array(sorted(gt_stamps))
    b = np.array(sorted(est_stamps))
    diff = np.abs(a[:, None] - b[None, :])
    ia, ib = np.nonzero(diff < max_difference)
    order = np.lexsort((b[ib], a[ia], diff[ia, ib]))  # by diff, then a, then b
    free_a = np.ones(len(a), dtype=bool)
    free_b = np.ones(len(b), dtype=bool)
    pairs = []
    for k in order:
        x, y = ia[k], ib[k]
        if free_a[x] and free_b[y]:
            free_a[x] = False
            free_b[y] = False
            pairs.append((a[x], b[y]))
    pairs.sort()
    return pairs


def horn_rigid(model, data):
    """model, data: arrays of shape (N, 3). Returns the residual norms after aligning model."""
    mu_m = model.mean(axis=0)
    mu_d = data.mean(axis=0)
    W = (model - mu_m).T @ (data - mu_d)  # sum of outer products model_i data_i^T
    U, _, Vt = np.linalg.svd(W.T)
    S = np.eye(3)
    if np.linalg.det(U) * np.linalg.det(Vt) < 0:
        S[2, 2] = -1.0
    R = U @ S @ Vt
    t = mu_d - R @ mu_m
    residual = (model @ R.T + t) - data
    return np.sqrt((residual ** 2).sum(axis=1))


def summary(values, prefix, unit, scale=1.0):
    v = np.asarray(values, dtype=float) * scale
    return {
        prefix + "rmse_" + unit: float(np.sqrt(np.mean(v * v))),
        prefix + "mean_" + unit: float(np.mean(v)),
        prefix + "median_" + unit: float(np.median(v)),
        prefix + "std_" + unit: float(np.std(v)),
        prefix + "min_" + unit: float(np.min(v)),
        prefix + "max_" + unit: float(np.max(v)),
    }


def compute_ate(gt_rows, est_rows, max_difference):
    gt = ate_positions(gt_rows)
    est = ate_positions(est_rows)
    pairs = greedy_association(list(gt), list(est), max_difference)
    if len(pairs) < 2:
        return {"ok": False, "error": "only %d pose pairs" % len(pairs)}
    data = np.array([gt[a] for a, _ in pairs])
    model = np.array([est[b] for _, b in pairs])
    errors = horn_rigid(model, data)
    out = {"ok": True, "pairs": len(errors)}
    out.update(summary(errors, "", "m"))
    return out


def pose_matrix(r):
    x, y, z, w = r[4:8]
    n = x * x + y * y + z * z + w * w
    T = np.eye(4)
    T[0:3, 3] = r[1:4]
    if n < 4.0 * np.finfo(float).eps:
        return T
    s = 2.0 / n
    T[0:3, 0:3] = [
        [1 - s * (y * y + z * z), s * (x * y - z * w), s * (x * z + y * w)],
        [s * (x * y + z * w), 1 - s * (x * x + z * z), s * (y * z - x * w)],
        [s * (x * z - y * w), s * (y * z + x * w), 1 - s * (x * x + y * y)],
    ]
    return T


def rpe_poses(rows):
    out = {}
    for r in rows:
        if len(r) < 8:
            continue
        if r[4] == 0 and r[5] == 0 and r[6] == 0 and r[7] == 0:
            continue
        if any(math.isnan(v) for v in r) or not math.isfinite(r[0]):
            continue
        out[r[0]] = pose_matrix(r)
    return out


def tum_closest(L, t):
    """The benchmark's binary search, best of the visited midpoints."""
    lo, hi = 0, len(L)
    best, best_d = 0, abs(L[0] - t)
    while lo < hi:
        mid = (lo + hi) // 2
        d = abs(L[mid] - t)
        if d < best_d:
            best, best_d = mid, d
        if L[mid] == t:
            return mid
        if L[mid] > t:
            hi = mid
        else:
            lo = mid + 1
    return best


def compute_rpe(gt_rows, est_rows, delta):
    gt = rpe_poses(gt_rows)
    est = rpe_poses(est_rows)
    if len(gt) < 2 or len(est) < 2:
        return {"ok": False, "error": "too few poses"}
    tg = sorted(gt)
    te = sorted(est)
    returned = set()
    for t in te:
        returned.add(te[tum_closest(te, tg[tum_closest(tg, t)])])
    if len(returned) < 2:
        return {"ok": False, "error": "too little overlap"}
    n = len(te)
    pairs = []
    for i in range(n):
        j = tum_closest(te, te[i] + delta)
        if j != n - 1:
            pairs.append((i, j))
    max_dt = 2.0 * float(np.median(np.diff(np.array(tg))))
    trans, rot = [], []
    skipped = 0
    for i, j in pairs:
        e0, e1 = te[i], te[j]
        g0 = tg[tum_closest(tg, e0)]
        g1 = tg[tum_closest(tg, e1)]
        if abs(g0 - e0) > max_dt or abs(g1 - e1) > max_dt:
            skipped += 1
            continue
        rel_est = np.linalg.solve(est[e1], est[e0])   # inv(E1) E0
        rel_gt = np.linalg.solve(gt[g1], gt[g0])      # inv(G1) G0
        err = np.linalg.solve(rel_est, rel_gt)        # inv(rel_est) rel_gt
        trans.append(float(np.linalg.norm(err[0:3, 3])))
        c = (np.trace(err[0:3, 0:3]) - 1.0) / 2.0
        rot.append(float(np.arccos(np.clip(c, -1.0, 1.0))))
    if len(trans) < 2:
        return {"ok": False, "error": "only %d pairs" % len(trans)}
    out = {"ok": True, "pairs": len(trans), "skipped_pairs_gt_time": skipped}
    out.update(summary(trans, "trans_", "m_per_s", 1.0 / delta))
    out.update(summary(rot, "rot_", "deg_per_s", 180.0 / math.pi / delta))
    return out


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("gt")
    p.add_argument("est")
    p.add_argument("--fps", type=float, default=0.0)
    p.add_argument("--max-difference", type=float, default=0.02)
    p.add_argument("--delta", type=float, default=1.0)
    args = p.parse_args()
    try:
        gt_rows = load_rows(args.gt, args.fps)
        est_rows = load_rows(args.est, args.fps)
    except (OSError, ValueError) as e:
        sys.stderr.write("tum_reference_eval.py: %s\n" % e)
        return 2
    result = {
        "gt": args.gt, "est": args.est, "fps": args.fps,
        "max_difference_s": args.max_difference, "delta_s": args.delta,
        "ate": compute_ate(gt_rows, est_rows, args.max_difference),
        "rpe": compute_rpe(gt_rows, est_rows, args.delta),
    }
    result["ok"] = result["ate"]["ok"] and result["rpe"]["ok"]
    print(json.dumps(result, indent=2))
    return 0 if result["ok"] else 2


if __name__ == "__main__":
    sys.exit(main())
