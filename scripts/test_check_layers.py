#!/usr/bin/env python3
"""Tests of scripts/check_layers.py on fabricated source trees (ctest: layering_checker)."""

import io
import os
import sys
import tempfile
import unittest
from contextlib import redirect_stdout

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import check_layers  # noqa: E402


class Tree:
    """A temporary source tree with a core, an odometry and a tools library and fixtures."""

    def __init__(self):
        self._dir = tempfile.TemporaryDirectory()
        self.root = self._dir.name
        for header in ("core/include/pplvo/core/camera.h",
                       "odometry/geometry/include/pplvo/geometry/planes.h",
                       "tools/synth/include/pplvo/synth/scene.h",
                       "fixtures/include/pplvo/fixtures/room.h",
                       "lcmtypes/cpp/include/pplvo/msgs/convert.h"):
            self.write(header, "#pragma once\n")

    def write(self, rel, text):
        path = os.path.join(self.root, rel)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "w") as f:
            f.write(text)
        return path

    def run(self, targets=None, allow=None):
        args = ["--source", self.root]
        if targets is not None:
            args += ["--targets", self.write("build/targets.tsv", targets)]
        if allow is not None:
            args += ["--allow", self.write("allow.txt", allow)]
        out = io.StringIO()
        with redirect_stdout(out):
            rc = check_layers.main(args)
        return rc, out.getvalue()

    def close(self):
        self._dir.cleanup()


