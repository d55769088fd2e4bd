#!/usr/bin/env python3
"""Does the joint estimate beat the best single photograph? Repeated draws.

Usage: scripts/joint_draws.py [-n DRAWS] [--seed0 S] [--angles A,B,C] [SIDECAR]
  (default: 64 draws of fixtures/gauze_sinusoid_p10.json at 10, 60, -110 deg)

For each seed this renders the sidecar's scene at each phase angle (`weavefit
render --scene SIDECAR --seed S --phase-angle A`: one sample, so the same
weave, photographed at several angles with new sensor noise), estimates them
together (`weavefit estimate ... --joint --json`) and compares each single
photograph's and the joint estimate's peak spacing and wavelength with the
truth. Per photograph and for the joint: the rms error, its mean and spread,
and the rms stated error and statistical share. The joint beats the best
single photograph when its rms error is the smaller. Needs the built client
(build/client/weavefit); standard library only.
"""
import argparse
import concurrent.futures
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CLIENT = os.path.join(ROOT, "build", "client", "weavefit")


def diameter_mm(sidecar):
    """The cylinder's diameter the scene states (its sidecar's acquisition)."""
    with open(sidecar) as f:
        return json.load(f)["acquisition"]["cylinderDiameterMm"]


def run_seed(sidecar, seed, angles, workdir):
    """Renders the scene at each angle and estimates them jointly."""
    images = []
    for a in angles:
        out = os.path.join(workdir, "s%d_a%g.png" % (seed, a))
        subprocess.run([CLIENT, "render", "--scene", sidecar, "--seed", str(seed),
                        "--phase-angle", str(a), "--out", out], check=True, capture_output=True)
        images.append(out)
    r = subprocess.run([CLIENT, "estimate"] + images +
                       ["--phase-angle", ",".join("%g" % a for a in angles),
                        "--diameter-mm", "%g" % diameter_mm(sidecar), "--joint", "--json"],
                       capture_output=True, text=True)
    for out in images:
        for f in (out, os.path.splitext(out)[0] + ".json"):
            if os.path.exists(f):
                os.remove(f)
    lines = [json.loads(l) for l in r.stdout.splitlines() if l.strip()]
    if len(lines) != len(angles) + 1 or "joint" not in lines[-1]:
        return None
    return lines[:-1] + [lines[-1]["joint"]]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sidecar", nargs="?",
                    default=os.path.join(ROOT, "fixtures", "gauze_sinusoid_p10.json"))
    ap.add_argument("-n", "--draws", type=int, default=64)
    ap.add_argument("--seed0", type=int, default=100)
    ap.add_argument("--angles", default="10,60,-110")
    ap.add_argument("-j", "--jobs", type=int, default=os.cpu_count() or 2)
    args = ap.parse_args()
    angles = [float(a) for a in args.angles.split(",")]
    truth = json.load(open(args.sidecar))["truth"]
    work = tempfile.mkdtemp(prefix="weavefit_joint_")
    seeds = range(args.seed0, args.seed0 + args.draws)
    with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
        results = list(pool.map(lambda s: run_seed(args.sidecar, s, angles, work), seeds))
    os.rmdir(work)
    failed = sum(r is None for r in results)
    print("%s at %s deg, %d draws (%d failed)" %
          (os.path.basename(args.sidecar), args.angles, args.draws, failed))
    names = ["%g deg" % a for a in angles] + ["joint"]
    for field, rel in (("peakSpacingDeg", False), ("wavelengthMm", True)):
        t = truth.get(field)
        if not t:
            continue
        scale = 100.0 / t if rel else 1.0
        unit = "%" if rel else "deg"
        print("%s (%s)   %8s %9s %8s %8s %8s %3s" %
              (field, unit, "rms err", "mean", "sd", "rms se", "rms stat", "n"))
        for k, name in enumerate(names):
            errs, ses, stats = [], [], []
            for r in results:
                if r is None or not r[k].get(field, {}).get("resolved"):
                    continue
                q = r[k][field]
                errs.append((q["value"] - t) * scale)
                ses.append(q["stderr"] * scale)
                stats.append(q.get("statistical", 0.0) * scale)
            if len(errs) < 2:
                print("  %-10s unresolved" % name)
                continue
            rms = lambda v: math.sqrt(statistics.fmean([x * x for x in v]))
            print("  %-10s %18.5f %+9.5f %8.5f %8.5f %8.5f %3d" %
                  (name, rms(errs), statistics.fmean(errs), statistics.stdev(errs), rms(ses),
                   rms(stats), len(errs)))


if __name__ == "__main__":
    sys.exit(main())
