#!/usr/bin/env python3
"""Photographs from a renderer that shares no code with weavefit: rendered, estimated, checked.

Usage: scripts/independent_scenes.py [NAMES ...] [--out DIR] [-j JOBS]
                                     [--variants] [--mode MODE]

The renderer below was written from DESIGN.md §2-3 (../shared/design/DESIGN.md)
and Pont & Koenderink (2003) only, without reading estimator/ or render/, so
the photographs carry none of weavefit's own modelling choices. It renders
35 fixed scenes, s01-s35 (sinusoid, sawtooth and smooth cylinders; phase
angles -110 to 110 deg; 3.5-56 px per thread period; 320x240 to 800x600;
orthographic or perspective at 900-1000 mm; 2,000-50,000 photons full scale;
16-bit linear or 8-bit sRGB PNG), with --variants also 29 variants of them
with the warp's surface scattering weakened (*w, 0.04), removed (*n) or
spread evenly over each thread's lam/2 of arc (*s, a broad lobe); NAMES
picks scenes by name. Each is rendered into DIR (default
/tmp/weavefit_independent) as NAME.png with its truth, NAME.truth.json (the
scene's parameters under "params"; an image whose sidecar holds the same
parameters is not rendered again), estimated (`weavefit estimate --json`,
with the phase angle and camera distance the lab would state) and compared
with the truth. A line per scene:

  ok     the model right, and the spacing (2 arctan m) and wavelength, where
         resolved, within 3 stated errors
  BAD    a wrong model or a number beyond 3 stated errors: a wrong confident
         answer, the worst outcome (the scene's parameters follow on the next
         line). The truth does not judge whether a split is resolvable, so
         every wrong model is BAD
  ERROR  a refusal, with its message (a refusal is not wrong, but it may be
         needless)

and a count at the end. Not part of the test suite: some scenes lie beyond
what the estimator resolves (README, "Known limits"), and the renderer is
pure Python (1-5 s a scene, in -j processes: the main set in about 45 s on
two cores, a rerun over rendered images in about 10 s). Needs the built
client (build/client/weavefit); standard library only.

Physics (DESIGN conventions: camera on +y looking toward -y, image column
grows with world +x, cylinder axis = world z = image vertical, radius
R = 23 mm; light l = (sin a, cos a, 0), a the signed phase angle; view +y
(orthographic) or from (0, D, 0) (pinhole)):
- Weft threads run around the cylinder, pitch pz along the axis, each
  covering `fill` of it (the gaps show the warp). Thread j's height along the
  arc s = R phi is h(s + j lam/2 + jitter_j) (plain weave): sinusoid
  h = h0 sin(2 pi s/lam), slope m cos(2 pi s/lam), m = 2 pi h0/lam; sawtooth
  a triangle of amplitude h0 = m lam/4 whose slope is rounded at the corners,
  m tanh(K cos(2 pi s/lam))/tanh(K), K = 8. Facet normal azimuth phi + beta,
  beta = -arctan h'; across the thread the cross-section is round (radius rc).
- Specular term, exact geometric optics: a Gaussian source, std `blur` in
  normal space ((+) fibre roughness in quadrature); the normal's horizontal
  deviation dh from the half vector is integrated exactly (erf) between 8-16
  arc samples per pixel, weighted by the projected length, so sub-pixel
  glints do not alias. The cross-section integral is a glint band of length
  rc sqrt(2 pi) sn/cos(theta_i) at the crest, spread over rows by a Gaussian
  of std 0.12 pitch (fibre structure). Column means follow DESIGN §3,
  L ~ cos(a/2) p(beta*)/(cos phi cos beta*). Optionally the weft is hidden
  where the warp passes over it.
- Surface scattering: warp threads along the axis, lam/2 apart on the arc,
  diameter dw, each a small specular cylinder glinting in a vertical line
  where its normal is the half vector (energy ~ cos theta_i), seen in the
  gaps and where it passes over the weft; density ~ 1/cos phi, capped by
  masking/shadowing min(1, cos/0.12) near grazing. Its level at phi = a/2 is
  `scatter` times the comb's largest column mean.
- Smooth cylinder: a Gaussian microfacet lobe (std `rough`), radiance
  ~ D(dh)/cos theta_o (Torrance-Sparrow foreshortening).
- Lambertian term, ambient levels (thread and gap), background outside the
  silhouette, Gaussian optical PSF (0.6 px), Poisson-Gaussian noise, clip to
  [0, 1]; the specular gain puts the 99.9th percentile of the cylinder's
  pixels at `peak`.
Assumptions: no cast shadows or masking between weft undulations, no
inter-reflection, constant Fresnel factor, the relief (h << R) moves
positions only; the sawtooth's truth is the nominal h0 = m lam/4 (the rounded
corners lower it 2-3 %). Pixel c spans [c, c+1), so weavefit's centerXPx
reads 0.5 px below the truth's.
"""
import argparse
import concurrent.futures
import json
import math
import os
import random
import struct
import subprocess
import sys
import time
import zlib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
WEAVEFIT = os.path.join(ROOT, "build", "client", "weavefit")
R = 23.0  # cylinder radius, mm (weavefit's default diameter, 46 mm)

