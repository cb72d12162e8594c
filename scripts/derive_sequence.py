#!/usr/bin/env python3
"""A TUM-layout sequence derived from another by leaving frames out or replaying it, made of
symbolic links (nothing copied): what a slower camera, a lossy link or a camera that turns
back gives, on frames (and ground truth) recorded once. Pure Python.

  derive_sequence.py every N SRC DST          every N-th frame (a camera at 1/N the rate)
  derive_sequence.py drop FRACTION SEED SRC DST
                                              each frame after the first left out with
                                              probability FRACTION (a lossy link), seeded
  derive_sequence.py palindrome LEGS SRC DST  played forward, backward, forward... LEGS times;
                                              backward legs mirror the time, so the camera
                                              turns back and colour/depth offsets keep their
                                              sign relative to the motion

SRC's frames are its associations.txt if it has one (pplvo-synth), else its rgb.txt (with
depth.txt and groundtruth.txt kept whole: the reader associates them). DST must not exist.
Caveats: a backward leg reverses a rolling shutter's readout relative to the motion and a
ground-truth clock offset (TUM's is ~-15 ms) changes sign; both cost every system alike.
"""
import os
import random
import sys


def read_list(path):
    """Lines of a TUM list as (stamp, fields), comments and blank lines dropped."""
    out = []
    with open(path) as f:
        for line in f:
            if line.startswith('#') or not line.strip():
                continue
            fields = line.split()
            out.append((float(fields[0]), fields))
    return out


def link_folder(src, dst, names):
    os.makedirs(dst)
    for name in names:
        if os.path.exists(os.path.join(src, name)):
            os.symlink(os.path.join(os.path.abspath(src), name), os.path.join(dst, name))


def frame_list_name(src):
    return 'associations.txt' if os.path.exists(os.path.join(src, 'associations.txt')) else 'rgb.txt'


def write_list(path, header, rows):
    with open(path, 'w') as f:
        f.write(header)
        for fields in rows:
            f.write(' '.join(fields) + '\n')


def subset(src, dst, keep):
    """DST with the frames of SRC for which keep(index) holds; the rest linked as is."""
    name = frame_list_name(src)
    frames = read_list(os.path.join(src, name))
    rows = [fields for k, (_, fields) in enumerate(frames) if keep(k)]
    others = ['rgb', 'depth', 'calib_params.xml', 'groundtruth.txt', 'depth.txt',
              'associations.txt']
    link_folder(src, dst, [n for n in others if n != name])
    write_list(os.path.join(dst, name), '# derived by derive_sequence.py from %s\n' % src, rows)
    if name == 'associations.txt':  # depth_stamp depth_file rgb_stamp rgb_file
        write_list(os.path.join(dst, 'rgb.txt'), '# colour images\n', [r[2:4] for r in rows])
    return len(frames), len(rows)


def palindrome(src, dst, legs):
    """Mirrored legs: stamp t -> B + (t - t0) forward, B + (t1 - t) backward."""
    rgb = read_list(os.path.join(src, 'rgb.txt'))
    depth = read_list(os.path.join(src, 'depth.txt'))
    gt = read_list(os.path.join(src, 'groundtruth.txt'))
    t0 = min(t for t, _ in rgb + depth)
    t1 = max(t for t, _ in rgb + depth)
    period = (max(t for t, _ in rgb) - min(t for t, _ in rgb)) / max(1, len(rgb) - 1)
    link_folder(src, dst, ['calib_params.xml'])
    os.makedirs(os.path.join(dst, 'rgb'))
    os.makedirs(os.path.join(dst, 'depth'))
    out = {'rgb': [], 'depth': [], 'gt': []}
    base = t0
    for leg in range(legs):
        forward = leg % 2 == 0
        def moved(t, base=base, forward=forward):
            return base + (t - t0) if forward else base + (t1 - t)
        for kind, entries in (('rgb', rgb), ('depth', depth)):
            for t, fields in entries:
                stamp = '%.6f' % moved(t)
                name = '%s/%s.png' % (kind, stamp)
                os.symlink(os.path.join(os.path.abspath(src), fields[1]), os.path.join(dst, name))
                out[kind].append((moved(t), [stamp, name]))
        for t, fields in gt:
            if t0 <= t <= t1:
                out['gt'].append((moved(t), ['%.6f' % moved(t)] + fields[1:]))
        base += (t1 - t0) + period
    for kind, name, header in (('rgb', 'rgb.txt', '# colour images\n'),
                               ('depth', 'depth.txt', '# depth maps\n'),
                               ('gt', 'groundtruth.txt', '# ground truth trajectory\n')):
        write_list(os.path.join(dst, name), header, [f for _, f in sorted(out[kind])])
    return len(rgb), len(out['rgb'])


def main(argv):
    try:
        mode = argv[1]
        if len(argv) > 2 and os.path.lexists(argv[-1]):
            raise ValueError('%s exists' % argv[-1])
        if mode == 'every':
            n, src, dst = int(argv[2]), argv[3], argv[4]
            if n < 1:
                raise ValueError('N must be at least 1')
            before, after = subset(src, dst, lambda k: k % n == 0)
        elif mode == 'drop':
            fraction, seed, src, dst = float(argv[2]), int(argv[3]), argv[4], argv[5]
            if not 0 <= fraction < 1:
                raise ValueError('FRACTION must be in [0, 1)')
            rng = random.Random(seed)  # subset() asks once per frame, in order
            before, after = subset(src, dst, lambda k: k == 0 or rng.random() >= fraction)
        elif mode == 'palindrome':
            legs, src, dst = int(argv[2]), argv[3], argv[4]
            if legs < 1:
                raise ValueError('LEGS must be at least 1')
            before, after = palindrome(src, dst, legs)
        else:
            raise ValueError('unknown mode ' + mode)
    except (IndexError, ValueError, OSError) as e:
        sys.stderr.write('derive_sequence.py: %s\n\n%s' % (e, __doc__))
        return 1
    print('%s: %d of %d frames -> %s' % (mode, after, before, dst))
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv))
