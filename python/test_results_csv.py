#!/usr/bin/python3
"""The results CSV of `weavefit submit fixtures/ --out r.csv` loads as it is.

Run by ctest (test results_csv) with Debian's /usr/bin/python3, which has
python3-numpy and python3-pandas, and, in the environment, WEAVEFIT (the
client), WEAVEFITD (the daemon) and FIXTURES_DIR. Every fixture and one
photograph that cannot be decoded (with a sidecar, so that it is asked for)
are submitted to a real weavefitd on an ephemeral loopback port. The file
must read, without options beyond the delimiter, in the standard library's
csv module, numpy.genfromtxt and pandas.read_csv, with one row per
photograph (the failed one too) that says what was asked.
"""
import csv
import glob
import json
import os
import shutil
import subprocess
import tempfile
import unittest

import numpy
import pandas

from loopback_daemon import LoopbackDaemon

FIXTURES = os.environ.get("FIXTURES_DIR", "")
BROKEN = "not_a_photograph.png"


class ResultsCsv(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.work = tempfile.mkdtemp(prefix="weavefit_results_csv_")
        cls.addClassCleanup(shutil.rmtree, cls.work, ignore_errors=True)
        photos = os.path.join(cls.work, "fixtures")
        os.mkdir(photos)
        cls.sidecars = {}
        for path in sorted(glob.glob(os.path.join(FIXTURES, "*"))):
            os.symlink(path, os.path.join(photos, os.path.basename(path)))
            if path.endswith(".json"):
                with open(path) as f:
                    cls.sidecars[os.path.splitext(os.path.basename(path))[0]] = json.load(f)
        with open(os.path.join(photos, BROKEN), "wb") as f:
            f.write(b"\x89PNG\r\n\x1a\n" + b"\0" * 64)
        with open(os.path.join(photos, "not_a_photograph.json"), "w") as f:
            json.dump({"acquisition": {"phaseAngleDeg": 10.0, "cylinderDiameterMm": 46.0}}, f)
        cls.photographs = len(cls.sidecars) + 1
        cls.daemon = LoopbackDaemon(cls.work)
        cls.addClassCleanup(cls.daemon.stop)
        server = cls.daemon.server
        cls.csv = os.path.join(cls.work, "r.csv")
        cls.submitted = subprocess.run(
            [os.environ["WEAVEFIT"], "submit", photos, "--server", server, "--out", cls.csv,
             "--quiet"],
            capture_output=True, text=True, timeout=300)

    def test_the_standard_librarys_csv_reads_every_photograph(self):
        self.assertNotEqual(self.submitted.returncode, 0, "the broken photograph fails the batch")
        with open(self.csv, newline="") as f:
            rows = list(csv.DictReader(f))
        self.assertEqual(len(rows), self.photographs, self.submitted.stderr)
        by_stem = {os.path.splitext(os.path.basename(r["image"]))[0]: r for r in rows}
        failed = by_stem["not_a_photograph"]
        self.assertNotEqual(failed["status"], "OK")
        self.assertEqual(float(failed["phase_angle_deg"]), 10.0)  # what was asked
        self.assertTrue(failed["weavefit_version"])
        for stem, sidecar in self.sidecars.items():
            row = by_stem[stem]
            self.assertEqual(row["status"], "OK", row)
            self.assertAlmostEqual(float(row["phase_angle_deg"]),
                                   sidecar["acquisition"]["phaseAngleDeg"], places=6)
            self.assertAlmostEqual(float(row["cylinder_diameter_mm"]),
                                   sidecar["acquisition"]["cylinderDiameterMm"], places=6)
            self.assertEqual(row["mode"], "balanced")
            self.assertTrue(row["weavefit_version"])

    def test_numpy_genfromtxt_reads_it_with_the_delimiter_alone(self):
        table = numpy.genfromtxt(self.csv, delimiter=",", names=True, dtype=None,
                                 encoding=None)
        self.assertEqual(table.shape, (self.photographs,))
        self.assertIn("peak_spacing_deg", table.dtype.names)
        self.assertTrue(numpy.issubdtype(table["phase_angle_deg"].dtype, numpy.number))
        self.assertTrue(numpy.issubdtype(table["peak_spacing_deg"].dtype, numpy.floating))
        self.assertEqual(int(numpy.sum(table["status"] == "OK")), self.photographs - 1)

    def test_pandas_reads_it_without_options(self):
        table = pandas.read_csv(self.csv)
        self.assertEqual(len(table), self.photographs)
        self.assertEqual(int((table["status"] == "OK").sum()), self.photographs - 1)
        self.assertTrue(pandas.api.types.is_float_dtype(table["peak_spacing_deg"]))
        self.assertEqual(set(table["mode"].dropna()), {"balanced"})


if __name__ == "__main__":
    unittest.main()