# The main set. Keys: model, m (max slope), lam (mm), alpha (phase angle, deg),
# W x H, Rpx (radius, px), seed, scatter, blur (source, deg), peak, and where
# set photons, rough (deg), lamb, D (mm), bg, occl, jitter (of lam), srgb8, cx.
MAIN = [
    {"name": "s01", "model": "sinusoid", "m": 0.2356, "lam": 2.88, "alpha": 10, "W": 640, "H": 480, "Rpx": 224.0, "seed": 761, "scatter": 0.15, "blur": 0.5, "peak": 0.6},
    {"name": "s02", "model": "sinusoid", "m": 0.2356, "lam": 2.88, "alpha": 60, "W": 640, "H": 480, "Rpx": 224.0, "seed": 467, "scatter": 0.15, "blur": 0.5, "peak": 0.6},
    {"name": "s03", "model": "sinusoid", "m": 0.2356, "lam": 2.88, "alpha": 110, "W": 640, "H": 480, "Rpx": 224.0, "seed": 587, "scatter": 0.15, "blur": 0.5, "peak": 0.6},
    {"name": "s04", "model": "sawtooth", "m": 0.15, "lam": 2.88, "alpha": 60, "W": 640, "H": 480, "Rpx": 224.0, "seed": 459, "scatter": 0.15, "blur": 0.5, "peak": 0.6},
    {"name": "s05", "model": "sinusoid", "m": 0.1, "lam": 1.0, "alpha": 30, "W": 400, "H": 300, "Rpx": 120.0, "seed": 668, "scatter": 0.15, "blur": 0.4, "peak": 0.5},
    {"name": "s06", "model": "sinusoid", "m": 0.6, "lam": 4.0, "alpha": 30, "W": 800, "H": 600, "Rpx": 320.0, "seed": 580, "scatter": 0.15, "blur": 0.8, "peak": 0.7, "photons": 50000},
    {"name": "s07", "model": "sawtooth", "m": 0.4, "lam": 3.0, "alpha": -60, "W": 640, "H": 480, "Rpx": 192.0, "seed": 682, "scatter": 0.15, "blur": 0.6, "peak": 0.5},
    {"name": "s08", "model": "sinusoid", "m": 0.35, "lam": 2.0, "alpha": -30, "W": 320, "H": 240, "Rpx": 128.0, "seed": 677, "scatter": 0.15, "blur": 0.7, "peak": 0.6},
    {"name": "s09", "model": "smooth", "m": 0, "lam": 0, "alpha": 60, "W": 400, "H": 300, "Rpx": 140.0, "seed": 493, "scatter": 0, "rough": 3.0, "peak": 0.7},
    {"name": "s10", "model": "smooth", "m": 0, "lam": 0, "alpha": -90, "W": 640, "H": 480, "Rpx": 192.0, "seed": 282, "scatter": 0, "rough": 5.0, "peak": 0.5, "lamb": 0.08},
    {"name": "s11", "model": "sinusoid", "m": 0.2, "lam": 1.5, "alpha": 90, "W": 640, "H": 480, "Rpx": 224.0, "seed": 798, "scatter": 0.15, "blur": 0.6, "peak": 0.5, "lamb": 0.1},
    {"name": "s12", "model": "sawtooth", "m": 0.25, "lam": 2.0, "alpha": 90, "W": 640, "H": 480, "Rpx": 224.0, "seed": 273, "scatter": 0.15, "blur": 0.6, "peak": 0.4, "photons": 2000},
    {"name": "s13", "model": "sinusoid", "m": 0.45, "lam": 3.5, "alpha": 10, "W": 640, "H": 480, "Rpx": 224.0, "seed": 928, "scatter": 0.15, "blur": 0.6, "peak": 0.6, "D": 900},
    {"name": "s14", "model": "sawtooth", "m": 0.3, "lam": 2.5, "alpha": -110, "W": 640, "H": 480, "Rpx": 256.0, "seed": 642, "scatter": 0.15, "blur": 0.7, "peak": 0.5},
    {"name": "s15", "model": "sinusoid", "m": 0.15, "lam": 1.2, "alpha": 60, "W": 800, "H": 600, "Rpx": 200.0, "seed": 997, "scatter": 0.15, "blur": 0.5, "peak": 0.6},
    {"name": "s16", "model": "sinusoid", "m": 0.5, "lam": 2.0, "alpha": -10, "W": 640, "H": 480, "Rpx": 224.0, "seed": 638, "scatter": 0.15, "blur": 0.8, "peak": 0.6, "srgb8": True},
    {"name": "s17", "model": "sawtooth", "m": 0.2, "lam": 1.0, "alpha": 30, "W": 320, "H": 240, "Rpx": 96.0, "seed": 438, "scatter": 0.15, "blur": 0.6, "peak": 0.5},
    {"name": "s18", "model": "sinusoid", "m": 0.3, "lam": 2.5, "alpha": 60, "W": 640, "H": 480, "Rpx": 224.0, "seed": 117, "scatter": 0.15, "blur": 0.6, "peak": 0.6, "occl": True},
    {"name": "s19", "model": "sawtooth", "m": 0.35, "lam": 3.0, "alpha": 60, "W": 640, "H": 480, "Rpx": 224.0, "seed": 320, "scatter": 0.15, "blur": 0.6, "peak": 0.6, "occl": True, "jitter": 0.05},
    {"name": "s20", "model": "sinusoid", "m": 0.12, "lam": 2.0, "alpha": -60, "W": 640, "H": 480, "Rpx": 224.0, "seed": 705, "scatter": 0.15, "blur": 1.5, "peak": 0.6},
    {"name": "s21", "model": "sawtooth", "m": 0.1, "lam": 2.0, "alpha": 10, "W": 640, "H": 480, "Rpx": 224.0, "seed": 377, "scatter": 0.15, "blur": 0.3, "peak": 0.6},
    {"name": "s22", "model": "sinusoid", "m": 0.28, "lam": 3.0, "alpha": 110, "W": 640, "H": 480, "Rpx": 224.0, "seed": 352, "scatter": 0.15, "blur": 0.6, "peak": 0.7, "D": 1000, "bg": 0.3},
    {"name": "s23", "model": "smooth", "m": 0, "lam": 0, "alpha": 10, "W": 640, "H": 480, "Rpx": 224.0, "seed": 924, "scatter": 0, "rough": 2.0, "peak": 0.7, "D": 900},
    {"name": "s24", "model": "smooth", "m": 0, "lam": 0, "alpha": 110, "W": 400, "H": 300, "Rpx": 160.0, "seed": 55, "scatter": 0, "rough": 4.0, "peak": 0.6, "srgb8": True},
    {"name": "s25", "model": "sinusoid", "m": 0.4, "lam": 1.5, "alpha": -90, "W": 640, "H": 480, "Rpx": 224.0, "seed": 933, "scatter": 0.15, "blur": 0.7, "peak": 0.4, "photons": 3000, "lamb": 0.08},
    {"name": "s26", "model": "sawtooth", "m": 0.55, "lam": 4.0, "alpha": 30, "W": 800, "H": 600, "Rpx": 320.0, "seed": 858, "scatter": 0.15, "blur": 0.8, "peak": 0.7},
    {"name": "s27", "model": "sinusoid", "m": 0.2, "lam": 4.0, "alpha": -30, "W": 640, "H": 480, "Rpx": 192.0, "seed": 957, "scatter": 0.15, "blur": 0.6, "peak": 0.6, "cx": 268.8},
    {"name": "s28", "model": "sawtooth", "m": 0.18, "lam": 1.5, "alpha": -10, "W": 640, "H": 480, "Rpx": 224.0, "seed": 61, "scatter": 0.15, "blur": 0.6, "peak": 0.6, "lamb": 0.15},
    {"name": "s29", "model": "sinusoid", "m": 0.33, "lam": 2.2, "alpha": 30, "W": 640, "H": 480, "Rpx": 224.0, "seed": 719, "scatter": 0.15, "blur": 0.6, "peak": 0.6, "jitter": 0.08, "rough": 1.0},
    {"name": "s30", "model": "sawtooth", "m": 0.45, "lam": 2.0, "alpha": -60, "W": 640, "H": 480, "Rpx": 224.0, "seed": 426, "scatter": 0.15, "blur": 0.7, "peak": 0.5, "D": 900, "photons": 4000},
    {"name": "s31", "model": "smooth", "m": 0, "lam": 0, "alpha": -30, "W": 640, "H": 480, "Rpx": 224.0, "seed": 199, "scatter": 0, "rough": 6.0, "peak": 0.5, "lamb": 0.1, "bg": 0.25},
    {"name": "s32", "model": "sinusoid", "m": 0.6, "lam": 1.0, "alpha": 60, "W": 640, "H": 480, "Rpx": 192.0, "seed": 896, "scatter": 0.15, "blur": 0.6, "peak": 0.6},
    {"name": "s33", "model": "sinusoid", "m": 0.25, "lam": 1.0, "alpha": 30, "W": 320, "H": 240, "Rpx": 96.0, "seed": 33, "scatter": 0.15, "blur": 0.6, "peak": 0.6},
    {"name": "s34", "model": "sawtooth", "m": 0.3, "lam": 1.2, "alpha": -60, "W": 400, "H": 300, "Rpx": 100.0, "seed": 34, "scatter": 0.15, "blur": 0.6, "peak": 0.6},
    {"name": "s35", "model": "sinusoid", "m": 0.35, "lam": 1.0, "alpha": 60, "W": 320, "H": 240, "Rpx": 80.0, "seed": 35, "scatter": 0.1, "blur": 0.6, "peak": 0.6, "photons": 5000},
]

