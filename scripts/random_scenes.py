#!/usr/bin/env python3
"""Photographs weavefit has never seen: random scenes, rendered, estimated, checked.

Usage: scripts/random_scenes.py FIRST LAST [--out DIR] [--noisy] [--lens-blur PX]
                                [-j JOBS] [--mode MODE] [--outer-caustic LO HI] [--lab]
                                [--scale F]

Seeds FIRST..LAST-1 each pick a scene at random (the seed fixes it, so a
failure can be rendered again): sinusoid, sawtooth or smooth; max slope
0.05-0.7; wavelength 0.6-4.4 mm; |phase angle| 5-120 deg, either side;
320x240 to 1024x768; the cylinder's radius 25-45 % of the width, its axis
within 4 % of the middle; 3,000-50,000 photons full scale (--noisy: 300-3,000
and read noise 0.001-0.01); source blur 0.3-1.5 deg; exposure 0.002-0.012;
PNG 16-bit, PNG 8-bit sRGB, TIFF, EXR or JPEG; and, each with probability
0.2-0.3, a Lambertian term, axis tilt, lens blur 0.3-1.2 px (--lens-blur:
always that sigma), perspective at 500-2000 mm and vignetting.

--lab adds what lab photographs do (issue 31), drawn from a second random
stream so that a seed's scene without --lab is the same as before: stray light
on the whole body (0.005-0.08 of full scale, relief texture 0.3-0.8), an
ambient level 0-0.03 and a background 0-0.05; and, each with probability
0.4-0.7, axial threads glinting as lines (width 0.05-0.3 of lambda/2, half of
them floating over every other thread), a background gradient (up to 0.03
across the frame, any direction), a black-level pedestal (0.002-0.03) and the
cylinder's ends with a mount inside the frame; and, with probability 0.5, a
12-bit sensor's codes stored shifted up in a 16-bit PNG or TIFF (clipping at
65520).

--scale F renders the same scenes F times larger in pixels (the lens blur
stays in pixels): how the estimator fares on photographs of other sizes.

Each is rendered (`weavefit render`), estimated (`weavefit estimate --json`,
with the phase angle and camera distance the lab would state) and compared
with the render's truth sidecar. A line per seed:

  ok     the model right (or a split the truth calls unresolvable), and the
         spacing and wavelength, where resolved, within 3 stated errors
  BAD    a wrong model or a number beyond 3 stated errors: a wrong confident
         answer, the worst outcome (the scene's flags follow on the next line)
  ERROR  a refusal, with its message (a refusal is not wrong, but it may be
         needless)

and a count at the end. Not part of the test suite: the scenes are random and
some lie beyond what the estimator resolves (README, "Known limits"). Needs
the built client (build/client/weavefit); standard library only.
"""
import argparse
import concurrent.futures
import json
import math
import os
import random
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
WEAVEFIT = os.path.join(ROOT, "build", "client", "weavefit")
EXTENSIONS = {"png": "png", "png8": "png", "tiff": "tiff", "exr": "exr", "jpeg": "jpg"}


def lab_flags(seed, height, sixteen_bit):
    """The --lab conditions of seed's scene: their own random stream."""
    r = random.Random("lab%d" % seed)
    flags = ["--stray-light", "%.4f" % r.uniform(0.005, 0.08),
             "--stray-texture", "%.2f" % r.uniform(0.3, 0.8),
             "--ambient", "%.4f" % r.uniform(0.0, 0.03),
             "--background", "%.4f" % r.uniform(0.0, 0.05)]
    if r.random() < 0.7:
        flags += ["--axial-glint-width", "%.3f" % r.uniform(0.05, 0.3)]
        if r.random() < 0.5:
            flags += ["--axial-float-width", "%.2f" % r.uniform(0.2, 0.5)]
    if r.random() < 0.6:
        flags += ["--background-gradient", "%.4f" % r.uniform(-0.03, 0.03),
                  "--background-gradient-deg", "%.0f" % r.uniform(0, 360)]
    if r.random() < 0.6:
        flags += ["--black-level", "%.4f" % r.uniform(0.002, 0.03)]
    if r.random() < 0.4:
        flags += ["--top-row", "%d" % round(height * r.uniform(0.05, 0.2)),
                  "--bottom-row", "%d" % round(height * r.uniform(0.8, 0.95)),
                  "--mount-level", "%.3f" % r.uniform(0.02, 0.1),
                  "--mount-half-width", "%.2f" % r.uniform(0.6, 1.5)]
    if r.random() < 0.5 and sixteen_bit:
        # A 12-bit sensor's codes shifted up into the 16-bit file.
        flags += ["--white-level", "0.99977"]
    return flags


