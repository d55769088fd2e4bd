#!/usr/bin/env python3
"""Are the stated errors honest? Repeated noise draws of the fixture scenes.

Usage: scripts/noise_draws.py [-n DRAWS] [-m MODE] [-j JOBS] [-v] [FIXTURE ...]
  (default: 8 draws, balanced, every fixture with a truth sidecar)

Each fixture's sidecar holds the scene it was rendered from. This renders the
scene again with DRAWS other seeds (`weavefit render --scene SIDECAR --seed S`:
new sensor noise and a new realisation of the weave's irregular phases, as a
second patch of the same cloth gives), estimates each draw (`weavefit estimate
--json --mode MODE`) and compares with the truth, quantity by quantity (peak
spacing, max slope, wavelength, amplitude, where the truth resolves them):

  coverage  the share of draws with |error| <= 3 stated errors (issue 5: >= 90 %)
  spread    the standard deviation of the errors over the draws, divided by
            the rms stated error, and by the rms of its statistical share
            (Measurement.statistical: what repeated photographs of one set-up
            should spread by; issue 5: within a factor 1.5 of 1). Read over
            the draws that the most frequent method answered (column n), so
            that a fallback's different bias does not count as scatter
  bias      the mean error of those draws, in stated errors
  rms z     the root mean square of error / stated error (1 for errors that
            are as large as stated, bias included)

One line per fixture and quantity with -v; the summary always. Needs the built
client (build/client/weavefit); standard library only.
"""
import argparse
import concurrent.futures
import glob
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CLIENT = os.path.join(ROOT, "build", "client", "weavefit")
QUANTITIES = [  # reply field, truth field, relative?
    ("peakSpacingDeg", "peakSpacingDeg", False),
    ("maxSlope", "maxSlope", True),
    ("wavelengthMm", "wavelengthMm", True),
    ("amplitudeMm", "amplitudeMm", True),
]


