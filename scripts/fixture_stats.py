#!/usr/bin/env python3
"""Accuracy of `weavefit estimate` on the fixtures against their truth sidecars.

Usage: scripts/fixture_stats.py [-v] [MODE ...]   (default: fast balanced accurate)
Needs the built client (build/client/weavefit); standard library only.
One line per mode: models right, peak-spacing error (median, 90th percentile,
max) where the split is resolvable, share within 3 stated standard errors,
max-slope, wavelength and amplitude relative errors (median), and the median
in-process time per fixture (sum of the reply's stage timings). With -v, also
one line per fixture: method, spacing error and its stated error, time.
"""
import glob
import json
import os
import statistics
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CLIENT = os.path.join(ROOT, "build", "client", "weavefit")


def quantile(values, p):
    if not values:
        return float("nan")
    values = sorted(values)
    return values[min(len(values) - 1, int(p * len(values)))]


def median(values):
    return statistics.median(values) if values else float("nan")


def main(modes, verbose=False):
    images = sorted(f for f in glob.glob(os.path.join(ROOT, "fixtures", "*"))
                    if not f.endswith((".json", ".sh")))
    for mode in modes:
        spacing, slope, wavelength, amplitude, times, wrong = [], [], [], [], [], []
        right = total = covered = compared = 0
        for image in images:
            truth = json.load(open(os.path.splitext(image)[0] + ".json"))["truth"]
            out = subprocess.run([CLIENT, "estimate", image, "--json", "--mode", mode],
                                 capture_output=True, text=True).stdout.splitlines()
            if not out:
                continue
            e = json.loads(out[0])
            total += 1
            name = os.path.basename(image)
            if "error" in e:
                wrong.append(name + ": error")
                continue
            if e["model"] == truth["model"]:
                right += 1
            else:
                wrong.append(name + ": " + e["model"])
            times.append(sum(s["milliseconds"] for s in e["timings"]))
            if (truth["splitResolvable"] and truth["model"] != "SMOOTH"
                    and e["peakSpacingDeg"]["resolved"]):
                error = abs(e["peakSpacingDeg"]["value"] - truth["peakSpacingDeg"])
                spacing.append(error)
                compared += 1
                covered += error <= 3 * e["peakSpacingDeg"]["stderr"]
                slope.append(abs(e["maxSlope"]["value"] / truth["maxSlope"] - 1))
                if verbose:
                    print(f"  {name:32s} {e['method']:14s} spacing "
                          f"{e['peakSpacingDeg']['value'] - truth['peakSpacingDeg']:+.3f} "
                          f"± {e['peakSpacingDeg']['stderr']:.3f} deg  {times[-1]:.0f} ms")
            if e["wavelengthMm"]["resolved"]:
                wavelength.append(abs(e["wavelengthMm"]["value"] / truth["wavelengthMm"] - 1))
            if e["amplitudeMm"]["resolved"]:
                amplitude.append(abs(e["amplitudeMm"]["value"] / truth["amplitudeMm"] - 1))
        print(f"{mode}: model {right}/{total}; spacing |err| median {median(spacing):.2f}, "
              f"p90 {quantile(spacing, 0.9):.2f}, max {max(spacing, default=float('nan')):.2f} deg "
              f"(n={len(spacing)}); within 3 stderr {covered}/{compared}; max slope rel. median "
              f"{100 * median(slope):.2f}%; wavelength resolved {len(wavelength)}, rel. median "
              f"{100 * median(wavelength):.2f}%; amplitude rel. median {100 * median(amplitude):.2f}%; "
              f"median time {median(times):.0f} ms; wrong: {', '.join(wrong) or 'none'}")


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if a != "-v"]
    main(args or ["fast", "balanced", "accurate"], verbose="-v" in sys.argv[1:])