def scene_flags(seed, noisy, lens_blur, lab=False, scale=1.0):
    """The render flags of seed's scene, and its phase angle and distance.

    `scale` multiplies the frame and everything placed in pixels (the
    cylinder, the ends); the lens blur stays in pixels, as a camera with
    more pixels behind the same kind of lens has it."""
    r = random.Random(seed)
    model = r.choice(["smooth", "sinusoid", "sinusoid", "sawtooth", "sawtooth"])
    m = r.uniform(0.05, 0.7)
    lam = r.choice([0.6, 1.0, 1.5, 2.0, 2.88, 4.0]) * r.uniform(0.9, 1.1)
    h0 = m * lam / (2 * math.pi) if model == "sinusoid" else m * lam / 4
    alpha = r.choice([-1, 1]) * r.uniform(5, 120)
    w, h = r.choice([(320, 240), (640, 480), (800, 600), (1024, 768)])
    w, h = round(w * scale), round(h * scale)
    fmt = r.choice(["png", "png", "tiff", "exr", "jpeg", "png8"])
    flags = ["--model", model, "--width", str(w), "--height", str(h),
             "--wavelength-mm", "%.4f" % lam, "--amplitude-mm", "%.5f" % h0,
             "--phase-angle", "%.2f" % alpha,
             "--radius-px", "%.1f" % (w * r.uniform(0.25, 0.45)),
             "--center-x", "%.1f" % (w / 2 + r.uniform(-0.04, 0.04) * w)]
    if noisy:
        flags += ["--photons", "%.0f" % r.choice([300, 800, 1500, 3000]),
                  "--read-noise", "%.4f" % r.uniform(0.001, 0.01)]
    else:
        flags += ["--photons", "%.0f" % r.choice([3000, 10000, 20000, 50000])]
    flags += ["--source-blur-deg", "%.2f" % r.uniform(0.3, 1.5),
              "--exposure", "%.4f" % r.uniform(0.002, 0.012),
              "--seed", str(seed), "--format", fmt]
    distance = 0.0
    if r.random() < 0.3:
        flags += ["--diffuse", "%.3f" % r.uniform(0.02, 0.2)]
    if r.random() < 0.3:
        flags += ["--tilt-deg", "%.2f" % r.uniform(-0.7, 0.7)]
    if r.random() < 0.3 and lens_blur is None:
        flags += ["--optics-blur-px", "%.2f" % r.uniform(0.3, 1.2)]
    if lens_blur is not None:
        flags += ["--optics-blur-px", "%g" % lens_blur]
    if r.random() < 0.3:
        distance = round(r.uniform(500, 2000))
        flags += ["--distance-mm", "%.0f" % distance]
    if r.random() < 0.2:
        flags += ["--vignetting", "%.2f" % r.uniform(0.05, 0.3)]
    if lab:
        flags += lab_flags(seed, h, fmt in ("png", "tiff"))
    return flags, EXTENSIONS[fmt], alpha, distance


def outer_caustic_deg(seed, noisy, lens_blur):
    """|α|/2 + arctan m of seed's scene (orthographic); -1 for a smooth one."""
    flags, _, alpha, _ = scene_flags(seed, noisy, lens_blur)
    f = dict(zip(flags[::2], flags[1::2]))
    if f["--model"] == "smooth":
        return -1.0
    lam, h0 = float(f["--wavelength-mm"]), float(f["--amplitude-mm"])
    m = 2 * math.pi * h0 / lam if f["--model"] == "sinusoid" else 4 * h0 / lam
    return abs(alpha) / 2 + math.degrees(math.atan(m))