def run_draw(sidecar, seed, mode, workdir, extra):
    """Renders one draw and estimates it; returns (reply, truth) or an error."""
    stem = os.path.splitext(os.path.basename(sidecar))[0]
    image = json.load(open(sidecar))["image"]
    ext = os.path.splitext(image)[1]
    out = os.path.join(workdir, "%s_s%d%s" % (stem, seed, ext))
    fmt = []
    if ext == ".png":
        # 8-bit sRGB fixtures say so in their name; the rest are 16-bit.
        with open(os.path.join(ROOT, "fixtures", image), "rb") as f:
            head = f.read(25)
        if head[24] == 8:
            fmt = ["--format", "png8"]
    r = subprocess.run([CLIENT, "render", "--scene", sidecar, "--seed", str(seed), "--out", out]
                       + fmt + extra, capture_output=True, text=True)
    if r.returncode != 0:
        return None, None, "render: " + r.stderr.strip()
    truth = json.load(open(os.path.splitext(out)[0] + ".json"))["truth"]
    e = subprocess.run([CLIENT, "estimate", out, "--json", "--mode", mode],
                       capture_output=True, text=True).stdout.splitlines()
    for f in (out, os.path.splitext(out)[0] + ".json"):
        os.remove(f)
    if not e:
        return None, truth, "no reply"
    reply = json.loads(e[0])
    if "error" in reply:
        return None, truth, reply["error"]["message"]
    return reply, truth, None


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("fixtures", nargs="*")
    ap.add_argument("-n", "--draws", type=int, default=8)
    ap.add_argument("-m", "--mode", default="balanced")
    ap.add_argument("-j", "--jobs", type=int, default=os.cpu_count() or 2)
    ap.add_argument("-v", "--verbose", action="store_true")
    ap.add_argument("--seed0", type=int, default=5000)
    ap.add_argument("--render", default="",
                    help="more `weavefit render` flags, e.g. '--samples 16' (quoted)")
    args = ap.parse_args()
    sidecars = sorted(glob.glob(os.path.join(ROOT, "fixtures", "*.json")))
    if args.fixtures:
        wanted = {os.path.splitext(os.path.basename(f))[0] for f in args.fixtures}
        sidecars = [s for s in sidecars if os.path.splitext(os.path.basename(s))[0] in wanted]
    work = tempfile.mkdtemp(prefix="weavefit_draws_")
    jobs = [(s, args.seed0 + k) for s in sidecars for k in range(args.draws)]
    with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
        results = list(pool.map(lambda j: run_draw(j[0], j[1], args.mode, work, args.render.split()), jobs))
    os.rmdir(work)

    per = {}  # (fixture, quantity) -> list of (error, stderr)
    failures = []
    for (sidecar, seed), (reply, truth, err) in zip(jobs, results):
        name = os.path.splitext(os.path.basename(sidecar))[0]
        if err:
            failures.append("%s seed %d: %s" % (name, seed, err))
            continue
        for field, tfield, rel in QUANTITIES:
            q = reply.get(field, {})
            t = truth.get(tfield, 0.0)
            if field in ("peakSpacingDeg", "maxSlope"):
                if not truth["splitResolvable"] or truth["model"] == "SMOOTH":
                    continue
            elif not truth.get("periodResolvable") or truth["model"] != "SINUSOID":
                continue
            if not q.get("resolved") or not t:
                continue
            scale = t if rel else 1.0
            method = next((c.get("method", "") for c in reply.get("candidates", [])
                           if c.get("selected")), "")
            per.setdefault((name, field), []).append(
                ((q["value"] - t) / scale, q["stderr"] / scale,
                 q.get("statistical", 0.0) / scale, method))

    print("%d fixtures x %d draws, mode %s; %d failed draws" %
          (len(sidecars), args.draws, args.mode, len(failures)))
    for f in failures:
        print("  failed: " + f)
    if args.verbose:
        print("%-28s %-15s %3s %10s %10s %10s %7s %10s %8s %6s %8s %6s" %
              ("fixture", "quantity", "n", "mean err", "sd err", "rms se", "sd/se", "rms stat",
               "sd/stat", "cover", "bias/se", "rms z"))
    for field, _, rel in QUANTITIES:
        covered = total = 0
        ratios = []
        stat_ratios = []
        zs = []
        for (name, f), draws in sorted(per.items()):
            if f != field:
                continue
            cov = sum(abs(e) <= 3 * s for e, s, _, _ in draws)
            covered += cov
            total += len(draws)
            z = math.sqrt(statistics.fmean([(e / s) ** 2 for e, s, _, _ in draws if s > 0] or [0.0]))
            # The spread is read over the draws the most frequent method
            # answered: a draw another method answered (peak picking where
            # the comb fit gave up) has its own error and its own bias, and
            # would count the difference between the methods as scatter.
            methods = [d[3] for d in draws]
            common = max(set(methods), key=methods.count)
            same = [d for d in draws if d[3] == common]
            errs = [d[0] for d in same]
            ses = [d[1] for d in same]
            stats = [d[2] for d in same]
            rms_se = math.sqrt(sum(s * s for s in ses) / len(ses))
            rms_stat = math.sqrt(sum(s * s for s in stats) / len(stats))
            sd = statistics.stdev(errs) if len(errs) > 1 else float("nan")
            mean = statistics.fmean(errs)
            if len(errs) >= 4 and rms_se > 0:
                ratios.append((sd / rms_se, name))
                zs.append(z)
            if len(errs) >= 4 and rms_stat > 0:
                stat_ratios.append(sd / rms_stat)
            if args.verbose:
                unit = "rel" if rel else "deg" if "Deg" in field else "mm"
                print("%-28s %-15s %3d %10.3g %10.3g %10.3g %7.2f %10.3g %8.2f %3d/%-2d %8.2f %6.2f  %s" %
                      (name, field, len(errs), mean, sd, rms_se,
                       sd / rms_se if rms_se else float("nan"), rms_stat,
                       sd / rms_stat if rms_stat else float("nan"), cov, len(draws),
                       mean / rms_se if rms_se else float("nan"), z, unit))
        if not total or not ratios:
            continue
        within = sum(1 for r, _ in ratios if 1 / 1.5 <= r <= 1.5)
        rs = sorted(r for r, _ in ratios)
        print("%-15s coverage %d/%d = %.1f %%; sd/stated error median %.2f (range %.2f-%.2f), "
              "within 1.5x on %d/%d fixtures; rms z median %.2f" %
              (field, covered, total, 100.0 * covered / total, statistics.median(rs),
               rs[0], rs[-1], within, len(rs), statistics.median(zs)))
        if stat_ratios:
            ss = sorted(stat_ratios)
            print("%-15s sd/statistical share median %.2f (range %.2f-%.2f), within 1.5x on "
                  "%d/%d fixtures" %
                  ("", statistics.median(ss), ss[0], ss[-1],
                   sum(1 for r in ss if 1 / 1.5 <= r <= 1.5), len(ss)))


if __name__ == "__main__":
    sys.exit(main())
