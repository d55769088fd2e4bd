#!/usr/bin/python3
"""The weavefit Python package, installed offline and used against a real weavefitd.

Run by ctest (test python_package) with Debian's /usr/bin/python3 and, in the
environment, WEAVEFITD (the daemon binary) and FIXTURES_DIR. The checkout's
python/ and proto/ are copied to a temporary folder (the build writes build/
and an .egg-info beside its sources), a venv with --system-site-packages (for
Debian's python3-grpcio, python3-protobuf, python3-grpc-tools) is made there,
and the package is installed with `pip install --no-build-isolation
--no-index`, without pip's configuration, so nothing comes from an index or a
wheel folder. A script run with the venv's interpreter, from a folder that
holds no sources, then estimates photographs on a daemon on an ephemeral
loopback port and prints what it got as JSON; the assertions are made here.
The daemon is stopped, and the temporary folder removed, even when a test
fails.
"""
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import textwrap
import unittest

from loopback_daemon import LoopbackDaemon

HERE = os.path.dirname(os.path.abspath(__file__))
CHECKOUT = os.path.dirname(HERE)
FIXTURES = os.environ.get("FIXTURES_DIR", os.path.join(CHECKOUT, "fixtures"))
SINUSOID, SMOOTH = "gauze_sinusoid_p10.png", "smooth_p10.png"