def check(seed, out_dir, noisy, lens_blur, mode, lab=False, scale=1.0):
    """(seed, verdict line, render flags)."""
    flags, ext, alpha, distance = scene_flags(seed, noisy, lens_blur, lab, scale)
    image = os.path.join(out_dir, "s%d.%s" % (seed, ext))
    p = subprocess.run([WEAVEFIT, "render", "--out", image] + flags,
                       capture_output=True, text=True)
    if p.returncode:
        return seed, "RENDER-FAILED " + p.stderr.strip()[:200], flags
    with open(os.path.splitext(image)[0] + ".json") as f:
        sidecar = json.load(f)
    truth = sidecar["truth"]
    diameter = sidecar["acquisition"]["cylinderDiameterMm"]
    p = subprocess.run([WEAVEFIT, "estimate", image, "--json", "--mode", mode,
                        "--phase-angle", "%.2f" % alpha, "--diameter-mm", "%g" % diameter,
                        "--distance-mm", "%g" % distance],
                       capture_output=True, text=True)
    try:
        est = json.loads(p.stdout)
    except ValueError:
        return seed, "ERROR (no reply) " + p.stderr.strip()[:200], flags
    if "error" in est:
        return seed, "ERROR " + est["error"]["message"][:160], flags
    notes = []
    bad = False
    if est["model"] != truth["model"] and not (
            truth["model"] != "SMOOTH" and not truth.get("splitResolvable", True)):
        notes.append("model %s for %s" % (est["model"], truth["model"]))
        bad = True
    for key, name, fmt in (("peakSpacingDeg", "spacing", "%.3f"),
                           ("wavelengthMm", "wavelength", "%.4f")):
        q = est.get(key, {})
        if truth["model"] == "SMOOTH":
            break
        if not q.get("resolved"):
            notes.append("%s unresolved" % name)
            continue
        z = (q["value"] - truth[key]) / max(q["stderr"], 1e-12)
        notes.append(("%s " + fmt + " for " + fmt + " (z %.1f)") % (name, q["value"], truth[key], z))
        bad = bad or abs(z) > 3
    if "cylinder" in est:
        notes.append("radius %+.2f px" % (est["cylinder"]["radiusPx"] - truth["radiusPx"]))
    return seed, ("BAD   " if bad else "ok    ") + "; ".join(notes), flags


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("first", type=int)
    parser.add_argument("last", type=int)
    parser.add_argument("--out", default="/tmp/weavefit_random_scenes")
    parser.add_argument("--noisy", action="store_true")
    parser.add_argument("--lens-blur", type=float, default=None)
    parser.add_argument("--mode", default="balanced")
    parser.add_argument("-j", "--jobs", type=int, default=2)
    parser.add_argument("--outer-caustic", type=float, nargs=2, metavar=("LO", "HI"),
                        help="only the split scenes whose outer caustic, |alpha|/2 + arctan m, "
                             "lies at LO-HI deg (the limb at 90)")
    parser.add_argument("--lab", action="store_true",
                        help="add lab-photograph conditions: stray light, axial glint lines, "
                             "background gradient, pedestal, ends and mount")
    parser.add_argument("--scale", type=float, default=1.0,
                        help="render each scene this many times larger in pixels (the frame, "
                             "the cylinder, the ends; not the lens blur): the same scenes at "
                             "other photograph sizes")
    args = parser.parse_args()
    if not os.access(WEAVEFIT, os.X_OK):
        sys.exit("build the client first: %s is missing" % WEAVEFIT)
    os.makedirs(args.out, exist_ok=True)
    seeds = list(range(args.first, args.last))
    if args.outer_caustic:
        seeds = [s for s in seeds
                 if args.outer_caustic[0] <= outer_caustic_deg(s, args.noisy, args.lens_blur)
                 <= args.outer_caustic[1]]
    counts = {"ok": 0, "BAD": 0, "ERROR": 0, "RENDER-FAILED": 0}
    with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
        runs = pool.map(lambda s: check(s, args.out, args.noisy, args.lens_blur, args.mode,
                                        args.lab, args.scale),
                        seeds)
        for seed, line, flags in runs:
            print(seed, line, flush=True)
            counts[line.split()[0]] += 1
            if not line.startswith("ok"):
                print("      ", " ".join(flags), flush=True)
    print("%d scenes: %d ok, %d wrong (BAD), %d refused (ERROR), %d not rendered"
          % (len(seeds), counts["ok"], counts["BAD"], counts["ERROR"],
             counts["RENDER-FAILED"]))
    return 1 if counts["BAD"] or counts["RENDER-FAILED"] else 0


if __name__ == "__main__":
    sys.exit(main())