# Variants: a main scene again with its surface scattering weakened (w),
# removed (n), or smoothed (s: each axial thread's light spread evenly over
# its lam/2 of arc, the broad lobe of DESIGN.md §3 rather than lines).
VARIANT_SCATTER = {"n": 0, "w": 0.04}
VARIANTS = ["s01n", "s05n", "s33n", "s02w", "s03w", "s04w", "s07w", "s11w", "s12w",
            "s15w", "s18w", "s20w", "s22w", "s30w",
            "s01s", "s02s", "s03s", "s04s", "s07s", "s11s", "s12s", "s14s", "s19s",
            "s21s", "s22s", "s25s", "s26s", "s28s", "s30s"]


def scenes(with_variants):
    """The main scenes, and with_variants also the variants, in order."""
    out = list(MAIN)
    if with_variants:
        base = {sc["name"]: sc for sc in MAIN}
        for v in VARIANTS:
            if v[-1] == "s":
                out.append(dict(base[v[:-1]], name=v, smooth_scatter=True))
            else:
                out.append(dict(base[v[:-1]], name=v, scatter=VARIANT_SCATTER[v[-1]]))
    return out


# ---------------------------------------------------------------- renderer

def write_png(path, img, W, H, bits16=True, srgb=False):
    """Greyscale PNG: 16-bit linear, or 8-bit (sRGB-encoded if srgb), filter 0."""
    raw = bytearray()
    for r in range(H):
        raw.append(0)
        row = img[r]
        if bits16:
            for v in row:
                raw += struct.pack(">H", int(round(min(1.0, max(0.0, v)) * 65535)))
        else:
            for v in row:
                v = min(1.0, max(0.0, v))
                if srgb:
                    v = 12.92 * v if v <= 0.0031308 else 1.055 * v ** (1 / 2.4) - 0.055
                raw.append(int(round(v * 255)))

    def chunk(kind, data):
        c = struct.pack(">I", len(data)) + kind + data
        return c + struct.pack(">I", zlib.crc32(kind + data) & 0xffffffff)
    out = b"\x89PNG\r\n\x1a\n"
    out += chunk(b"IHDR", struct.pack(">IIBBBBB", W, H, 16 if bits16 else 8, 0, 0, 0, 0))
    if srgb:
        out += chunk(b"sRGB", b"\x00")
    out += chunk(b"IDAT", zlib.compress(bytes(raw), 6))
    out += chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(out)