# Run with the venv's interpreter: argv = server, photographs folder, a port
# nothing listens on. Prints one JSON object.
CHECK = textwrap.dedent("""
    import json, os, sys
    import grpc
    import weavefit
    from weavefit.v1 import weavefit_pb2

    server, photos, dead = sys.argv[1:4]
    out = {"module": weavefit.__file__, "stubs": weavefit_pb2.__file__}

    def failure(call):
        try:
            call()
        except weavefit.EstimateError as e:
            return {"code": e.code.name, "message": e.message,
                    "is_status": isinstance(e.code, grpc.StatusCode)}
        return None

    with weavefit.Client(server, timeout_s=60) as client:
        for name in ("gauze_sinusoid_p10.png", "smooth_p10.png"):
            r = client.estimate(os.path.join(photos, name))
            d = r.to_dict()
            d["types"] = {"result": type(r).__name__, "spacing": type(r.peak_spacing_deg).__name__,
                          "reply": type(r.reply).__name__}
            json.dumps(d)  # to_dict is JSON as it is
            try:
                r.model = "changed"
                d["frozen"] = False
            except Exception:
                d["frozen"] = True
            out[name] = d
        with open(os.path.join(photos, "gauze_sinusoid_p10.png"), "rb") as f:
            png = f.read()
        # Bytes with the phase angle and no diameter: wavelength unresolved.
        r = client.estimate(png, phase_angle_deg=10.0, sample_name="bytes", filename="b.png",
                            mode="BALANCED")
        out["bytes_no_diameter"] = r.to_dict()
        out["no_phase_path"] = failure(
            lambda: client.estimate(os.path.join(photos, "no_sidecar.png")))
        out["no_phase_bytes"] = failure(lambda: client.estimate(png))
        out["not_a_photograph"] = failure(
            lambda: client.estimate(b"not a photograph", phase_angle_deg=10.0))
        out["missing_file"] = failure(
            lambda: client.estimate(os.path.join(photos, "missing.png"), phase_angle_deg=10.0))
    with weavefit.Client(dead, timeout_s=5, retries=1, backoff_s=0.05) as client:
        out["unavailable"] = failure(lambda: client.estimate(png, phase_angle_deg=10.0))
    print(json.dumps(out))
""")


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class PythonPackage(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.work = tempfile.mkdtemp(prefix="weavefit_python_package_")
        cls.addClassCleanup(shutil.rmtree, cls.work, ignore_errors=True)
        src = os.path.join(cls.work, "src")
        ignore = shutil.ignore_patterns("build", "*.egg-info", "__pycache__")
        shutil.copytree(HERE, os.path.join(src, "python"), ignore=ignore)
        shutil.copytree(os.path.join(CHECKOUT, "proto"), os.path.join(src, "proto"), ignore=ignore)
        venv = os.path.join(cls.work, "venv")
        cls.python = os.path.join(venv, "bin", "python")
        env = {k: v for k, v in os.environ.items() if not k.startswith("PIP_")}
        env["PIP_CONFIG_FILE"] = os.devnull  # no find-links, no index from a config
        cls.install = subprocess.run(
            [sys.executable, "-m", "venv", "--system-site-packages", venv], capture_output=True,
            text=True, timeout=120)
        if cls.install.returncode == 0:
            cls.install = subprocess.run(
                [cls.python, "-m", "pip", "install", "--no-build-isolation", "--no-index",
                 "--disable-pip-version-check", "./python"],
                cwd=src, env=env, capture_output=True, text=True, timeout=240)
        if cls.install.returncode != 0:
            raise RuntimeError("install failed:\n" + cls.install.stdout + cls.install.stderr)

        cls.photos = os.path.join(cls.work, "photos")
        os.mkdir(cls.photos)
        for name in (SINUSOID, SMOOTH):
            for file in (name, os.path.splitext(name)[0] + ".json"):
                os.symlink(os.path.join(FIXTURES, file), os.path.join(cls.photos, file))
        os.symlink(os.path.join(FIXTURES, SINUSOID), os.path.join(cls.photos, "no_sidecar.png"))

        cls.daemon = LoopbackDaemon(cls.work)
        cls.addClassCleanup(cls.daemon.stop)
        cls.server = cls.daemon.server

        script = os.path.join(cls.work, "check.py")
        with open(script, "w") as f:
            f.write(CHECK)
        cls.run_dir = os.path.join(cls.work, "run")  # no sources here: the installed package
        os.mkdir(cls.run_dir)
        check = subprocess.run(
            [cls.python, script, cls.server, cls.photos, f"127.0.0.1:{free_port()}"],
            cwd=cls.run_dir, capture_output=True, text=True, timeout=200)
        if check.returncode != 0:
            raise RuntimeError("check script failed:\n" + check.stdout + check.stderr +
                               cls.daemon.log())
        cls.out = json.loads(check.stdout)

    def test_installed_offline_with_generated_stubs(self):
        self.assertIn("Successfully installed weavefit", self.install.stdout)
        site = os.path.join(self.work, "venv", "lib")
        self.assertTrue(self.out["module"].startswith(site), self.out["module"])
        self.assertTrue(self.out["stubs"].startswith(site), self.out["stubs"])
        self.assertTrue(self.out["stubs"].endswith(os.path.join("weavefit", "v1",
                                                                "weavefit_pb2.py")))

    def test_the_source_tree_carries_no_stubs(self):
        generated = [os.path.join(d, n) for d, _, names in os.walk(os.path.join(HERE, "src"))
                     for n in names if n.endswith(("_pb2.py", "_pb2_grpc.py"))]
        self.assertEqual(generated, [])

    def test_each_fixture_reads_near_its_truth(self):
        for name in (SINUSOID, SMOOTH):
            with self.subTest(name):
                with open(os.path.join(FIXTURES, os.path.splitext(name)[0] + ".json")) as f:
                    sidecar = json.load(f)
                truth, r = sidecar["truth"], self.out[name]
                self.assertEqual(r["types"], {"result": "Result", "spacing": "Measurement",
                                              "reply": "EstimateReply"})
                self.assertTrue(r["frozen"])
                self.assertEqual(r["model"], truth["model"], r)
                self.assertEqual(r["filename"], name)
                self.assertEqual(r["sample_name"], name)
                self.assertEqual(r["mode"], "balanced")
                self.assertTrue(r["version"])
                # The acquisition came from the sidecar.
                self.assertEqual(r["phase_angle_deg"], sidecar["acquisition"]["phaseAngleDeg"])
                self.assertEqual(r["diameter_mm"], sidecar["acquisition"]["cylinderDiameterMm"])
                spacing = r["peak_spacing_deg"]
                if not truth["splitResolvable"]:
                    self.assertFalse(spacing["resolved"], r)
                    self.assertGreater(spacing["upper_bound"], 0, r)
                    continue
                self.assertTrue(spacing["resolved"], r)
                self.assertGreater(spacing["stderr"], 0, r)
                self.assertLessEqual(abs(spacing["value"] - truth["peakSpacingDeg"]),
                                     3 * spacing["stderr"], r)
                self.assertTrue(r["wavelength_mm"]["resolved"], r)

    def test_bytes_without_a_diameter_leave_the_wavelength_unresolved(self):
        r = self.out["bytes_no_diameter"]
        self.assertEqual(r["model"], "SINUSOID", r)
        self.assertEqual((r["filename"], r["sample_name"], r["mode"]),
                         ("b.png", "bytes", "balanced"))
        self.assertEqual(r["diameter_mm"], 0.0)
        self.assertTrue(r["peak_spacing_deg"]["resolved"], r)
        self.assertFalse(r["wavelength_mm"]["resolved"], r)
        self.assertFalse(r["amplitude_mm"]["resolved"], r)
        self.assertTrue(any("radii" in w for w in r["warnings"]), r["warnings"])

    def test_no_phase_angle_raises_before_any_call(self):
        for case in ("no_phase_path", "no_phase_bytes"):
            with self.subTest(case):
                e = self.out[case]
                self.assertIsNotNone(e, case)
                self.assertEqual(e["code"], "INVALID_ARGUMENT", e)
                self.assertIn("no phase angle", e["message"])
        self.assertIn("no_sidecar.json", self.out["no_phase_path"]["message"])

    def test_failures_raise_estimate_error_with_the_status_code(self):
        e = self.out["not_a_photograph"]  # the daemon turns it down
        self.assertEqual(e["code"], "INVALID_ARGUMENT", e)
        self.assertNotIn("no phase angle", e["message"])
        self.assertTrue(e["is_status"])
        self.assertEqual(self.out["missing_file"]["code"], "NOT_FOUND")
        e = self.out["unavailable"]  # retried once, then raised
        self.assertEqual(e["code"], "UNAVAILABLE", e)
        self.assertIn("after 2 attempts", e["message"])
        self.assertIsNone(self.daemon.poll(), "bad input must never stop the daemon")

    def test_the_example_script_runs(self):
        example = os.path.join(self.work, "src", "python", "examples", "estimate_one.py")
        run = subprocess.run([self.python, example, self.server,
                              os.path.join(self.photos, SINUSOID), "--json", "--mode", "fast"],
                             cwd=self.run_dir, capture_output=True, text=True, timeout=100)
        self.assertEqual(run.returncode, 0, run.stdout + run.stderr)
        r = json.loads(run.stdout)
        self.assertEqual((r["model"], r["mode"]), ("SINUSOID", "fast"), r)
        run = subprocess.run([self.python, example, self.server,
                              os.path.join(self.photos, "no_sidecar.png")],
                             cwd=self.run_dir, capture_output=True, text=True, timeout=100)
        self.assertEqual(run.returncode, 3, run.stdout + run.stderr)  # INVALID_ARGUMENT
        self.assertIn("no phase angle", run.stderr)


if __name__ == "__main__":
    unittest.main(verbosity=2)
