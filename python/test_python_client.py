#!/usr/bin/python3
"""End-to-end test of python/weavefit_submit.py against a real weavefitd.

Run by ctest (test python_client) with Debian's /usr/bin/python3 and, in the
environment, WEAVEFITD (the daemon binary), WEAVEFIT_STUBS (the generated
weavefit.v1 stubs, passed on to the script) and FIXTURES_DIR. The daemon
listens on an ephemeral loopback port (--listen 127.0.0.1:0 --port-file) and
is stopped, and the temporary folder removed, even when a test fails.
"""
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import unittest

from loopback_daemon import LoopbackDaemon

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "weavefit_submit.py")
FIXTURES = os.environ.get("FIXTURES_DIR", "")
# Four photographs: a sinusoid (PNG and EXR), a tilted sawtooth (TIFF) and a
# smooth cylinder, whose split the reply must call unresolved.
IMAGES = ("gauze_sinusoid_p10.png", "gauze_sinusoid_p30.exr", "saw_m020_p30_tilt.tiff",
          "smooth_p10.png")


def sidecar(name):
    with open(os.path.join(FIXTURES, os.path.splitext(name)[0] + ".json")) as f:
        return json.load(f)


class PythonClient(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.work = tempfile.mkdtemp(prefix="weavefit_python_client_")
        cls.addClassCleanup(shutil.rmtree, cls.work, ignore_errors=True)
        cls.photos = os.path.join(cls.work, "photos")
        os.mkdir(cls.photos)
        for name in IMAGES:
            for file in (name, os.path.splitext(name)[0] + ".json"):
                os.symlink(os.path.join(FIXTURES, file), os.path.join(cls.photos, file))
        cls.daemon = LoopbackDaemon(cls.work)
        cls.addClassCleanup(cls.daemon.stop)
        cls.server = cls.daemon.server

    def submit(self, *paths):
        """Runs the script; returns its exit code and its table as {file name: cells}."""
        run = subprocess.run([sys.executable, SCRIPT, "--server", self.server, *paths],
                             capture_output=True, text=True, timeout=100)
        lines = run.stdout.splitlines()
        self.assertTrue(lines and lines[0].startswith("file"), run.stdout + run.stderr)
        rows = {}
        for line in lines[1:]:
            if not line.strip():
                break  # the table ends here
            cells = re.split(r"\s{2,}", line.strip(), maxsplit=6)
            rows[os.path.basename(cells[0])] = cells
        return run.returncode, rows, run.stdout + run.stderr + self.daemon.log()

    def test_each_photograph_reads_near_its_truth(self):
        code, rows, output = self.submit(self.photos)
        self.assertEqual(code, 0, output)
        self.assertEqual(sorted(rows), sorted(IMAGES), output)
        for name in IMAGES:
            with self.subTest(name):
                truth = sidecar(name)["truth"]
                model, spacing, status = rows[name][1], rows[name][2], rows[name][6]
                self.assertTrue(status.startswith("OK"), rows[name])
                self.assertEqual(model, truth["model"], rows[name])
                if model == "SMOOTH":
                    self.assertTrue(spacing.startswith("unresolved"), rows[name])
                    continue
                value, stderr = (float(x) for x in spacing.split(" ± "))
                # As tests/e2e_test.cc: within what the reply claims, plus the
                # table's rounding.
                self.assertLessEqual(abs(value - truth["peakSpacingDeg"]), 3 * stderr + 0.25,
                                     rows[name])

    def test_a_broken_file_fails_with_invalid_argument(self):
        bad = os.path.join(self.work, "bad.png")
        with open(bad, "w") as f:
            f.write("this is not a photograph\n")
        # A sidecar too, so that the daemon, not the script, turns it down.
        shutil.copy(os.path.join(FIXTURES, "smooth_p10.json"), os.path.join(self.work, "bad.json"))
        good = os.path.join(self.photos, "smooth_p10.png")
        code, rows, output = self.submit(bad, good)
        self.assertEqual(code, 3, output)  # INVALID_ARGUMENT, the first failure's code
        self.assertTrue(rows["bad.png"][-1].startswith("FAILED INVALID_ARGUMENT: "), output)
        self.assertNotIn("no phase angle", rows["bad.png"][-1])
        self.assertTrue(rows["smooth_p10.png"][-1].startswith("OK"), output)
        self.assertIsNone(self.daemon.poll(), "bad input must never stop the daemon")


if __name__ == "__main__":
    unittest.main(verbosity=2)