def gblur(img, W, H, sigma):
    """Separable Gaussian blur (std sigma px), edges clamped."""
    if sigma <= 0:
        return img
    rad = max(1, int(math.ceil(3 * sigma)))
    ker = [math.exp(-i * i / (2 * sigma * sigma)) for i in range(-rad, rad + 1)]
    sk = sum(ker)
    ker = [k / sk for k in ker]
    tmp = []
    for r in range(H):
        row = img[r]
        out = [0.0] * W
        for c in range(W):
            acc = 0.0
            for i, k in enumerate(ker):
                cc = c + i - rad
                cc = 0 if cc < 0 else (W - 1 if cc >= W else cc)
                acc += k * row[cc]
            out[c] = acc
        tmp.append(out)
    res = [[0.0] * W for _ in range(H)]
    for c in range(W):
        col = [tmp[r][c] for r in range(H)]
        for r in range(H):
            acc = 0.0
            for i, k in enumerate(ker):
                rr = r + i - rad
                rr = 0 if rr < 0 else (H - 1 if rr >= H else rr)
                acc += k * col[rr]
            res[r][c] = acc
    return res


def gauss_int(a, b, L, sig):
    """The integral over t in [0, L] of exp(-(a + b t)^2 / (2 sig^2))."""
    e0 = a
    e1 = a + b * L
    if abs(b * L) < 1e-4 * sig:
        em = a + 0.5 * b * L
        return L * math.exp(-em * em / (2 * sig * sig))
    c = 1.0 / (sig * math.sqrt(2.0))
    return (math.erf(e1 * c) - math.erf(e0 * c)) / (b * c) * math.sqrt(math.pi) / 2.0