class CheckLayersTest(unittest.TestCase):
    def setUp(self):
        self.tree = Tree()

    def tearDown(self):
        self.tree.close()

    def test_downward_includes_pass(self):
        self.tree.write("odometry/geometry/src/planes.cpp",
                        '#include "pplvo/geometry/planes.h"\n#include "pplvo/core/camera.h"\n')
        self.tree.write("tools/synth/src/scene.cpp", '#include <pplvo/geometry/planes.h>\n')
        rc, out = self.tree.run()
        self.assertEqual(rc, 0, out)
        self.assertIn("clean", out)

    def test_upward_include_fails(self):
        self.tree.write("odometry/geometry/src/planes.cpp",
                        '#include <vector>\n#include "pplvo/synth/scene.h"\n')
        rc, out = self.tree.run()
        self.assertEqual(rc, 1)
        self.assertIn("odometry/geometry/src/planes.cpp:2: includes pplvo/synth/scene.h of tools",
                      out)
        self.assertIn("upward", out)

    def test_message_headers_are_lcmtypes(self):
        self.tree.write("core/src/camera.cpp", "#include <pplvo_msgs/pose_t.hpp>\n")
        self.tree.write("core/src/other.cpp", '#include "pplvo/msgs/convert.h"\n')
        rc, out = self.tree.run()
        self.assertEqual(rc, 1)
        self.assertIn("core/src/camera.cpp:1: includes pplvo_msgs/pose_t.hpp of lcmtypes", out)
        self.assertIn("core/src/other.cpp:1", out)

    def test_relative_include_into_a_higher_folder_fails(self):
        self.tree.write("tools/synth/src/private.h", "#pragma once\n")
        self.tree.write("odometry/geometry/test/test_x.cpp",
                        '#include "../../../tools/synth/src/private.h"\n')
        rc, out = self.tree.run()
        self.assertEqual(rc, 1)
        self.assertIn("test_x.cpp:1", out)

    def test_fixtures_only_from_test_code(self):
        self.tree.write("odometry/geometry/test/test_planes.cpp",
                        '#include "pplvo/fixtures/room.h"\n')
        self.tree.write("core/bench/bench_camera.cpp", '#include "pplvo/fixtures/room.h"\n')
        rc, out = self.tree.run()
        self.assertEqual(rc, 0, out)
        self.tree.write("odometry/geometry/src/planes.cpp", '#include "pplvo/fixtures/room.h"\n')
        rc, out = self.tree.run()
        self.assertEqual(rc, 1)
        self.assertIn("planes.cpp:1: includes pplvo/fixtures/room.h of fixtures (test-only", out)

    def test_fixtures_may_not_use_odometry(self):
        self.tree.write("fixtures/src/room.cpp", '#include "pplvo/geometry/planes.h"\n')
        rc, out = self.tree.run()
        self.assertEqual(rc, 1)
        self.assertIn("fixtures/src/room.cpp:1", out)

    def test_test_code_may_not_include_a_higher_layer(self):
        self.tree.write("odometry/geometry/test/test_planes.cpp",
                        '#include "pplvo/synth/scene.h"\n')
        rc, out = self.tree.run()
        self.assertEqual(rc, 1)
        self.assertIn("test_planes.cpp:1", out)

    def test_sibling_layers_fail(self):
        self.tree.write("drivers/player/include/pplvo/player/player.h", "#pragma once\n")
        self.tree.write("logs/logger/src/logger.cpp", '#include "pplvo/player/player.h"\n')
        rc, out = self.tree.run()
        self.assertEqual(rc, 1)
        self.assertIn("sibling layer", out)

    TARGETS = ("pplvo_core\tcore\t0\t\tcore/include\n"
               "pplvo_geometry\todometry\t0\tpplvo_core;Eigen3::Eigen\todometry/geometry/include\n"
               "pplvo_synth\ttools\t0\tpplvo_geometry\t\n"
               "pplvo_fixtures\tfixtures\t0\tpplvo_core\t\n")

    def test_links(self):
        rc, out = self.tree.run(self.TARGETS)
        self.assertEqual(rc, 0, out)
        rc, out = self.tree.run(self.TARGETS + "pplvo_bad\todometry\t0\tpplvo_synth\t\n")
        self.assertEqual(rc, 1)
        self.assertIn("target pplvo_bad (odometry) links pplvo_synth of tools (upward)", out)

    def test_fixture_links_only_from_test_targets(self):
        rc, out = self.tree.run(self.TARGETS + "test_geometry\todometry\t1\tpplvo_fixtures\t\n")
        self.assertEqual(rc, 0, out)
        rc, out = self.tree.run(self.TARGETS + "pplvo_lib\todometry\t0\tpplvo_fixtures\t\n")
        self.assertEqual(rc, 1)
        self.assertIn("links pplvo_fixtures of fixtures (test-only layer)", out)

    def test_include_directory_of_a_higher_folder_fails(self):
        rc, out = self.tree.run(self.TARGETS + "test_geometry\todometry\t1\t\ttools/synth/src\n")
        self.assertEqual(rc, 1)
        self.assertIn("adds include directory tools/synth/src", out)

    def test_allowlist(self):
        self.tree.write("odometry/geometry/src/planes.cpp", '#include "pplvo/synth/scene.h"\n')
        targets = self.TARGETS + "pplvo_bad\todometry\t0\tpplvo_synth\t\n"
        allow = ("# reason\ninclude odometry/geometry/src/planes.cpp pplvo/synth/scene.h\n"
                 "link pplvo_bad pplvo_synth  # reason\n")
        rc, out = self.tree.run(targets, allow)
        self.assertEqual(rc, 0, out)
        self.assertIn("2 allowlisted", out)
        # Only the listed pair passes: another upward include in the same file still fails.
        self.tree.write("odometry/geometry/src/planes.cpp",
                        '#include "pplvo/synth/scene.h"\n#include "pplvo/fixtures/room.h"\n')
        rc, out = self.tree.run(targets, allow)
        self.assertEqual(rc, 1)
        self.assertIn("pplvo/fixtures/room.h", out)
        self.assertNotIn("pplvo/synth/scene.h of", out)

    def test_stale_allowlist_entry_fails(self):
        rc, out = self.tree.run(self.TARGETS, "link pplvo_gone pplvo_synth\n")
        self.assertEqual(rc, 1)
        self.assertIn("no longer needed (remove it): link pplvo_gone pplvo_synth", out)

    def test_malformed_allowlist_is_a_usage_error(self):
        rc, _ = self.tree.run(None, "include only_two_fields\n")
        self.assertEqual(rc, 2)


if __name__ == "__main__":
    unittest.main()
