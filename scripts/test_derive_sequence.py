#!/usr/bin/env python3
"""Tests of scripts/derive_sequence.py on fabricated TUM folders (ctest: derive_sequence)."""

import io
import os
import sys
import tempfile
import unittest
from contextlib import redirect_stderr, redirect_stdout

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import derive_sequence  # noqa: E402

PERIOD = 1.0 / 30
DEPTH_OFFSET = -0.015  # depth taken 15 ms before colour, as fr1's often is


def stamps(path):
    with open(path) as f:
        return [float(l.split()[0]) for l in f if l.strip() and not l.startswith('#')]


def column(path, k):
    with open(path) as f:
        return [l.split()[k] for l in f if l.strip() and not l.startswith('#')]


class Folder:
    """A TUM folder of n frames at 30 Hz: rgb/, depth/ (empty files), the lists, and ground
    truth at 100 Hz moving along x at 1 m/s (x = stamp - start)."""

    def __init__(self, n=10, associations=False):
        self._dir = tempfile.TemporaryDirectory()
        self.root = os.path.join(self._dir.name, 'src')
        self.out = self._dir.name
        os.makedirs(os.path.join(self.root, 'rgb'))
        os.makedirs(os.path.join(self.root, 'depth'))
        self.start = 100.0
        rgb, depth = [], []
        for k in range(n):
            t = self.start + k * PERIOD
            rgb.append('%.6f rgb/%.6f.png' % (t, t))
            depth.append('%.6f depth/%.6f.png' % (t + DEPTH_OFFSET, t + DEPTH_OFFSET))
            open(os.path.join(self.root, 'rgb', '%.6f.png' % t), 'w').close()
            open(os.path.join(self.root, 'depth', '%.6f.png' % (t + DEPTH_OFFSET)), 'w').close()
        self.write('rgb.txt', rgb)
        self.write('depth.txt', depth)
        if associations:
            self.write('associations.txt',
                       [d + ' ' + r for d, r in zip(depth, rgb)])
        gt = []
        t = self.start - 0.1
        while t < self.start + n * PERIOD + 0.1:
            gt.append('%.4f %.4f 0 0 0 0 0 1' % (t, t - self.start))
            t += 0.01
        self.write('groundtruth.txt', gt)
        self.write('calib_params.xml', ['<opencv_storage/>'])

    def cleanup(self):
        self._dir.cleanup()

    def write(self, name, lines):
        with open(os.path.join(self.root, name), 'w') as f:
            f.write('# fabricated\n' + '\n'.join(lines) + '\n')

    def derive(self, *args):
        out, err = io.StringIO(), io.StringIO()
        with redirect_stdout(out), redirect_stderr(err):
            rc = derive_sequence.main(['derive_sequence.py'] + [str(a) for a in args])
        return rc, err.getvalue()

    def path(self, name):
        return os.path.join(self.out, name)


class Case(unittest.TestCase):
    def folder(self, *args, **kwargs):
        f = Folder(*args, **kwargs)
        self.addCleanup(f.cleanup)
        return f


class Every(Case):
    def test_every_third_frame_of_the_colour_list(self):
        f = self.folder(10)
        self.assertEqual(f.derive('every', 3, f.root, f.path('e3'))[0], 0)
        got = stamps(f.path('e3/rgb.txt'))
        self.assertEqual(len(got), 4)
        self.assertAlmostEqual(got[1] - got[0], 3 * PERIOD, places=5)
        # Depth and ground truth whole (the reader associates), images linked, not copied.
        self.assertEqual(len(stamps(f.path('e3/depth.txt'))), 10)
        self.assertTrue(os.path.islink(f.path('e3/rgb')))
        self.assertTrue(os.path.isfile(f.path('e3/rgb/%.6f.png' % got[3])))

    def test_a_rendered_folder_keeps_its_associations(self):
        f = self.folder(9, associations=True)
        self.assertEqual(f.derive('every', 2, f.root, f.path('e2'))[0], 0)
        self.assertEqual(len(stamps(f.path('e2/associations.txt'))), 5)
        # rgb.txt follows the associations' colour columns.
        self.assertEqual(column(f.path('e2/rgb.txt'), 1),
                         column(f.path('e2/associations.txt'), 3))


class Drop(Case):
    def test_seeded_keeps_the_first_and_drops_about_the_fraction(self):
        f = self.folder(400)
        self.assertEqual(f.derive('drop', 0.25, 7, f.root, f.path('a'))[0], 0)
        self.assertEqual(f.derive('drop', 0.25, 7, f.root, f.path('b'))[0], 0)
        a = stamps(f.path('a/rgb.txt'))
        self.assertEqual(a, stamps(f.path('b/rgb.txt')))  # same seed, same frames
        self.assertAlmostEqual(a[0], f.start, places=5)
        self.assertGreater(len(a), 0.65 * 400)
        self.assertLess(len(a), 0.85 * 400)
        self.assertEqual(a, sorted(a))


class Palindrome(Case):
    def test_backward_legs_mirror_time_images_and_truth(self):
        n = 10
        f = self.folder(n)
        self.assertEqual(f.derive('palindrome', 3, f.root, f.path('p'))[0], 0)
        rgb = stamps(f.path('p/rgb.txt'))
        self.assertEqual(len(rgb), 3 * n)
        self.assertTrue(all(b > a for a, b in zip(rgb, rgb[1:])))
        # The first frame of the backward leg is the last image, its ground truth the last
        # pose; its last frame is the first image.
        names = column(f.path('p/rgb.txt'), 1)
        first_back = os.path.basename(os.readlink(f.path('p/' + names[n])))
        last_back = os.path.basename(os.readlink(f.path('p/' + names[2 * n - 1])))
        self.assertEqual(first_back, '%.6f.png' % (f.start + (n - 1) * PERIOD))
        self.assertEqual(last_back, '%.6f.png' % f.start)
        # The camera turns back: x of the truth rises over leg one and falls over leg two.
        with open(f.path('p/groundtruth.txt')) as g:
            truth = [(float(l.split()[0]), float(l.split()[1])) for l in g
                     if l.strip() and not l.startswith('#')]
        def x_at(t):
            return min(truth, key=lambda p: abs(p[0] - t))[1]
        self.assertLess(x_at(rgb[0]), x_at(rgb[n - 1]))
        self.assertGreater(x_at(rgb[n]), x_at(rgb[2 * n - 1]))
        self.assertAlmostEqual(x_at(rgb[n]), x_at(rgb[n - 1]), places=2)
        # Depth 15 ms before colour forward is 15 ms after it backward (mirrored time).
        depth = stamps(f.path('p/depth.txt'))
        nearest = min(depth, key=lambda d: abs(d - rgb[n + 1]))
        self.assertAlmostEqual(nearest - rgb[n + 1], -DEPTH_OFFSET, places=4)


class Errors(Case):
    def test_bad_arguments_and_an_existing_destination_are_refused(self):
        f = self.folder(5)
        self.assertEqual(f.derive('every', 0, f.root, f.path('x'))[0], 1)
        self.assertEqual(f.derive('drop', 1.5, 1, f.root, f.path('x'))[0], 1)
        self.assertEqual(f.derive('sideways', 1, f.root, f.path('x'))[0], 1)
        self.assertEqual(f.derive('every', 2, f.root, f.path('y'))[0], 0)
        rc, err = f.derive('every', 2, f.root, f.path('y'))
        self.assertEqual(rc, 1)
        self.assertIn('exists', err)
        rc, err = f.derive('every', 2, f.path('missing'), f.path('z'))
        self.assertEqual(rc, 1)


if __name__ == '__main__':
    unittest.main()