def render(sc, outdir):
    """Render scene sc into outdir as NAME.png and NAME.truth.json; return the truth."""
    rnd = random.Random(sc.get("seed", 1))
    W, H = sc["W"], sc["H"]
    Rpx = sc["Rpx"]
    k = Rpx / R                    # px per mm at the axis
    cx = sc.get("cx", W / 2.0)
    cy = H / 2.0
    D = sc.get("D", 0.0)
    a = math.radians(sc["alpha"])
    lx, ly = math.sin(a), math.cos(a)
    model = sc["model"]
    m = sc.get("m", 0.0)
    lam = sc.get("lam") or 2.0
    kk = 2 * math.pi / lam
    sn = math.radians(sc.get("blur", 0.6))          # source blur in normal space (std)
    sn = math.sqrt(sn * sn + math.radians(sc.get("rough", 0.0)) ** 2)
    pz = sc.get("pz", lam / 2.0)
    fill = sc.get("fill", 0.85)
    rc = sc.get("rc", 0.5 * pz)
    sz = sc.get("sz", 0.12 * pz)
    nsub = sc.get("nsub", 10)
    phlim = math.acos(R / D) if D > 0 else math.pi / 2
    Ksaw = sc.get("Ksaw", 8.0)
    h0 = m / kk if model == "sinusoid" else m * lam / 4.0
    jit = sc.get("jitter", 0.0)

    def project(P):
        """(column, row, unit view vector toward the camera, px per mm) of point P."""
        x, y, z = P
        if D > 0:
            scl = k * D / (D - y)
            vx, vy, vz = -x, D - y, -z
            n = math.sqrt(vx * vx + vy * vy + vz * vz)
            return cx + scl * x, cy - scl * z, (vx / n, vy / n, vz / n), scl
        return cx + k * x, cy - k * z, (0.0, 1.0, 0.0), k

    def slope(t):
        c = math.cos(kk * t)
        if model == "sinusoid":
            return m * c
        return m * math.tanh(Ksaw * c) / math.tanh(Ksaw)

    def height(t):
        if model == "sinusoid":
            return h0 * math.sin(kk * t)
        f = (t / lam + 0.25) % 1.0        # triangle: -h0 at s = -lam/4, +h0 at lam/4
        return h0 * (4 * f - 1 if f < 0.5 else 3 - 4 * f)

    spec = [[0.0] * W for _ in range(H)]

    def deposit(buf, u, rowc, e, sigr):
        """Add energy e at column u (linear split), rows Gaussian (std sigr) about rowc."""
        if e <= 0:
            return
        c0 = int(math.floor(u - 0.5))
        fc = (u - 0.5) - c0
        r0 = int(math.floor(rowc - 3 * sigr - 0.5))
        r1 = int(math.ceil(rowc + 3 * sigr + 0.5))
        ws = []
        for r in range(r0, r1 + 1):
            ws.append((r, math.exp(-((r + 0.5 - rowc) ** 2) / (2 * sigr * sigr))))
        tw = sum(w for _, w in ws)
        for r, w in ws:
            if 0 <= r < H:
                ww = e * w / tw
                if 0 <= c0 < W:
                    buf[r][c0] += ww * (1 - fc)
                if 0 <= c0 + 1 < W:
                    buf[r][c0 + 1] += ww * fc

    # ---- weft (circumferential) threads: the specular comb
    zhalf = (H / 2.0 + 4) / k * (1.03 if D > 0 else 1.0)
    z0 = rnd.uniform(0, pz)
    jmin = int(math.floor((-zhalf - z0) / pz)) - 1
    jmax = int(math.ceil((zhalf - z0) / pz)) + 1
    if model in ("sinusoid", "sawtooth"):
        ds = 1.0 / k / nsub
        ns = int(2 * R * phlim / ds)
        for j in range(jmin, jmax + 1):
            zj = z0 + j * pz
            sh = (j % 2) * lam / 2.0 + (rnd.gauss(0, jit * lam) if jit > 0 else 0.0)
            prev = None
            for i in range(ns + 1):
                s = -R * phlim + i * ds
                t = s + sh
                phi = s / R
                beta = -math.atan(slope(t))
                rr = R + height(t)
                u, rowc, v, scl = project((rr * math.sin(phi), rr * math.cos(phi), zj))
                Hx, Hy, Hz = v[0] + lx, v[1] + ly, v[2]
                Hn = math.sqrt(Hx * Hx + Hy * Hy + Hz * Hz)
                psi = math.atan2(Hx, Hy)
                costh = Hn / 2.0
                dh = phi + beta - psi
                vis = (math.sin(phi) * v[0] + math.cos(phi) * v[1]) > 0
                occl = False
                if sc.get("occl"):
                    dw = sc.get("dw", 0.35 * lam / 2)
                    f = ((t - 0.75 * lam) / lam + 0.5) % 1.0 - 0.5
                    occl = abs(f * lam) < dw / 2
                cur = (s, dh, u, rowc, costh, scl, vis and not occl)
                if prev is not None and prev[6] and cur[6]:
                    a0, a1 = prev[1], cur[1]
                    if not ((a0 > 6 * sn and a1 > 6 * sn) or (a0 < -6 * sn and a1 < -6 * sn)):
                        gi = gauss_int(a0, (a1 - a0) / ds, ds, sn)
                        dudx = abs(cur[2] - prev[2]) / ds      # px per mm of arc
                        band = rc * math.sqrt(2 * math.pi) * sn / (0.5 * (cur[4] + prev[4]))
                        e = gi * dudx * band * 0.5 * (cur[5] + prev[5])
                        deposit(spec, 0.5 * (cur[2] + prev[2]), 0.5 * (cur[3] + prev[3]),
                                e, max(0.3, sz * scl))
                prev = cur

    # ---- warp (axial) threads: surface scattering lines
    scat = [[0.0] * W for _ in range(H)]
    if model in ("sinusoid", "sawtooth") and sc.get("scatter", 0) > 0:
        dw = sc.get("dw", 0.35 * lam / 2)
        amin = int(math.floor((-R * phlim - lam / 4) / (lam / 2))) - 1
        amax = -amin + 1
        for ai in range(amin, amax + 1):
            sa = lam / 4 + ai * lam / 2
            pha = sa / R
            if abs(pha) >= phlim:
                continue
            if math.cos(pha - a) <= 0:
                continue
            # the warp's centre, its top at R (the silhouette); the glint point
            # on its cross-section is where the normal is the half vector
            Pc = ((R - dw / 2) * math.sin(pha), (R - dw / 2) * math.cos(pha), 0.0)
            _, _, v, scl = project(Pc)
            Hx, Hy = v[0] + lx, v[1] + ly
            psi = math.atan2(Hx, Hy)
            costh = math.sqrt(Hx * Hx + Hy * Hy) / 2.0
            Pg = (Pc[0] + dw / 2 * math.sin(psi), Pc[1] + dw / 2 * math.cos(psi), 0.0)
            u, _, v, scl = project(Pg)
            mu = math.sin(pha) * v[0] + math.cos(pha) * v[1]
            if mu <= 0:
                continue
            G = min(1.0, mu / 0.12) * min(1.0, math.cos(pha - a) / 0.12)
            e_row = costh * (dw / 2) * math.sqrt(2 * math.pi) * sn * scl * G
            # rows: seen in the gaps and where this warp passes over the weft
            yg = Pg[1]
            zs = (D - yg) / (k * D) if D > 0 else 1.0 / k
            c0 = int(math.floor(u - 0.5))
            fc = (u - 0.5) - c0
            for r in range(H):
                vis = 0.0
                for sub in (0.25, 0.75):
                    z = (cy - (r + sub)) * zs
                    j = int(math.floor((z - z0) / pz + 0.5))
                    off = z - (z0 + j * pz)
                    if abs(off) > fill * pz / 2 or (ai + j) % 2 == 1:
                        vis += 0.5
                if vis > 0:
                    e = e_row * vis
                    if 0 <= c0 < W:
                        scat[r][c0] += e * (1 - fc)
                    if 0 <= c0 + 1 < W:
                        scat[r][c0 + 1] += e * fc

        if sc.get("smooth_scatter"):
            # each axial thread's light spread over its lam/2 of arc (a box
            # of that width in columns, orthographic foreshortening)
            widths = []
            for c in range(W):
                x = (c + 0.5 - cx) / k
                cphi = math.sqrt(max(0.0, 1.0 - (x / R) ** 2)) if abs(x) < R else 0.0
                widths.append(max(1, int(round(lam / 2 * k * cphi))))
            for r in range(H):
                row = scat[r]
                pre = [0.0]
                for val in row:
                    pre.append(pre[-1] + val)
                new_row = [0.0] * W
                for c in range(W):
                    w = widths[c]
                    lo_c = max(0, c - w // 2)
                    hi_c = min(W, lo_c + w)
                    new_row[c] = (pre[hi_c] - pre[lo_c]) / w
                scat[r] = new_row

    # ---- per-pixel body terms (4 sub-columns, 2 sub-rows a pixel)
    body = [[0.0] * W for _ in range(H)]
    cov = [0.0] * W
    glossy = [[0.0] * W for _ in range(H)] if model == "smooth" else None
    A_t, A_g = sc.get("amb", 0.03), sc.get("amb_gap", sc.get("amb", 0.03) * 0.6)
    bg = sc.get("bg", 0.01)
    colinfo = []
    NS = 4
    for c in range(W):
        subs = []
        for q in range(NS):
            uu = c + (q + 0.5) / NS
            X = uu - cx
            if D > 0:
                aa = X / (k * D)
                disc = D * D - (1 + aa * aa) * (D * D - R * R)
                if disc < 0:
                    subs.append(None)
                    continue
                t = (D - math.sqrt(disc)) / (1 + aa * aa)
                x, y = t * aa, D - t
                phi = math.atan2(x, y)
                zs = (D - y) / (k * D)
                vx, vy = -x, D - y
                vn = math.hypot(vx, vy)
                psi = math.atan2(vx / vn + lx, vy / vn + ly)
                mu = (math.sin(phi) * vx + math.cos(phi) * vy) / vn
            else:
                x = X / k
                if abs(x) >= R:
                    subs.append(None)
                    continue
                phi = math.asin(x / R)
                zs = 1.0 / k
                psi = a / 2
                mu = math.cos(phi)
            subs.append((phi, zs, psi, mu))
        colinfo.append(subs)
        cov[c] = sum(1 for s_ in subs if s_ is not None) / NS
    lamb = sc.get("lamb", 0.0)
    for c in range(W):
        subs = colinfo[c]
        for r in range(H):
            acc = 0.0
            gl = 0.0
            for s_ in subs:
                if s_ is None:
                    acc += bg
                    continue
                phi, zs, psi, mu = s_
                for sub in (0.25, 0.75):
                    z = (cy - (r + sub)) * zs
                    j = int(math.floor((z - z0) / pz + 0.5))
                    off = z - (z0 + j * pz)
                    inthr = abs(off) <= fill * pz / 2 or model == "smooth"
                    val = A_t if inthr else A_g
                    if inthr and lamb > 0:
                        val += lamb * max(0.0, math.cos(phi - a))
                    acc += 0.5 * val
                    if glossy is not None:
                        dd = phi - psi
                        gl += 0.5 * math.exp(-dd * dd / (2 * sn * sn)) / max(mu, 0.02)
            body[r][c] = acc / NS
            if glossy is not None:
                glossy[r][c] = gl / NS
    if glossy is not None:
        spec = glossy

    # ---- levels: the specular gain puts the pct percentile of the cylinder's
    # pixels at peak; the scatter is scaled at phi = a/2 against the column means
    vals = sorted(v for row in spec for v in row if v > 0)
    target = sc.get("peak", 0.6)
    pct = sc.get("pct", 0.999)
    ncyl = int(sum(cov) * H)
    idx = max(0, len(vals) - max(1, int((1 - pct) * ncyl)))
    ref = vals[idx] if vals else 1.0
    gain = target / ref
    colmean = [sum(spec[r][c] for r in range(H)) / H * gain for c in range(W)]
    pcol = max(colmean)
    if sc.get("scatter", 0) > 0:
        cc = int(cx + Rpx * math.sin(a / 2))
        hw = max(3, int(0.1 * Rpx))
        sm = sum(scat[r][c] for r in range(H) for c in range(cc - hw, cc + hw + 1)) / ((2 * hw + 1) * H)
        sg = sc["scatter"] * pcol / sm if sm > 0 else 0.0
    else:
        sg = 0.0
    img = [[body[r][c] + gain * spec[r][c] + sg * scat[r][c] for c in range(W)] for r in range(H)]
    img = gblur(img, W, H, sc.get("psf", 0.6))

    # ---- noise: Poisson (Gaussian above 40 photons) plus read noise, clipped
    nfs = sc.get("photons", 20000)
    rn = sc.get("read", 0.002)
    for r in range(H):
        row = img[r]
        for c in range(W):
            v = max(0.0, row[c])
            lamp = v * nfs
            if lamp > 40:
                cnt = rnd.gauss(lamp, math.sqrt(lamp))
            else:
                L_ = math.exp(-lamp)
                cnt, p = 0, 1.0
                while True:
                    p *= rnd.random()
                    if p <= L_:
                        break
                    cnt += 1
            row[c] = min(1.0, max(0.0, cnt / nfs + rnd.gauss(0, rn)))

    name = sc["name"]
    bits16 = not sc.get("srgb8", False)
    png = os.path.join(outdir, name + ".png")
    write_png(png + ".part", img, W, H, bits16=bits16, srgb=not bits16)
    os.replace(png + ".part", png)
    spacing = 2 * math.degrees(math.atan(m)) if model != "smooth" else 0.0
    Rapp = Rpx * D / math.sqrt(D * D - R * R) if D > 0 else Rpx
    truth = dict(name=name, model=model.upper(), maxSlope=m, peakSpacingDeg=spacing,
                 wavelengthMm=lam if model != "smooth" else None,
                 amplitudeMm=h0 if model != "smooth" else None,
                 phaseAngleDeg=sc["alpha"], radiusPx=Rapp, centerXPx=cx,
                 distanceMm=D, pxPerPeriod=lam * Rpx / R if model != "smooth" else None,
                 params=sc, colPeak=pcol,
                 clippedFrac=sum(1 for row in img for v in row if v >= 1.0) / (W * H))
    with open(os.path.join(outdir, name + ".truth.json.part"), "w") as f:
        json.dump(truth, f, indent=1)
    os.replace(os.path.join(outdir, name + ".truth.json.part"),
               os.path.join(outdir, name + ".truth.json"))
    return truth


# ---------------------------------------------------------------- driver

def rendered(sc, outdir):
    """The truth of sc's image in outdir if it was rendered from these parameters, else None."""
    png = os.path.join(outdir, sc["name"] + ".png")
    try:
        with open(os.path.join(outdir, sc["name"] + ".truth.json")) as f:
            truth = json.load(f)
    except (OSError, ValueError):
        return None
    return truth if os.path.exists(png) and truth.get("params") == sc else None


def check(sc, outdir, mode):
    """(verdict line, seconds spent rendering) for scene sc."""
    t0 = time.time()
    truth = rendered(sc, outdir) or render(sc, outdir)
    seconds = time.time() - t0
    image = os.path.join(outdir, sc["name"] + ".png")
    cmd = [WEAVEFIT, "estimate", image, "--json", "--phase-angle", "%g" % sc["alpha"],
           "--diameter-mm", "%g" % (2.0 * R)]
    if truth["distanceMm"] > 0:
        cmd += ["--distance-mm", "%g" % truth["distanceMm"]]
    p = subprocess.run(cmd + ["--mode", mode], capture_output=True, text=True)
    try:
        est = json.loads(p.stdout)
    except ValueError:
        return "ERROR (no reply) " + p.stderr.strip()[:200], seconds
    if "error" in est:
        return "ERROR " + est["error"]["message"][:160], seconds
    notes = []
    bad = False
    if est["model"] != truth["model"]:
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
    return ("BAD   " if bad else "ok    ") + "; ".join(notes), seconds


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("names", nargs="*", metavar="NAMES")
    parser.add_argument("--out", default="/tmp/weavefit_independent")
    parser.add_argument("--variants", action="store_true")
    parser.add_argument("--mode", default="balanced")
    parser.add_argument("-j", "--jobs", type=int, default=2)
    args = parser.parse_args()
    if not os.access(WEAVEFIT, os.X_OK):
        sys.exit("build the client first: %s is missing" % WEAVEFIT)
    todo = scenes(True) if args.names else scenes(args.variants)
    if args.names:
        unknown = set(args.names) - {sc["name"] for sc in todo}
        if unknown:
            sys.exit("no such scene: %s" % " ".join(sorted(unknown)))
        todo = [sc for sc in todo if sc["name"] in args.names]
    os.makedirs(args.out, exist_ok=True)
    counts = {"ok": 0, "BAD": 0, "ERROR": 0}
    with concurrent.futures.ProcessPoolExecutor(args.jobs) as pool:
        runs = pool.map(check, todo, [args.out] * len(todo), [args.mode] * len(todo))
        for sc, (line, _) in zip(todo, runs):
            print("%-5s" % sc["name"], line, flush=True)
            counts[line.split()[0]] += 1
            if not line.startswith("ok"):
                print("      ", json.dumps({k: v for k, v in sc.items() if k != "name"}),
                      flush=True)
    print("%d scenes: %d ok, %d wrong (BAD), %d refused (ERROR)"
          % (len(todo), counts["ok"], counts["BAD"], counts["ERROR"]))
    return 1 if counts["BAD"] else 0


if __name__ == "__main__":
    sys.exit(main())
